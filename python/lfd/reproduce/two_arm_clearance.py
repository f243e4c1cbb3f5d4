"""The two arms kept out of each other's way (:mod:`.two_arms`): how close the arms come along
both plans (:func:`~.two_arm_distance.arm_distances`, every :data:`EVERY` ticks); a hold that
brings them closer than :data:`CLEARANCE` is re-ordered (:func:`clear_holds`).

A ``hold_until`` point (one arm holds an object still while the other acts on it) needs the
two arms together only during the other arm's step: before it, the other arm fetches what it
acts with. When the person's hands crossed to do so (the acting hand fetching an object
beyond the holding one), the arms that follow them meet on the way. Then the holder's
approach waits (at its start) until the other arm has fetched and brought its object to
where its step begins, and holds from there; the other arm's step still starts only once
the holder holds (:func:`~lfd.reproduce.two_arms.synchronise`). Or, where the two would meet
there, the holder waits only until the other arm has picked its object up, and the other
arm brings it once the holder holds. A holder so made to wait waits up by its own base
(:func:`park_first`), not where the person's hand rested: the person's idle hand lay where
the other one then reached across; towards the hold or turned from it
(:data:`PARK_TURNS`: a base near the work puts the park towards the hold above the work,
where the other arm lifts its object). A re-ordered plan is kept only when its arms stay
further apart than the original's (the least distance, then the time they overlap, then the
time closer than :data:`CLEARANCE`: :func:`clearance_score`).

Where the arms still meet, the holder's way to its hold is made straight
(:func:`straight_approach`): the one-arm planner takes it to where the person's hand began its
approach (mapped with the object), which, the object moved and turned in a layout, may lie
under the other arm that waits above the hold with its object; it goes instead over to above
the hold and down, in the same time. Kept, too, only when the arms stay further apart.
Likewise the other arm's step beside the hold goes over and straight down to its lowest
point (:func:`straight_down`: a DMP keeps the person's curve, which, the objects moved, may
sweep towards the holding gripper), and its carry there goes over the holder, up at
:data:`PARK_HEIGHT` (:func:`carry_over`). And where they meet still, the holder lifts off
as soon as the other arm's step has ended (:func:`lift_early`; the person's hand held on for a
while more, the arm that then goes away passing the pressing one), kept likewise. And last,
an arm's move to where the person's hand went to rest once done goes up by its own base
instead (:func:`park_last`), kept likewise.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import numpy as np

from .controller import Plan
from .dmp import min_jerk
from .program import HandsProgram
from .two_arm_clock import _start, _wait
from .two_arm_distance import MakeIK, arm_distances

AWAY_GRASP = 1.0
"""How far (m) :func:`stack_away` asks a grasp from the object's centre (then clipped to the
object)."""
CLEARANCE = 0.015
"""The least distance (m) the two arms' colliding geoms are planned to keep."""
EVERY = 4
"""The arms' distance is measured every this many control ticks."""


def hold_later(
    plans: dict[str, Plan],
    hands: HandsProgram,
    point: Any,
    sync: Callable[..., Any],
    *,
    fetched: bool = False,
) -> dict[str, Plan]:
    """The holder of ``point`` (a ``hold_until``) waiting at its start until the other arm
    has done the steps before its synchronised one (it is where that step begins), then
    both on one clock again (``sync``: :func:`~lfd.reproduce.two_arms.synchronise`).
    ``fetched``: the holder waits only until the other arm has picked its object up (its
    next step begins), and that step (bringing it) waits until the holder holds."""
    from .two_arm_clock import _before

    lane = hands.lanes[point.hand]
    k = point.step - 1  # its pick_up, or the move that brings it there
    if k >= 1 and lane[k - 1].skill == "move" and lane[k - 1].object == point.object:
        k -= 1
    a, b = plans[point.hand], plans[point.other]
    at = _start(a, k)
    until = point.other_step - (1 if fetched else 0)
    need = _start(b, until) - at
    if need <= 0 or at >= len(a):
        return plans
    out = dict(plans)
    out[point.hand] = a = _wait(a, at, need, _before(a, at))
    if fetched:  # the other arm brings its object once the holder holds
        bt = _start(b, until)
        out[point.other] = _wait(b, bt, _start(a, point.step) - bt, _before(b, bt))
    return dict(sync(out, hands))


def clearance_score(
    plans: dict[str, Plan], scene: str, make_ik: MakeIK, robot: Any
) -> tuple[float, int, int]:
    """How far apart the arms of ``plans`` (on one clock) stay, to compare plans (larger is
    further): the least distance of :func:`~.two_arm_distance.arm_distances` (up to
    :data:`CLEARANCE`; overlaps count as 0), then fewer ticks where they overlap (a run
    fails there), then fewer ticks closer than :data:`CLEARANCE`."""
    d = arm_distances(plans, scene, make_ik, robot, every=EVERY)
    least = min(max(float(d.min()), 0.0), CLEARANCE)
    return least, -int(np.sum(d <= 0.0)), -int(np.sum(d < CLEARANCE))


def clear_holds(
    plans: dict[str, Plan],
    hands: HandsProgram,
    scene: str,
    make_ik: MakeIK,
    robot: Any,
    sync: Callable[..., Any],
    bases: dict[str, np.ndarray],
) -> dict[str, Plan]:
    """``plans`` with each ``hold_until`` whose arms come closer than :data:`CLEARANCE`
    re-ordered (:func:`hold_later`, the holder waiting by its base: :func:`park_first`;
    ``bases``: each arm's), then its ways changed (:func:`straight_approach`,
    :func:`straight_down`, :func:`carry_over`, :func:`lift_early`, :func:`park_last`), each
    kept only when that keeps the arms further apart (the module docstring)."""
    holds = [p for p in hands.sync if p.kind == "hold_until" and {p.hand, p.other} <= set(plans)]
    if len(plans) != 2 or not holds:
        return plans

    def score(p: dict[str, Plan]) -> tuple[float, int, int]:
        return clearance_score(p, scene, make_ik, robot)

    out, best = plans, score(plans)
    for trial in _reordered(plans, hands, holds, sync, bases):
        if best[0] >= CLEARANCE:
            return out
        if (s := score(trial)) > best:
            out, best = trial, s
    changes: list[tuple[str, Callable[[dict[str, Plan]], Plan]]] = []
    for make in (_straight_approach, _straight_down, _carry_over, _lift_early):
        changes += [make(p, hands) for p in holds]
    changes += [_park_last(side, hands, bases[side]) for side in plans]
    for side, change in changes:
        if best[0] >= CLEARANCE:
            break
        new = change(out)
        if new is not out[side] and (s := score({**out, side: new})) > best:
            out, best = {**out, side: new}, s
    return out


def _reordered(
    plans: dict[str, Plan],
    hands: HandsProgram,
    holds: list[Any],
    sync: Callable[..., Any],
    bases: dict[str, np.ndarray],
) -> Iterator[dict[str, Plan]]:
    """The re-ordered ``plans`` :func:`clear_holds` tries: each hold's holder waiting
    (:func:`hold_later`, both ways) where the person's hand rested, or by its base
    (:func:`park_first`, each way in and each of :data:`PARK_TURNS`)."""
    ways = [(None, 0.0)] + [(low, t) for t in PARK_TURNS for low in (True, False)]
    for p in holds:
        for fetched in (False, True):
            later = hold_later(plans, hands, p, sync, fetched=fetched)
            if later is plans:
                continue
            for low, turn in ways:
                if low is None:
                    yield later
                    continue
                parked = park_first(later[p.hand], hands, p, bases[p.hand], low=low, turn=turn)
                if parked is not later[p.hand]:
                    yield {**later, p.hand: parked}


def _straight_approach(p: Any, hands: HandsProgram) -> tuple[str, Callable[..., Plan]]:
    return p.hand, lambda o: straight_approach(o[p.hand], hands, p)


def _straight_down(p: Any, hands: HandsProgram) -> tuple[str, Callable[..., Plan]]:
    return p.other, lambda o: straight_down(o[p.other], p.other_step)


def _carry_over(p: Any, hands: HandsProgram) -> tuple[str, Callable[..., Plan]]:
    before = p.other_step - 1
    lane = hands.lanes[p.other]
    if before < 0 or lane[before].skill != "move_with":
        return p.other, lambda o: o[p.other]
    return p.other, lambda o: carry_over(o[p.other], before)


def _lift_early(p: Any, hands: HandsProgram) -> tuple[str, Callable[..., Plan]]:
    return p.hand, lambda o: lift_early(o, p)


def _park_last(side: str, hands: HandsProgram, base: np.ndarray) -> tuple[str, Callable[..., Plan]]:
    return side, lambda o: park_last(o[side], hands.lanes[side], base)


def park_last(plan: Plan, lane: list[Any], base: np.ndarray) -> Plan:
    """``plan`` (of ``lane``) with its last step, a move to where the person's hand went to
    rest (no object), going instead up by its own base (as :func:`park_first` waits): over the
    same ticks, up, over and down to :data:`PARK_HEIGHT`. ``plan`` itself when its last step
    is not such a move."""
    k = len(lane) - 1
    if k < 1 or lane[k].skill != "move" or lane[k].object is not None:
        return plan
    sel = np.nonzero(plan.segment == k)[0]
    if sel.size < 2:
        return plan
    i0, i1 = int(sel[0]), int(sel[-1])
    a = plan.position[i0]
    park = _park(base, a)
    if park is None:
        return plan
    pos, yaw = plan.position.copy(), plan.yaw.copy()
    ya = float(plan.yaw[i0])
    pos[i0 : i1 + 1], yaw[i0 : i1 + 1] = _over(a, ya, park, ya, i1 - i0 + 1)
    pos[i1 + 1 :], yaw[i1 + 1 :] = park, ya
    return Plan(pos, yaw, plan.opening.copy(), plan.segment.copy())


def lift_early(plans: dict[str, Plan], point: Any) -> Plan:
    """The holder's plan of ``point`` (``plans`` on one clock) with its hold cut short where it
    outlasts the other arm's step: the holder lifts off (its ``place``) once the other arm's
    step has ended (its release and back-off included), not after the rest of the time the
    person's hand held on, while the other arm goes away. ``plans[point.hand]`` itself when
    the hold does not outlast it."""
    a, b = plans[point.hand], plans[point.other]
    held = np.nonzero(a.segment == point.step)[0]
    if not held.size:
        return a
    cut, end = max(_start(b, point.other_step + 1), int(held[0]) + 1), int(held[-1]) + 1
    if end <= cut:
        return a
    keep = np.r_[0:cut, end : len(a)]
    return Plan(a.position[keep], a.yaw[keep], a.opening[keep], a.segment[keep])


PARK_TURNS = (0.0, np.pi / 3, -np.pi / 3)
"""The headings (rad, from towards the hold) a waiting holder's park is tried at
(:func:`park_first`): where the holder's base is near the work, the park towards the hold lies
above it, where the other arm lifts its object."""
PARK_REACH = 0.4
"""How far (m, horizontally) from its base a waiting holder waits (:func:`park_first`)."""
PARK_HEIGHT = 0.35
"""How high (m) above the table a waiting holder's TCP waits (:func:`park_first`)."""


PARK_IN_RISE = 0.1
"""How high (m) above its grasp at least a parked holder comes in low (:func:`park_first`): a
DMP's ``pick_up`` may begin at the grasp's height, and the way in would sweep the objects."""


def park_first(
    plan: Plan,
    hands: HandsProgram,
    point: Any,
    base: np.ndarray,
    *,
    low: bool = False,
    turn: float = 0.0,
) -> Plan:
    """The holder's ``plan`` of ``point`` (made to wait by :func:`hold_later`) waiting, from
    its start, up by its own base (:data:`PARK_REACH` from it towards the hold turned by
    ``turn`` rad about the base, :data:`PARK_HEIGHT` high), not where the person's hand
    rested, then going from there over to above the hold and down (as
    :func:`straight_approach`; ``low``: down by its base first, then in at the hover's height,
    at least :data:`PARK_IN_RISE` above the grasp, and down)
    over the ticks of its way there. ``plan`` itself when the hold's way there is not its
    first step."""
    k = point.step - 1  # the pick_up
    lane = hands.lanes[point.hand]
    if k != 1 or lane[0].skill != "move":
        return plan
    i0, sel = _start(plan, 0), np.nonzero(plan.segment == k)[0]
    if not sel.size or sel[0] - i0 < 2:
        return plan
    h = _hover(plan, sel)
    hover = plan.position[h]
    park = _park(base, hover, turn)
    if park is None:
        return plan
    pos, yaw, opening = plan.position.copy(), plan.yaw.copy(), plan.opening.copy()
    yh, n = float(plan.yaw[h]), h - i0 + 1
    pos[:i0], yaw[:i0] = park, yh
    if low:  # down by its base first, then in at the hover's height (or over the objects)
        z = max(float(hover[2]), float(plan.position[sel, 2].min()) + PARK_IN_RISE)
        way = np.array([[*park, yh], [*park[:2], z, yh], [*hover[:2], z, yh], [*hover, yh]])
        pos[i0 : h + 1], yaw[i0 : h + 1] = _along(way, n)
    else:
        pos[i0 : h + 1], yaw[i0 : h + 1] = _over(park, yh, hover, yh, n)
    opening[: h + 1] = np.maximum(opening[: h + 1], opening[h])
    return Plan(pos, yaw, opening, plan.segment.copy())


def _park(base: np.ndarray, towards: np.ndarray, turn: float = 0.0) -> np.ndarray | None:
    """Where an arm waits up by its ``base``: :data:`PARK_REACH` from it horizontally towards
    ``towards`` turned by ``turn`` rad about it, :data:`PARK_HEIGHT` high (None when
    ``towards`` is above the base)."""
    b = np.asarray(base, dtype=np.float64)[:2]
    u = np.asarray(towards, dtype=np.float64)[:2] - b
    d = float(np.linalg.norm(u))
    if d < 1e-9:
        return None
    c, s = np.cos(turn), np.sin(turn)
    u = np.array([c * u[0] - s * u[1], s * u[0] + c * u[1]]) / d
    return np.array([*(b + PARK_REACH * u), PARK_HEIGHT])


def _hover(plan: Plan, sel: np.ndarray) -> int:
    """The hover tick of a ``pick_up`` (ticks ``sel``): its highest before its descent to the
    lowest."""
    z = plan.position[sel[: int(np.argmin(plan.position[sel, 2])) + 1], 2]  # down to it
    return int(sel[np.nonzero(z >= z.max() - 1e-4)[0][-1]])


def _along(corners: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """``n`` ticks (min-jerk along the path) through ``corners`` (k, 4: position and yaw)."""
    arc = np.concatenate(
        [[0.0], np.cumsum(np.linalg.norm(np.diff(corners[:, :3], axis=0), axis=1))]
    )
    if arc[-1] < 1e-9:
        return np.repeat(corners[-1:, :3], n, 0), np.full(n, corners[-1, 3])
    at = min_jerk(n) * arc[-1]
    path = np.stack([np.interp(at, arc, corners[:, j]) for j in range(4)], axis=1)
    return path[:, :3], path[:, 3]


def _over(
    a: np.ndarray, ya: float, b: np.ndarray, yb: float, n: int, top: float = -np.inf
) -> tuple[np.ndarray, np.ndarray]:
    """``n`` ticks from ``a`` up to ``top`` (at least both heights), over to above ``b`` and
    down to it, the yaw from ``ya`` to ``yb``."""
    top = max(top, float(a[2]), float(b[2]))
    return _along(np.array([[*a, ya], [*a[:2], top, ya], [*b[:2], top, yb], [*b, yb]]), n)


def straight_approach(plan: Plan, hands: HandsProgram, point: Any) -> Plan:
    """The holder's ``plan`` with its way to the hold of ``point`` replaced, over the same
    ticks (the clock unchanged): the move before its ``pick_up`` and the approach up to the
    hover above the hold (the highest tick of the ``pick_up`` before its descent to the lowest)
    become a path up to the highest height the two had, over to above the hover and down to it
    (min-jerk along the path). ``plan`` itself when no move comes right before the
    ``pick_up``."""
    k = point.step - 1  # the pick_up: the approach and the hold's grasp or press
    lane = hands.lanes[point.hand]
    if k < 1 or lane[k - 1].skill != "move":
        return plan
    i0, sel = _start(plan, k - 1), np.nonzero(plan.segment == k)[0]
    if not sel.size or sel[0] - i0 < 2:
        return plan
    h = _hover(plan, sel)
    top = float(plan.position[i0 : h + 1, 2].max())
    a, b = plan.position[i0], plan.position[h]
    if np.linalg.norm(b - a) < 1e-9 and top <= a[2]:
        return plan
    out = _redone(plan, i0, h, top)
    out.opening[i0 : h + 1] = np.maximum(out.opening[i0 : h + 1], out.opening[h])
    return out


def carry_over(plan: Plan, step: int) -> Plan:
    """``plan`` with its ``step`` (the other arm's ``move_with`` bringing what it stacks or
    pushes beside the hold) going up to :data:`PARK_HEIGHT` (or the highest it had), over to
    where the step ends and down to it, over the same ticks: the person's hand carried it on a
    slant past the holding one, the arms' wrists meeting on the way. ``plan`` itself when the
    step has fewer than three ticks."""
    sel = np.nonzero(plan.segment == step)[0]
    if sel.size < 3:
        return plan
    i0, i1 = int(sel[0]), int(sel[-1])
    return _redone(plan, i0, i1, max(PARK_HEIGHT, float(plan.position[i0 : i1 + 1, 2].max())))


def _redone(plan: Plan, i0: int, i1: int, top: float) -> Plan:
    """``plan`` with ticks ``i0`` to ``i1`` going up to ``top``, over and down (:func:`_over`)."""
    pos, yaw = plan.position.copy(), plan.yaw.copy()
    a, b = plan.position[i0], plan.position[i1]
    pos[i0 : i1 + 1], yaw[i0 : i1 + 1] = _over(a, plan.yaw[i0], b, plan.yaw[i1], i1 - i0 + 1, top)
    return Plan(pos, yaw, plan.opening.copy(), plan.segment.copy())


def straight_down(plan: Plan, step: int) -> Plan:
    """``plan`` with its ``step`` (the other arm's at a hold: the stack or push beside the
    holder) going from its start up to the highest height it had, over to above its lowest
    point and straight down to it, over the same ticks (min-jerk along the path): a DMP's
    approach keeps the person's curve, which, the object moved, may sweep towards the holding
    gripper 10 cm away. ``plan`` itself when the step does not go down to its lowest point
    over two ticks or more."""
    sel = np.nonzero(plan.segment == step)[0]
    if sel.size < 3:
        return plan
    i0, low = int(sel[0]), int(sel[int(np.argmin(plan.position[sel, 2]))])
    if low - i0 < 2:
        return plan
    return _redone(plan, i0, low, float(plan.position[i0 : low + 1, 2].max()))


def _stacks_beside(
    planned: dict[str, tuple[Any, Any, Any]], presses: dict[str, Any]
) -> Iterator[tuple[str, str, np.ndarray, np.ndarray]]:
    """(the stacking side, the object it stacks, the object's stacked pose, the press' x, y) of
    every stack planned next to where the other arm presses (a hold by pressing,
    :mod:`.two_arm_press`)."""
    for side, point in presses.items():
        other = point.other
        if side not in planned or other not in planned:
            continue
        press = planned[side][2].plan
        at = np.nonzero(press.segment == point.step)[0]
        result = planned[other][2]
        if not at.size or result.program is None:
            continue
        xy = press.position[int(at[0]), :2]
        for g in result.program.segments:
            if g.skill == "stack" and g.object in result.expected:
                yield other, str(g.object), result.expected[g.object], xy


def stack_across(
    planned: dict[str, tuple[Any, Any, Any]], presses: dict[str, Any]
) -> dict[str, dict[str, int]]:
    """For each lane that stacks an object next to where the other arm presses
    (:func:`_stacks_beside`): the object's axis its gripper is to close along, the one
    most across the line from the stacked object to the press. A gripper's bar spans its
    closing axis (the ViperX's 15 cm): so both grippers turn their narrow side to each other
    (the pressing one closes across that line too), the stacking one not reaching over the
    pressing one."""
    from .goals import closing_axis

    out: dict[str, dict[str, int]] = {}
    for other, name, T, xy in _stacks_beside(planned, presses):
        u = xy - T[:2, 3]
        out.setdefault(other, {})[name] = closing_axis(T, float(np.arctan2(u[1], u[0])) + np.pi / 2)
    return out


def stack_away(
    planned: dict[str, tuple[Any, Any, Any]], presses: dict[str, Any]
) -> dict[str, dict[str, np.ndarray]]:
    """For each lane that stacks an object next to where the other arm presses
    (:func:`_stacks_beside`): where its gripper takes the object (x, y in the object's frame,
    :func:`~lfd.reproduce.modes.plan_task`'s ``grasp_at``), at its end away from the press,
    as far as the fingers stay on it (:func:`~lfd.reproduce.goals.grasp_goal` clips the
    offset across the closing axis; along it the grasp is centred). The two wrists, each
    about 10 cm across, then stand further apart than the stack and the press (natural
    ``hold_stack`` 9508: 8 cm apart, the wrists overlapping by 11 mm)."""
    out: dict[str, dict[str, np.ndarray]] = {}
    for other, name, T, xy in _stacks_beside(planned, presses):
        u = T[:2, 3] - xy
        n = float(np.linalg.norm(u))
        if n > 0.0:
            out.setdefault(other, {})[name] = T[:2, :2].T @ (u / n) * AWAY_GRASP
    return out
