"""Where the two arms' bases go (:mod:`.two_arms`): each on its side of the work, clear of the
objects, both hands' paths and the other base, reaching all of its lane top-down
(:func:`choose_bases`), and turned towards its lane (:func:`mount_yaw`, :func:`mounted`)."""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from ..errors import DemonstrationError
from .aloha import TwoArmRobot
from .arm import Robot
from .program import HandsProgram, TaskProgram

BASE_GAP = 0.4
"""Smallest distance between the two bases (m)."""


def choose_bases(
    points: dict[str, np.ndarray],
    objects: np.ndarray,
    robot: TwoArmRobot,
    *,
    level: float = np.inf,
) -> dict[str, np.ndarray]:
    """Each arm's base (z = 0): every TCP point of its lane reachable top-down (the widest
    reach margin), the right arm's base right of the workspace centre, the left's left of it,
    both at most ``level`` (m) before or behind it (along y).

    Raises
    ------
    DemonstrationError
        No base reaches all of a lane's points (one line naming the arm).
    """
    arm = robot.ik
    every = np.concatenate([p for p in points.values()])
    every = every[np.all(np.isfinite(every), axis=1)]
    centre = every[:, :2].mean(axis=0)
    lo, hi = every[:, :2].min(axis=0) - 0.7, every[:, :2].max(axis=0) + 0.7
    gx, gy = np.meshgrid(np.arange(lo[0], hi[0], 0.02), np.arange(lo[1], hi[1], 0.02))
    cand = np.stack([gx.ravel(), gy.ravel()], axis=1)
    clear = _clear(cand, every[:, :2], 0.2) & _clear(cand, np.asarray(objects)[:, :2], 0.14)
    out: dict[str, np.ndarray] = {}
    for side in sorted(points, key=lambda s: s != "right"):
        pts = points[side][np.all(np.isfinite(points[side]), axis=1)]
        if len(pts) > 300:
            pts = pts[np.linspace(0, len(pts) - 1, 300).astype(int)]
        wrist = pts + np.array([0.0, 0.0, arm.tcp_offset])
        sign = 1.0 if side == "right" else -1.0
        ok = clear & (sign * (cand[:, 0] - centre[0]) > 0.05)
        ok &= np.abs(cand[:, 1] - centre[1]) <= level
        for b in out.values():
            ok &= np.linalg.norm(cand - b[:2], axis=1) >= BASE_GAP
        d = np.sqrt(
            np.sum((wrist[None, :, :2] - cand[ok, None, :]) ** 2, axis=2)
            + (wrist[None, :, 2] - arm.shoulder_z) ** 2
        )
        score = np.full(len(cand), -np.inf)
        score[ok] = np.minimum(d - arm.reach[0], arm.reach[1] - d).min(axis=1)
        best = int(np.argmax(score))
        if not np.isfinite(score[best]):
            raise DemonstrationError(
                f"the {side} arm ({arm.title}) has no base on the {side} side clear of the "
                "objects, both hands' paths and the other arm"
            )
        if score[best] < 0:
            raise DemonstrationError(
                f"the {side} arm ({arm.title}) cannot reach all of the {side} hand's path "
                f"from any base on its side (short by {-float(score[best]) * 1000:.0f} mm)"
            )
        out[side] = np.array([cand[best, 0], cand[best, 1], 0.0])
    return out


def mount_yaw(base: np.ndarray, points: np.ndarray) -> float:
    """The heading (rad) the arm's base is turned to: towards the middle of its lane's points,
    so that its first joint (limited to +-180 deg) turns either way from there."""
    pts = points[np.all(np.isfinite(points), axis=1)]
    c = pts[:, :2].mean(axis=0) if len(pts) else base[:2] + np.array([1.0, 0.0])
    return float(np.arctan2(c[1] - base[1], c[0] - base[0]))


def mounted(arm: Robot, yaw: float) -> Robot:
    """``arm`` with its body turned by ``yaw`` about the vertical inside its base."""
    q = f"{np.cos(yaw / 2):.6f} 0 0 {np.sin(yaw / 2):.6f}"
    name = arm.arm_joints[0].rsplit("/", 1)[0] + "/mount" if "/" in arm.arm_joints[0] else "mount"
    return replace(arm, body=f'<body name="{name}" quat="{q}">{arm.body}</body>')


def _clear(cand: np.ndarray, pts: np.ndarray, r: float) -> np.ndarray:
    """Which candidates are at least ``r`` from every point (a k-d tree: a planned path has a
    point per control tick)."""
    from scipy.spatial import cKDTree

    if not len(pts):
        return np.ones(len(cand), dtype=bool)
    dist, _ = cKDTree(pts).query(cand, k=1)
    return np.asarray(dist >= r)


def layout(
    trajs: dict[str, Any],
    hands: HandsProgram,
    programs: dict[str, TaskProgram],
    robot: TwoArmRobot,
    displace: dict[str, Any],
    sequence: bool,
    level: float = np.inf,
) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray], dict[str, np.ndarray]]:
    """The objects where the layout puts them (``displace``), the points each base is chosen
    for (the hands' paths; for a program with carries that no base reaches so, where its skills
    act) and both bases (:func:`choose_bases`, ``level``)."""
    from .displacement import initial_poses, program_start
    from .goals import DemoFrames
    from .two_arm_sequence import task_points

    sides = list(programs)
    traj0 = trajs[sides[0]]
    start0 = program_start(traj0, programs[sides[0]])
    moved = initial_poses(DemoFrames(traj0, np.zeros(3), robot.ik), displace, start0)
    first = np.asarray(traj0.object_position, dtype=np.float64)
    objects0 = np.array([p[np.all(np.isfinite(p), axis=1)][0] for p in first]).reshape(-1, 3)
    shifted = np.array([T[:3, 3] for T in moved.values()]).reshape(-1, 3)
    keep_out = np.concatenate([objects0, shifted])
    points = {s: np.asarray(trajs[s].tcp, dtype=np.float64) for s in sides}
    try:
        return moved, points, choose_bases(points, keep_out, robot, level=level)
    except DemonstrationError:
        if not sequence:
            raise
        points = task_points(trajs, hands)  # where the skills act, not the hands' free moves
        return moved, points, choose_bases(points, keep_out, robot, level=level)
