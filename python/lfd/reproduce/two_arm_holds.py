"""A hold kept clear of the other arm (:mod:`.two_arms`), measured before anything is run by
how close the two arms come along their plans (:func:`arm_clearance`, of
:func:`~.two_arm_distance.arm_distances`).

A hold whose holding gripper comes closer than :data:`ARM_CLEARANCE` to the other arm (a push
of a box next to the held one: the pushing fingers between the two boxes, both grippers' bars
15 cm wide) is planned again with the object held by pressing on its top at the end away from
the other arm (:func:`~lfd.reproduce.two_arm_press.plan_press_lane`), kept when that leaves
more room (:func:`~lfd.reproduce.two_arms.plan_two_arms`). Where the arms still meet, the
other arm's approach waits until the holder holds (:func:`approach_after_hold`); a pushing arm
waits for the hold low behind the box it pushes, not above it beside the holding gripper
(:func:`push_from_below`); or it pushes the box by grasping and sliding it, its gripper over
the box rather than between it and the held one (``by_grasp`` of
:func:`~lfd.reproduce.motion.push_geometry`, when the box fits the gripper). Each is kept only
when the arms then keep more room.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from .aloha import TwoArmRobot
from .controller import Plan
from .two_arm_distance import MakeIK, arm_distances, tick_s

ARM_CLEARANCE = 0.01
"""Smallest planned distance (m) between the two arms' colliding geoms at a hold."""
EVERY = 2
"""The distance is measured every this many control ticks (the IK follows every tick)."""


def arm_clearance(
    plans: dict[str, Plan], scene: str, make_ik: MakeIK, robot: TwoArmRobot
) -> tuple[float, float]:
    """The smallest distance (m, at most :data:`~.two_arm_distance.FAR`) between the two arms'
    colliding geoms along their plans on one clock, and when (s): :func:`~.two_arm_distance.
    arm_distances` every :data:`EVERY` ticks. ``scene``: the MJCF of both arms
    (:func:`~lfd.reproduce.two_arms.scene_xml`); ``make_ik(side)``: that arm's IK, mounted at
    its base (:class:`~lfd.reproduce.two_arms.MountedIK`)."""
    d = arm_distances(plans, scene, make_ik, robot, every=EVERY)
    k = int(np.argmin(d))
    return float(d[k]), tick_s(k, EVERY)


def hold_points(hands: Any) -> list[Any]:
    """The ``hold_until`` points whose lane can press (:func:`~lfd.reproduce.two_arm_press.
    press_holds`' shape: the ``pick_up`` before, the ``place`` after, of the held object),
    held by a grasp or already by pressing."""
    out = []
    for p in hands.sync:
        if p.kind != "hold_until" or p.object is None:
            continue
        lane, k = hands.lanes[p.hand], p.step
        if (
            0 < k < len(lane) - 1
            and lane[k - 1].skill == "pick_up"
            and lane[k + 1].skill == "place"
        ):
            if lane[k - 1].object == lane[k + 1].object == p.object:
                out.append(p)
    return out


def other_path(plan: Plan, step: int) -> np.ndarray:
    """Where the other arm's TCP is during its step ``step`` (its whole plan when it has none)."""
    sel = plan.segment == step
    return plan.position[sel] if sel.any() else plan.position


NEAR = 0.25
"""A hold whose gripper stays farther (m, horizontally) from the other arm's TCP during its
step is not measured (:func:`press_if_clearer`)."""


def press_if_clearer(
    planned: dict[str, tuple[Any, Any, Any]],
    plans: dict[str, Plan],
    hands: Any,
    press_lane: Any,
    clearance: Any,
    sync: Any,
    slid: Any = None,
) -> tuple[dict[str, tuple[Any, Any, Any]], dict[str, Plan]]:
    """Each hold (:func:`hold_points`, by a grasp or by pressing) whose arms come closer than
    :data:`ARM_CLEARANCE` on the common clock planned again by pressing at the object's end
    away from the other arm's step (``press_lane(point, away)``: the lane, or None when it
    cannot be planned there), kept when the arms then keep more room; if still too close,
    the other arm's approach waits until the holder holds (:func:`approach_after_hold`), or
    a pushing arm waits for the hold low behind the object it pushes
    (:func:`push_from_below`), or pushes it by grasping it (``slid(point)``: the other arm's
    lane so planned, or None), each kept when it leaves more room.
    ``clearance(plans)``: :func:`arm_clearance` of plans on one clock; ``sync``: the lanes put
    on one clock (:func:`~lfd.reproduce.two_arms.synchronise`)."""
    planned, plans = dict(planned), dict(plans)
    for p in hold_points(hands):
        if p.hand not in plans or p.other not in plans:
            continue
        mine = plans[p.hand].position[plans[p.hand].segment == p.step]
        away = other_path(plans[p.other], p.other_step)
        if not len(mine) or _gap(mine, away) > NEAR:
            continue
        before, _ = clearance(sync(plans, hands))
        if before >= ARM_CLEARANCE:
            continue
        lane = press_lane(p, away)
        if lane is not None:
            trial = plans | {p.hand: lane[2].plan}
            after, _ = clearance(sync(trial, hands))
            if after > before:
                planned[p.hand], plans, before = lane, trial, after
        if before >= ARM_CLEARANCE:
            continue
        theirs = plans[p.other]
        for other in (approach_after_hold(plans, hands, p, sync), push_from_below(plans, hands, p)):
            if before >= ARM_CLEARANCE or other is theirs:
                continue  # clear, or nothing to try
            trial = plans | {p.other: other}
            after, _ = clearance(sync(trial, hands))
            if after > before:
                plans, before = trial, after
        other_lane = slid(p) if slid is not None and before < ARM_CLEARANCE else None
        if other_lane is not None:
            trial = plans | {p.other: other_lane[2].plan}
            after, _ = clearance(sync(trial, hands))
            if after > before:
                planned[p.other], plans = other_lane, trial
    return planned, plans


VERTICAL_M = 0.001
"""A push's first ticks within this (m, horizontally) of its first are its descent."""


def push_from_below(plans: dict[str, Plan], hands: Any, p: Any) -> Plan:
    """The other arm's plan of the hold ``p`` with its push's descent (from above the pushed
    object to behind it, :func:`~lfd.reproduce.motion.push_path`: the push's first ticks, all
    within :data:`VERTICAL_M` of the first horizontally) counted in the step before, where
    :func:`~lfd.reproduce.two_arms.synchronise` makes the arm wait for the hold: it waits low
    behind the object, beside the held one, rather than above it, its gripper below the
    holder's. Unchanged when the other step is no push or starts with no descent."""
    plan, k = plans[p.other], p.other_step
    if k < 1 or hands.lanes[p.other][k].skill != "push":
        return plan
    ticks = np.flatnonzero(plan.segment == k)
    if ticks.size < 2:
        return plan
    xy = plan.position[ticks, :2]
    moved = np.flatnonzero(np.linalg.norm(xy - xy[0], axis=1) > VERTICAL_M)
    end = int(ticks[moved[0]]) if moved.size else int(ticks[-1])
    if plan.position[ticks[0], 2] - plan.position[end, 2] <= VERTICAL_M:
        return plan  # no descent
    segment = plan.segment.copy()
    segment[ticks[0] : end] = k - 1
    return replace(plan, segment=segment)


def approach_after_hold(plans: dict[str, Plan], hands: Any, p: Any, sync: Any) -> Plan:
    """The other arm's plan of the hold ``p`` with the step before its own (the approach)
    started only once the holder holds (on the common clock: ``sync``)."""
    from .two_arm_clock import _before, _start, _wait

    synced = sync(plans, hands)
    a, b = synced[p.hand], synced[p.other]
    first = max(p.other_step - 1, 0)
    need = _start(a, p.step) - _start(b, first)
    plan = plans[p.other]
    at = _start(plan, first)
    return _wait(plan, at, need, _before(plan, at)) if need > 0 else plan


def press_lanes(
    trajs: dict[str, Any],
    hands: Any,
    mode: str,
    bases: dict[str, np.ndarray],
    robot: TwoArmRobot,
    moved: dict[str, np.ndarray],
    displace: dict[str, Any],
    others: dict[str, set[str]],
) -> Any:
    """``press_lane(point, away)`` of :func:`press_if_clearer`: the holding lane of ``point``
    pressed at the end away from ``away`` (:func:`~lfd.reproduce.two_arm_press.plan_press_lane`),
    its goals checked (:func:`~lfd.reproduce.two_arm_lanes.check_lane_goals`; ``others``:
    the objects only the other arm handles, by side), or None."""
    from ..errors import DemonstrationError, UsageError
    from .two_arm_lanes import check_lane_goals
    from .two_arm_press import plan_press_lane

    def press_lane(p: Any, away: np.ndarray) -> tuple[Any, Any, Any] | None:
        try:
            lane = plan_press_lane(trajs[p.hand], hands, p, mode, bases[p.hand], robot, moved, away)
            check_lane_goals(lane, displace, others[p.hand], p.hand)
        except (UsageError, DemonstrationError):
            return None
        return lane

    return press_lane


def _gap(a: np.ndarray, b: np.ndarray) -> float:
    """Smallest horizontal distance (m) between two point sets."""
    from scipy.spatial import cKDTree

    d, _ = cKDTree(b[:, :2]).query(a[:, :2], k=1)
    return float(np.min(d))
