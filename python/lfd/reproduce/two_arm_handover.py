"""A handover on two arms (:mod:`.two_arms`): the taker's lane planned with the object where the
giver's ``place`` leaves it (:func:`plan_handovers`), the two lanes on one clock at the handover
(:func:`handover_waits`), and the two grasps on the object kept a gripper's width apart
(:func:`plan_handovers_apart`).

Each grasp follows the demonstration along the object (the planner centres it only across
it), so the grippers hold it where the two hands did; but two hands hold a bar closer together
than two ViperX grippers can (a hand is narrower than a gripper and its wrist), and the taker
coming down beside the giver's grasp touches the giver's gripper or wrist. Where the two
planned grasps are less than :data:`HANDOVER_GAP` apart along the object (or in the order that
crosses the arms), the giver's is moved to half the gap from their middle, within the
object's ends (:func:`handover_grasps`), and the taker's put the gap from where the giver's
plan then holds the object (:func:`taker_grasps`); the taker arrives above its grasp
(:func:`~lfd.reproduce.modes.plan_task`'s ``grasp_at``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from .aloha import TwoArmRobot
from .controller import TICK, Plan
from .goals import GRASP_EDGE
from .modes import DWELL_S
from .program import HandsProgram, SyncPoint
from .two_arm_clock import _before, _end, _release, _start, _wait

HANDOVER_GAP = 0.10
"""Smallest distance (m) between the two TCPs on a handed object, along it: the ViperX
gripper's finger bar is 72 mm across the closing axis (its collision mesh), its wrist about as
wide, and with the two grasps 4-7 cm apart the taker's gripper touched the giver's wrist."""
SLACK = 0.005
"""A grasp within this (m) of where it was asked counts as there."""


def plan_handovers(
    planned: dict[str, tuple[Any, Any, Any]],
    hands: HandsProgram,
    mode: str,
    moved: dict[str, np.ndarray],
    grasp_at: dict[str, dict[str, np.ndarray]] | None = None,
) -> dict[str, Plan]:
    """Every lane's plan, a handover's taker planned again with the handed object where the
    giver's plan leaves it (:func:`~lfd.reproduce.modes.plan_task`; the other objects where the
    layout puts them, ``moved``; the taker's grasp at ``grasp_at[taker]``, else where its hand
    held the object). ``planned[taker]`` is replaced by that plan."""
    from .modes import plan_task

    plans = {s: r.plan for s, (_, _, r) in planned.items()}
    for p in hands.sync:
        if p.kind != "handover" or p.object is None:
            continue
        giver, taker = p.hand, p.other
        T_meet = planned[giver][2].expected[p.object]
        t_frames = planned[taker][0]
        result = plan_task(
            t_frames,
            hands.program(taker),
            mode,
            initial={**moved, p.object: T_meet},
            grasp_at=(grasp_at or {}).get(taker),
        )
        planned[taker] = (t_frames, planned[taker][1], result)
        plans[taker] = result.plan
    return plans


def handover_waits(plans: dict[str, Plan], p: Any, hands: HandsProgram) -> bool:
    """A handover, on one clock: the taker's ``pick_up``, and the ``move`` that brings it there,
    start once the giver has brought the object to the meeting point (the end of its
    ``place``): the taker waits out of the giver's way. The giver opens only once the taker has
    grasped (its closing dwell has ended; the giver's wait is a dwell, segment -1), and the taker
    carries the object off only once the giver has moved away (the ``move`` after its place)."""
    giver, taker = plans[p.hand], plans[p.other]
    changed = False
    first = p.other_step
    if first > 0 and hands.lanes[p.other][first - 1].skill == "move":
        first -= 1
    need = _end(giver, p.step) - _start(taker, first)
    if need > 0:
        at = _start(taker, first)
        plans[p.other] = taker = _wait(taker, at, need, _before(taker, at))
        changed = True
    grasped = min(_end(taker, p.other_step) + round(DWELL_S / TICK), len(taker))
    need = grasped - _release(giver, p.step)
    if need > 0:
        plans[p.hand] = giver = _wait(giver, _release(giver, p.step), need, -1)
        changed = True
    lane = hands.lanes[p.hand]
    away = p.step + 1 < len(lane) and lane[p.step + 1].skill == "move"
    gone = _end(giver, p.step + 1) if away else _start(giver, p.step + 1)
    need = gone - _start(taker, p.other_step + 1)
    if need > 0:
        plans[p.other] = _wait(taker, _start(taker, p.other_step + 1), need, -1)
        changed = True
    return changed


def _goal(result: Any, name: str, skills: tuple[str, ...], last: bool) -> np.ndarray | None:
    """The TCP goal (3,) of the first (``last``: the last) of ``result``'s ``skills`` on
    ``name``."""
    segs = result.program.segments if result.program is not None else []
    idx = [k for k, g in enumerate(segs) if g.skill in skills and g.object == name]
    if not idx or len(result.goals) != len(segs):
        return None
    return np.asarray(result.goals[idx[-1] if last else idx[0]], dtype=np.float64)


def _along(T: np.ndarray, p: np.ndarray, k: int) -> float:
    """``p``'s coordinate along the object's axis ``k`` (m, from its centre)."""
    return float((T[:3, :3].T @ (p - T[:3, 3]))[k])


def _grasps_on(
    p: SyncPoint,
    planned: dict[str, tuple[Any, Any, Any]],
    bases: dict[str, np.ndarray],
    robot: TwoArmRobot,
) -> tuple[float, float, float, int, np.ndarray] | None:
    """Where the giver holds the object at the meeting and the taker grasps it, along its
    longer side (``a_giver``, ``a_taker``), the side (+1/-1) the taker's base is on along it,
    that axis and the meeting pose; None when the plans do not show both grasps."""
    name = str(p.object)
    frames, _, g_result = planned[p.hand]
    T = np.asarray(g_result.expected[name], dtype=np.float64)
    given = _goal(g_result, name, ("place", "stack"), last=True)
    taken = _goal(planned[p.other][2], name, ("pick_up",), last=False)
    if given is None or taken is None:
        return None
    size = frames.size[frames.object_index(name)]
    k = int(np.argmax(size[:2]))
    u = T[:2, k]
    towards = float((bases[p.other][:2] - bases[p.hand][:2]) @ u)
    return _along(T, given, k), _along(T, taken, k), 1.0 if towards >= 0 else -1.0, k, T


def _free(
    p: SyncPoint, planned: dict[str, tuple[Any, Any, Any]], k: int, robot: TwoArmRobot
) -> float:
    """How far from the object's centre along its axis ``k`` a grasp may be (m): the fingers
    :data:`~lfd.reproduce.goals.GRASP_EDGE` inside its ends."""
    frames = planned[p.hand][0]
    size = frames.size[frames.object_index(p.object)]
    return max(0.0, float(size[k]) / 2 - robot.ik.finger_half_x - GRASP_EDGE)


def _at(a: float, k: int) -> np.ndarray:
    out = np.zeros(2)
    out[k] = a
    return out


def handover_grasps(
    hands: HandsProgram,
    planned: dict[str, tuple[Any, Any, Any]],
    bases: dict[str, np.ndarray],
    robot: TwoArmRobot,
) -> dict[str, dict[str, np.ndarray]]:
    """For every handover whose two grasps (as planned, ``planned`` after
    :func:`plan_handovers`) are less than :data:`HANDOVER_GAP` apart along the object, or the
    taker's not on the end towards its base: each arm's grasp (x, y in the object's frame at
    the meeting, for :func:`~lfd.reproduce.modes.plan_task`'s ``grasp_at``), the two moved apart
    about their middle, within the object's ends (closer when it is too short)."""
    out: dict[str, dict[str, np.ndarray]] = {}
    for p in hands.sync:
        if p.kind != "handover" or p.object is None:
            continue
        got = _grasps_on(p, planned, bases, robot)
        if got is None:
            continue
        a_g, a_t, sign, k, _ = got
        if sign * (a_t - a_g) >= HANDOVER_GAP - SLACK:
            continue
        free = _free(p, planned, k, robot)
        gap = min(HANDOVER_GAP, 2 * free)
        mid = float(np.clip((a_g + a_t) / 2, -free + gap / 2, free - gap / 2))
        out.setdefault(p.hand, {})[p.object] = _at(mid - sign * gap / 2, k)
        out.setdefault(p.other, {})[p.object] = _at(mid + sign * gap / 2, k)
    return out


def _giver_miss(
    hands: HandsProgram,
    planned: dict[str, tuple[Any, Any, Any]],
    asked: dict[str, dict[str, np.ndarray]],
    bases: dict[str, np.ndarray],
    robot: TwoArmRobot,
) -> float:
    """How far (m, the most over the handovers) the givers' planned grasps at the meeting are
    from the ``asked`` ones."""
    miss = 0.0
    for p in hands.sync:
        if p.kind == "handover" and p.object in asked.get(p.hand, {}):
            got = _grasps_on(p, planned, bases, robot)
            if got is not None:
                miss = max(miss, abs(got[0] - float(asked[p.hand][p.object][got[3]])))
    return miss


def taker_grasps(
    hands: HandsProgram,
    planned: dict[str, tuple[Any, Any, Any]],
    asked: dict[str, dict[str, np.ndarray]],
    bases: dict[str, np.ndarray],
    robot: TwoArmRobot,
) -> dict[str, dict[str, np.ndarray]]:
    """Each taker's grasp :data:`HANDOVER_GAP` from where the giver's plan holds the object at
    the meeting, towards the taker's base, else (the giver holding it too near that end) the
    farther of the two (within the object's ends)."""
    out: dict[str, dict[str, np.ndarray]] = {}
    for p in hands.sync:
        if p.kind != "handover" or p.object not in asked.get(p.other, {}):
            continue
        got = _grasps_on(p, planned, bases, robot)
        if got is None:
            out.setdefault(p.other, {})[p.object] = asked[p.other][p.object]
            continue
        a_g, _, sign, k, _ = got
        free = _free(p, planned, k, robot)
        ends = [float(np.clip(a_g + s * HANDOVER_GAP, -free, free)) for s in (sign, -sign)]
        a = (
            ends[0]
            if abs(ends[0] - a_g) >= HANDOVER_GAP - SLACK
            else max(ends, key=lambda e: abs(e - a_g))
        )
        out.setdefault(p.other, {})[p.object] = _at(a, k)
    return out


def plan_handovers_apart(
    planned: dict[str, tuple[Any, Any, Any]],
    hands: HandsProgram,
    mode: str,
    moved: dict[str, np.ndarray],
    bases: dict[str, np.ndarray],
    robot: TwoArmRobot,
    plan_lanes: Callable[..., dict[str, tuple[Any, Any, Any]]],
) -> tuple[dict[str, tuple[Any, Any, Any]], dict[str, Plan]]:
    """:func:`plan_handovers`; where a handover's two grasps are too close
    (:func:`handover_grasps`), the lanes planned again (``plan_lanes(bases, before, grasps)``)
    with the giver's grasp moved (or its mirror image: a giver may put the object down turned
    half a turn, the gripper being symmetric; the one that ends nearer where it was asked),
    then the taker's :data:`HANDOVER_GAP` from it (:func:`taker_grasps`). Returns the lanes
    and their plans."""
    lanes = dict(planned)  # (plan_handovers replaces the takers' plans)
    plans = plan_handovers(planned, hands, mode, moved)
    asked = handover_grasps(hands, planned, bases, robot)
    if not asked:
        return planned, plans
    tries = []
    for flip in (1.0, -1.0):
        ask = {s: dict(g) for s, g in asked.items()}
        for p in hands.sync:
            if p.kind == "handover" and p.object in ask.get(p.hand, {}):
                ask[p.hand][p.object] = flip * asked[p.hand][p.object]
        got = plan_lanes(bases, lanes, ask)
        tries.append((_giver_miss(hands, got, asked, bases, robot), flip, got))
        if tries[-1][0] <= SLACK:
            break
    planned = min(tries, key=lambda x: x[0])[2]
    takers = taker_grasps(hands, planned, asked, bases, robot)
    return planned, plan_handovers(planned, hands, mode, moved, takers)
