"""Why a reproduction failed: one result per executed skill, with a reason when it went wrong.

The task is achieved when every object ends at its expected pose (:mod:`.measures`). When it
is not, each skill of the executed program is examined over its ticks (including the dwell and
lift-off that follow it) and gets one or more reasons:

* ``goal unreachable`` / ``IK limit``: the IK solution ended (or fell) more than
  :data:`IK_TOL` away from the planned TCP pose;
* ``grasp failed`` (pick_up: the object was not lifted with the gripper, or ``toppled over``:
  it tilted more than :data:`TOPPLE_DEG` while being grasped) and ``grasp lost``
  (move_with: the carried object slipped more than :data:`GRASP_TOL` in the gripper);
* ``collision``: an object the skill does not handle moved more than the success tolerance;
* ``placed/stacked/pushed off target by X mm``: the object a place/stack/push handled last ends
  outside the tolerance (its final error is attributed to that skill).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .controller import LOOKAHEAD, TICK, Execution, Plan
from .goals import quat_to_matrix
from .measures import POS_TOL, ROT_TOL_DEG, ObjectResult
from .program import TaskProgram

IK_TOL = 0.01
"""The IK solution farther than this from the planned TCP (m) means the arm could not follow."""
GRASP_TOL = 0.02
"""A carried object moving more than this relative to the TCP (m) was lost from the grasp."""
LIFT_MIN = 0.01
"""A grasped object must rise at least this much during the carry (m)."""
PLACING = ("place", "stack", "push")
TOPPLE_DEG = 30.0
"""A handled object tilting more than this (deg) during a skill toppled over."""


@dataclass
class SkillResult:
    """Outcome of one skill of the executed program."""

    index: int
    skill: str
    object: str | None
    reasons: list[str] = field(default_factory=list)
    position_error_mm: float | None = None
    """Final position error of the object this skill placed last (place/stack/push)."""
    rotation_error_deg: float | None = None
    demo_s: float = 0.0
    """Duration of the segment in the demonstration (s)."""
    robot_s: float = 0.0
    """Duration of the segment on the robot (s), with the dwell and lift-off after it."""

    @property
    def slowdown(self) -> float | None:
        """How many times longer the robot took than the demonstration (None: no demo time)."""
        return self.robot_s / self.demo_s if self.demo_s > 0 else None

    @property
    def ok(self) -> bool:
        return not self.reasons

    @property
    def reason(self) -> str | None:
        return "; ".join(self.reasons) if self.reasons else None

    def label(self) -> str:
        """``"6 stack box_1"``."""
        return f"{self.index} {self.skill}" + (f" {self.object}" if self.object else "")

    def to_json(self) -> dict[str, Any]:
        return {
            "index": self.index,
            "skill": self.skill,
            "object": self.object,
            "ok": self.ok,
            "reason": self.reason,
            "position_error_mm": self.position_error_mm,
            "rotation_error_deg": self.rotation_error_deg,
            "demo_s": self.demo_s,
            "robot_s": self.robot_s,
            "slowdown": self.slowdown,
        }


def _quat_angle_deg(a: np.ndarray, b: np.ndarray) -> float:
    d = abs(float(np.dot(a / np.linalg.norm(a), b / np.linalg.norm(b))))
    return float(np.degrees(2 * np.arccos(min(d, 1.0))))


def _tilt_deg(quats: np.ndarray) -> np.ndarray:
    """Angle (deg) between an object's z axis and the vertical, per quaternion (n, 4), folded
    into [0, 90] (a box upside down stands as well as upright)."""
    q = np.asarray(quats, dtype=np.float64).reshape(-1, 4)
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    zz = 1 - 2 * (q[:, 0] ** 2 + q[:, 1] ** 2)  # R[2, 2]
    return np.asarray(np.degrees(np.arccos(np.clip(np.abs(zz), 0.0, 1.0))))


def _spans(plan: Plan, n_segments: int) -> list[tuple[int, int]]:
    """Tick range [a, b) of each segment, including the dwell/lift-off ticks (-1) after it."""
    seg = np.asarray(plan.segment)
    starts = []
    for k in range(n_segments):
        idx = np.flatnonzero(seg == k)
        starts.append(int(idx[0]) if idx.size else -1)
    spans = []
    for k, a in enumerate(starts):
        later = [s for s in starts[k + 1 :] if s >= 0]
        b = later[0] if later else len(seg)
        spans.append((a, b) if a >= 0 else (0, 0))
    return spans


def skill_results(
    program: TaskProgram,
    plan: Plan,
    ex: Execution,
    objects: list[ObjectResult],
) -> list[SkillResult]:
    """Examine every skill of an executed program (see the module docstring).

    Parameters
    ----------
    program : TaskProgram
        The executed program; ``plan.segment`` indexes its segments.
    plan : Plan
    ex : Execution
    objects : list of ObjectResult
        Final errors per object, in ``ex.object_names`` order.
    """
    segs = program.segments
    spans = _spans(plan, len(segs))
    out = [
        SkillResult(k, s.skill, s.object, demo_s=s.end_s - s.start_s, robot_s=(b - a) * TICK)
        for k, (s, (a, b)) in enumerate(zip(segs, spans, strict=True))
    ]
    n = len(plan)
    names = ex.object_names
    ahead = np.minimum(np.arange(n) + LOOKAHEAD, n - 1)
    ik_err = np.linalg.norm(ex.planned_ik - plan.position[ahead], axis=1)
    held: str | None = None
    last_handler: dict[str, int] = {}
    last_mover: dict[str, int] = {}
    for k, (seg, (a, b)) in enumerate(zip(segs, spans, strict=True)):
        if b <= a:
            continue
        res = out[k]
        end = min(b, n) - 1
        _check_tracking(res, plan, ik_err, ahead, a, b, end)
        if seg.skill == "pick_up":
            held = seg.object
        handled = {seg.object, held} - {None}
        _check_collisions(res, ex, a, end, handled, k, last_mover)
        for name in sorted(n for n in handled if n in names):  # a handled box stays upright
            j = names.index(name)
            tilts = _tilt_deg(ex.object_quaternion[j, a : end + 1])
            tilt = float(tilts.max() - tilts[0]) if tilts.size else 0.0
            if tilt > TOPPLE_DEG:
                what = "grasp failed: " if seg.skill == "pick_up" else ""
                res.reasons.append(f"{what}{name} toppled over ({tilt:.0f} deg)")
        if seg.skill == "move_with" and held in names:
            _check_carry(out, segs, ex, held, k, a, b)
        if seg.skill in PLACING:
            placed = seg.object or (held if seg.skill != "push" else None)
            if placed is not None:
                last_handler[placed] = k
        if seg.skill in ("place", "stack"):
            held = None
    _blame_objects(out, segs, objects, last_handler, last_mover)
    return out


def _check_tracking(
    res: SkillResult,
    plan: Plan,
    ik_err: np.ndarray,
    ahead: np.ndarray,
    a: int,
    b: int,
    end: int,
) -> None:
    """The arm reaches the skill's goal and follows its path (ticks ``a..b``)."""
    if ik_err[end] > IK_TOL:
        res.reasons.append(
            f"goal unreachable: the arm ends {ik_err[end] * 1000:.0f} mm from the planned "
            f"TCP pose ({', '.join(f'{v:.3f}' for v in plan.position[ahead[end]])}) m"
        )
    elif ik_err[a:b].max() > IK_TOL:
        res.reasons.append(
            f"IK limit: the arm falls {ik_err[a:b].max() * 1000:.0f} mm behind the planned path"
        )


def _check_collisions(
    res: SkillResult,
    ex: Execution,
    a: int,
    end: int,
    handled: set[str | None],
    k: int,
    last_mover: dict[str, int],
) -> None:
    """The objects the skill does not handle stay where they are (``last_mover``: the last
    skill each object moved in, updated)."""
    for j, name in enumerate(ex.object_names):
        moved = float(np.linalg.norm(ex.object_position[j, end] - ex.object_position[j, a]))
        turned = _quat_angle_deg(ex.object_quaternion[j, end], ex.object_quaternion[j, a])
        if moved > 0.003 or turned > 3.0:
            last_mover[name] = k
        if name in handled:
            continue
        if moved > POS_TOL or turned > ROT_TOL_DEG:
            res.reasons.append(
                f"collision: {name} was knocked {moved * 1000:.0f} mm / {turned:.0f} deg"
            )


def _check_carry(
    out: list[SkillResult],
    segs: list[Any],
    ex: Execution,
    held: str,
    k: int,
    a: int,
    b: int,
) -> None:
    """A Move with (skill ``k``, ticks ``a..b``) lifts the ``held`` object with the gripper
    (else the Pick up before it failed) and keeps it in the gripper."""
    j = ex.object_names.index(held)
    # the TCP in the object's frame: a carried object may turn with the gripper (or between two
    # grippers pressing it, lfd.reproduce.two_arm_carry) without slipping
    R = np.stack([quat_to_matrix(q) for q in ex.object_quaternion[j, a:b]])
    rel = np.einsum("nji,nj->ni", R, ex.tcp[a:b] - ex.object_position[j, a:b])
    slip = np.linalg.norm(rel - rel[0], axis=1)
    rise = float(ex.object_position[j, a:b, 2].max() - ex.object_position[j, a, 2])
    if rise < LIFT_MIN and float(ex.tcp[a:b, 2].max() - ex.tcp[a, 2]) > LIFT_MIN:
        pick = next((i for i in range(k - 1, -1, -1) if segs[i].skill == "pick_up"), k)
        out[pick].reasons.append(f"grasp failed: {held} was not lifted by the gripper")
    elif slip.max() > GRASP_TOL:
        t = (a + int(np.argmax(slip > GRASP_TOL))) * TICK
        out[k].reasons.append(
            f"grasp lost: {held} slipped {slip.max() * 1000:.0f} mm in the gripper "
            f"during the carry (from t = {t:.1f} s)"
        )


def _blame_objects(
    out: list[SkillResult],
    segs: list[Any],
    objects: list[ObjectResult],
    last_handler: dict[str, int],
    last_mover: dict[str, int],
) -> None:
    """Each object's final error goes to the skill that last placed it; an object off target
    is blamed on that skill, a lost grasp, or the collision that last moved it."""
    verbs = {"place": "placed", "stack": "stacked", "push": "pushed"}
    for o in objects:
        h = last_handler.get(o.name)
        if h is not None:
            out[h].position_error_mm = o.position_error * 1000
            out[h].rotation_error_deg = o.rotation_error_deg
        if o.success:
            continue
        off = f"{o.position_error * 1000:.0f} mm / {o.rotation_error_deg:.0f} deg"
        mover = last_mover.get(o.name)
        lost = any(o.name in r and "grasp" in r for s in out[: h or 0] for r in s.reasons)
        if h is not None and lost:
            out[h].reasons.append(f"{o.name} never got there (ends {off} off target)")
        elif h is not None and (mover is None or mover <= h):
            out[h].reasons.append(f"{verbs[segs[h].skill]} {o.name} off target by {off}")
        elif mover is not None:
            if not any(o.name in r for r in out[mover].reasons):
                out[mover].reasons.append(f"collision: {o.name} was moved and ends {off} off")
        else:
            target = h if h is not None else len(segs) - 1
            out[target].reasons.append(f"{o.name} ends {off} off target")
