"""Synthetic demonstrations (preprocessed trajectories + task programs) for the robot tests."""

from __future__ import annotations

import numpy as np
from lfd.demo import (
    INDEX_MCP,
    INDEX_TIP,
    THUMB_TIP,
    Demonstration,
    HandTrack,
    ObjectTrack,
    SkillLabel,
)
from lfd.reproduce.ik import gripper_rotation
from lfd.reproduce.program import Segment, TaskProgram
from lfd.trajectory import Trajectory

RATE = 30.0


def _seg(a: np.ndarray, b: np.ndarray, dur: float, arc: float = 0.0) -> np.ndarray:
    n = max(2, round(dur * RATE))
    s = np.linspace(0, 1, n)
    s = 10 * s**3 - 15 * s**4 + 6 * s**5
    p = a + s[:, None] * (b - a)
    p[:, 2] += arc * np.sin(np.pi * s)
    return p[1:]


def synthetic_demo(kind: str = "pick_place") -> tuple[Trajectory, TaskProgram]:
    """A clean demo: ``pick_place`` (box_1 A -> B), ``stack`` (box_1 onto box_2) or ``push``."""
    size = np.array([[0.05, 0.05, 0.05], [0.05, 0.05, 0.05]])
    A = np.array([0.10, 0.10, 0.025])
    B = np.array([0.02, -0.12, 0.025])
    C = np.array([0.16, -0.10, 0.025])  # box_2
    up = np.array([0.0, 0.0, 0.12])
    if kind == "stack":
        B = C + np.array([0.0, 0.0, 0.05])
    keys: list[tuple[str, np.ndarray, float, float]] = []  # (skill, target, duration, arc)
    start = A + up + np.array([-0.05, 0.03, 0.03])
    if kind == "push":
        u = np.array([1.0, 0.0, 0.0])
        behind = A - u * 0.045 + np.array([0.0, 0.0, -0.005])
        keys = [
            ("move", behind + np.array([0, 0, 0.0]), 1.6, 0.06),
            ("push", behind + u * 0.08, 1.6, 0.0),
            ("move", behind + u * 0.08 + up, 1.0, 0.0),
        ]
    else:
        keys = [
            ("pick_up", A, 1.5, 0.0),
            ("move_with", B + up, 1.6, 0.05),
            ("place" if kind == "pick_place" else "stack", B, 1.2, 0.0),
            ("move", B + up + np.array([0.04, 0.02, 0.02]), 1.0, 0.0),
        ]
    pts = [start[None]]
    segs = []
    t = 0.0
    cur = start
    for skill, target, dur, arc in keys:
        p = _seg(cur, target, dur, arc)
        # a human wobble on the moves, removed by the skills mode
        if skill.startswith("move"):
            p[:, 1] += 0.05 * np.sin(np.linspace(0, np.pi, len(p)))
            p[-1] = target
        pts.append(p)
        segs.append(Segment(skill, t, t + len(p) / RATE, "box_1" if skill != "move" else None))
        t += len(p) / RATE
        cur = target
    tcp = np.concatenate(pts)
    n = len(tcp)
    t_s = np.arange(n) / RATE
    opening = np.full(n, 0.085)
    obj = np.zeros((2, n, 3))
    obj[0] = A
    obj[1] = C
    if kind == "push":
        i0 = round(segs[1].start_s * RATE)
        i1 = round(segs[1].end_s * RATE)
        for i in range(i0, n):
            contact = tcp[min(i, i1), 0] + 0.045
            obj[0, i, 0] = max(A[0], contact)
        opening[:] = 0.03
    else:
        i0 = round(segs[0].end_s * RATE)
        i1 = round(segs[2].end_s * RATE)
        obj[0, i0:i1] = tcp[i0:i1]
        obj[0, i1:] = B
        opening[i0:i1] = 0.065
    yaw = np.full(n, np.pi / 2 + 0.2)
    rot = np.stack([gripper_rotation(y) for y in yaw])
    quat = np.zeros((2, n, 4))
    quat[..., 3] = 1.0
    traj = Trajectory(
        t_ns=(t_s * 1e9).astype(np.int64) + 1_000_000_000,
        tcp=tcp,
        rotation=rot,
        euler=np.zeros((n, 3)),
        opening=opening,
        keypoints=np.zeros((n, 21, 3)),
        object_names=["box_1", "box_2"],
        object_position=obj,
        object_quaternion=quat,
        object_size=size,
        hand_valid=np.ones(n, bool),
        object_valid=np.ones((2, n), bool),
    )
    return traj, TaskProgram(segs)


def synthetic_recording(kind: str = "pick_place") -> Demonstration:
    """The synthetic demo as a raw :class:`Demonstration` (hand keypoints, objects, labels)."""
    traj, program = synthetic_demo(kind)
    n = len(traj)
    kp = np.zeros((n, 21, 3))
    y_axis = traj.rotation[:, :, 1]
    z_axis = traj.rotation[:, :, 2]
    base = traj.tcp - 0.09 * z_axis
    kp[:] = base[:, None, :] - 0.03 * z_axis[:, None, :]
    kp[:, INDEX_MCP] = base
    kp[:, INDEX_TIP] = traj.tcp + 0.5 * traj.opening[:, None] * y_axis
    kp[:, THUMB_TIP] = traj.tcp - 0.5 * traj.opening[:, None] * y_axis
    hand = HandTrack(traj.t_ns, kp, np.ones((n, 21)))
    objects = {
        name: ObjectTrack(
            name,
            k + 1,
            traj.object_size[k],
            traj.t_ns,
            traj.object_position[k],
            traj.object_quaternion[k],
            np.ones(n, bool),
        )
        for k, name in enumerate(traj.object_names)
    }
    t0 = int(traj.t_ns[0])
    labels = [
        SkillLabel(s.skill, t0 + round(s.start_s * 1e9), t0 + round(s.end_s * 1e9), s.object)
        for s in program.segments
    ]
    return Demonstration(hand=hand, objects=objects, labels=labels, metadata={"task": kind})
