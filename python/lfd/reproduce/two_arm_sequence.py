"""A two-hand program with two-handed carries on two arms, one unit at a time.

A program with a ``carry`` (both hands ``move_with`` one object, more than
:data:`~lfd.reproduce.program.SYNC_TOLERANCE_S` together) runs as a sequence of units in the
order the demonstration began them: a two-handed carry (both arms,
:func:`~lfd.reproduce.two_arm_carry.carry_unit`) or one hand's run of steps that handle objects
(its arm alone, the one-arm planner from where the arm is, the objects where the units before
left them). The other arm waits at its rest pose meanwhile (over its side of the workspace,
clear of the objects), and each arm goes back there after a unit that leaves nothing in its
gripper. The hands' free moves between are not followed (the robot goes from its rest to the
next skill), so only the skills need to be within the arms' reach (:func:`task_points`).

Before (:func:`prepare`):

* a ``move_with`` of an object the lane has not picked up (a take that starts with it in the
  hands, or a grasp in the air next to the other hand) gets a ``pick_up`` before it: the robot
  takes it from where it lies (objects start on the table in the robot's scene);
* a one-hand carry (``pick_up``, ``move_with``, ``place``) of an object too wide for the gripper
  (every horizontal side wider than :func:`~lfd.reproduce.goals.grasp_max_width`: a mug, a
  teapot, a wine glass's box) while the other hand only moves becomes a two-handed carry: the
  other lane gets the same three steps at the same times, and both arms hold it between their
  pressing grippers, as two arms carry what is too big for one gripper.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from .aloha import TwoArmRobot
from .controller import TICK, Plan
from .goals import DemoFrames, grasp_max_width, upright, wrap_near
from .motion import line
from .program import SYNC_TOLERANCE_S, HandsProgram, Segment, SyncPoint
from .two_arm_carry import _hold, _lane_part, carry_unit

Z_CAP = 0.25
"""Highest TCP (m) of the plans and of the points the bases are placed to reach: people lift an
object to look at it far higher than a small arm reaches (a ViperX reaches a top-down TCP 0.24 m
high 0.45 m from its shoulder)."""
REST_Z = 0.15
"""Height (m) of an arm's rest pose, at least 5 cm over every object's top (fingertips)."""
REST_FRACTION = 0.5
"""An arm rests at most this fraction of the way from its base to the objects."""
REST_REACH = 0.22
"""An arm rests at most this far (m, horizontally) from its base, towards the objects and
turned away from the other arm (:func:`rest_pose`): halfway to the objects it is where the
other arm reaches (the two grippers, a gripper and a wrist touched on real takes)."""
REST_MAX_TURN_DEG = 100.0
"""The rest is at most this far (deg) from the direction of the objects (the arm's base is
turned towards them; its first joint turns at most 180 deg either way)."""
SET_DOWN_S = 0.5
"""A wide object still carried in one hand when the take ends is set down by both arms during
this last part of its carry (s)."""
OTHER_BASE_CLEAR = 0.3
"""A one-arm carry (``move_with``) keeps its TCP this far (m, horizontally) from the other
arm's base, where that arm rests (people lift an object to look at it anywhere; a gripper
0.2 m from the other arm's base touched its upper arm)."""
TRANSIT_CLEAR = 0.05
"""An arm's move from its rest to a unit's first skill (:func:`transit_to_first`) passes this
far (m) above the top of the object it goes to (its fingertips), then comes straight down."""
ACTING = ("pick_up", "move_with", "place", "stack", "push", "locate")


def _carry_overlaps(lanes: dict[str, list[Segment]]) -> list[SyncPoint]:
    """Both hands ``move_with`` the same object together for longer than
    :data:`SYNC_TOLERANCE_S` (shorter: a handover's moment, not a carry)."""
    out: list[SyncPoint] = []
    a, b = list(lanes)[:2] if len(lanes) > 1 else (None, None)
    if a is None or b is None:
        return out
    for i, s in enumerate(lanes[a]):
        for j, o in enumerate(lanes[b]):
            if s.skill == o.skill == "move_with" and s.object == o.object:
                both = min(s.end_s, o.end_s) - max(s.start_s, o.start_s)
                if both > SYNC_TOLERANCE_S:
                    t = max(s.start_s, o.start_s)
                    out.append(SyncPoint("carry", a, i, b, j, s.object, t))
    return sorted(out, key=lambda p: p.t_s)


def has_carry(hands: HandsProgram) -> bool:
    return bool(_carry_overlaps(hands.lanes))


def carried_by_both(hands: HandsProgram) -> set[str]:
    """The objects both hands carry together (the two-handed carries' objects)."""
    return {str(p.object) for p in _carry_overlaps(hands.lanes)}


def _with_pick_ups(lane: list[Segment]) -> list[Segment]:
    """A ``pick_up`` before every ``move_with`` of an object the lane does not hold."""
    out: list[Segment] = []
    held = None
    for seg in lane:
        if seg.skill == "move_with" and seg.object is not None and held != seg.object:
            t = seg.start_s
            if (
                out
                and out[-1].skill in ("move", "locate")
                and out[-1].end_s - out[-1].start_s > 0.2
            ):
                prev = out[-1]
                cut = max(prev.start_s + 0.1, t - 0.5)
                out[-1] = replace(prev, end_s=cut)
                out.append(Segment("pick_up", cut, t, seg.object))
            else:
                out.append(Segment("pick_up", t, t, seg.object))
        if seg.skill == "pick_up" or seg.skill == "move_with":
            held = seg.object
        elif seg.skill in ("place", "stack"):
            held = None
        out.append(seg)
    return out


def _joined(
    other: list[Segment], pick: Segment, carry: Segment, put: Segment
) -> list[Segment] | None:
    """The other lane's part in a one-hand carry made two-handed: the same steps, ending where
    the other hand's own next step on an object begins (it takes the object over as it is put
    down); None when that hand is busy before the carry is under way."""
    acting = [s for s in other if s.skill != "move"]
    during = [s for s in acting if s.start_s < put.end_s and s.end_s > pick.start_s]
    if any(s.object != carry.object for s in during):
        return None  # the other hand works on something else meanwhile
    # its own steps that end as this carry begins are done first (the units run in turn)
    begin = max((s.end_s for s in acting if pick.start_s < s.end_s <= carry.start_s), default=0.0)
    if begin > pick.start_s:
        pick = replace(pick, start_s=min(begin, pick.end_s))
    end = min(
        (s.start_s for s in acting if carry.start_s <= s.start_s < put.end_s), default=put.end_s
    )
    if any(s.start_s < carry.start_s < s.end_s for s in acting):
        return None  # the other hand is on an object as this carry begins
    if end < carry.start_s + SYNC_TOLERANCE_S + 0.1:
        return None
    if end >= put.end_s:
        return [pick, carry, put]
    if end > put.start_s:
        return [pick, carry, replace(put, end_s=end)]
    cut = max(carry.start_s + SYNC_TOLERANCE_S + 0.05, end - 0.1)
    return [pick, replace(carry, end_s=cut), replace(put, start_s=cut, end_s=end)]


def _insert(lane: list[Segment], steps: list[Segment]) -> list[Segment]:
    """``lane`` with ``steps`` put in, the moves they overlap cut around them."""
    t0, t1 = steps[0].start_s, steps[-1].end_s
    out: list[Segment] = []
    for s in lane:
        if s.end_s <= t0 or s.start_s >= t1:
            out.append(s)
            continue
        if s.start_s < t0:
            out.append(replace(s, end_s=t0))
        if s.end_s > t1:
            out.append(replace(s, start_s=t1))
    out += steps
    return sorted(out, key=lambda s: (s.start_s, s.end_s))


def _set_down_at_end(lane: list[Segment], wide: set[str]) -> list[Segment]:
    """A lane that ends carrying a wide object (its last step on an object a ``move_with`` of
    it after its ``pick_up``: the take ends with it in the hand) sets it down during the last
    :data:`SET_DOWN_S` of the carry (a ``place``): two arms do not end holding it in the air."""
    acting = [k for k, s in enumerate(lane) if s.skill != "move"]
    if len(acting) < 2:
        return lane
    k = acting[-1]
    carry, pick = lane[k], lane[acting[-2]]
    if carry.skill != "move_with" or carry.object not in wide:
        return lane
    if pick.skill != "pick_up" or pick.object != carry.object or acting[-2] != k - 1:
        return lane
    if carry.end_s - carry.start_s < 2 * SET_DOWN_S + SYNC_TOLERANCE_S:
        return lane
    cut = carry.end_s - SET_DOWN_S
    put = Segment("place", cut, carry.end_s, carry.object)
    return [*lane[:k], replace(carry, end_s=cut), put, *lane[k + 1 :]]


def prepare(hands: HandsProgram, sizes: dict[str, np.ndarray], robot: TwoArmRobot) -> HandsProgram:
    """The program the two arms run when it has a two-handed carry or a one-hand carry of an
    object too wide for the gripper (the module docstring); else ``hands`` unchanged."""
    widest = grasp_max_width(robot.ik)
    wide = {n for n, s in sizes.items() if float(min(s[:2])) > widest}
    lanes = {side: _with_pick_ups(list(segs)) for side, segs in hands.lanes.items()}
    lanes = {side: _set_down_at_end(segs, wide) for side, segs in lanes.items()}
    converted = False
    sides = list(lanes)
    holds = {(p.hand, p.step) for p in hands.sync if p.kind == "hold_until"}
    if holds:  # a hold keeps the object still: nothing is carried (two_arm_press)
        return hands
    for a in sides:
        for b in (x for x in sides if x != a):
            lane = lanes[a]
            for k in range(1, len(lane) - 1):
                pick, carry, put = lane[k - 1], lane[k], lane[k + 1]
                if carry.skill != "move_with" or carry.object not in wide:
                    continue
                if pick.skill != "pick_up" or put.skill not in ("place", "stack"):
                    continue
                if pick.object != carry.object or put.object != carry.object:
                    continue
                steps = _joined(lanes[b], pick, carry, put)
                if steps:
                    lanes[b] = _insert(lanes[b], steps)
                    converted = True
    if not converted and not _carry_overlaps(lanes):
        return hands
    return HandsProgram(lanes, _carry_overlaps(lanes))


def task_points(trajs: dict[str, Any], hands: HandsProgram) -> dict[str, np.ndarray]:
    """What each arm must reach: where its hand's skills grasp and let go (the TCP and the
    objects at the start and end of every step that handles an object; either arm may press an
    object), below :data:`Z_CAP`. The carries between are planned low over the objects."""
    out = {}
    for side, lane in hands.lanes.items():
        t = np.asarray(trajs[side].t_s, dtype=np.float64)
        tcp = np.asarray(trajs[side].tcp, dtype=np.float64)
        objs = np.asarray(trajs[side].object_position, dtype=np.float64)
        idx = [
            int(np.clip(np.searchsorted(t, x), 0, len(t) - 1))
            for s in lane
            if s.skill in ACTING and s.skill != "move_with"
            for x in (s.start_s, s.end_s)
        ]
        p = np.concatenate([tcp[idx], *(o[idx] for o in objs)]) if idx else tcp
        p = p[np.all(np.isfinite(p), axis=1)]
        p[:, 2] = np.minimum(p[:, 2], Z_CAP)
        out[side] = p if len(p) else tcp
    return out


def _units(hands: HandsProgram, fits: set[str]) -> list[tuple[float, str, Any]]:
    """``(start, side or "both", run of step indices or the carry point)`` in time order; a
    two-handed carry of an object in ``fits`` (one gripper closes across it) is one arm's."""
    from .two_arm_carry import carry_steps

    units: list[tuple[float, str, Any]] = []
    covered: set[tuple[str, int]] = set()
    for p in hands.sync:
        if p.kind != "carry":
            continue
        steps = carry_steps(hands, p)
        covered |= {(s, k) for s, ks in steps.items() for k in ks}
        start = min(hands.lanes[s][ks[0]].start_s for s, ks in steps.items())
        if p.object in fits:  # one gripper holds it: the arm that puts it down carries it
            side = max(steps, key=lambda s: hands.lanes[s][steps[s][2]].end_s)
            units.append((start, side, list(steps[side])))
        else:
            units.append((start, "both", p))
    for side, lane in hands.lanes.items():
        run: list[int] = []
        for k, s in enumerate([*lane, Segment("move", 1e9, 1e9)]):
            if s.skill in ACTING and (side, k) not in covered:
                run.append(k)
                continue
            if run:
                units.append((lane[run[0]].start_s, side, run))
                run = []
    return sorted(units, key=lambda u: u[0])


def rest_pose(
    base: np.ndarray,
    other: np.ndarray | None,
    centre: np.ndarray,
    top: float,
    frames: DemoFrames,
    avoid: np.ndarray | None = None,
) -> np.ndarray:
    """An idle arm's rest (``[x, y, z, yaw]``): :data:`REST_REACH` from its own base (at most
    :data:`REST_FRACTION` of the way to the objects' ``centre``), in the direction, within
    :data:`REST_MAX_TURN` of the objects', farthest from where the other arm works: the points
    ``avoid`` (where the skills act) and the other arm's reach to them (the segments from its
    base ``other`` to them; None: straight towards the objects); its fingertips at least 5 cm
    over every object's top (``top``), the wrist turned as it turns least."""
    to = centre[:2] - base[:2]
    dist = float(np.hypot(*to))
    u = to / dist if dist > 1e-9 else np.array([1.0, 0.0])
    h = min(REST_REACH, REST_FRACTION * dist) if dist > 1e-9 else REST_REACH
    best = base[:2] + u * h
    if other is not None:
        pts = np.array([centre[:2], *(() if avoid is None else np.asarray(avoid)[:, :2])])
        pts = pts[np.all(np.isfinite(pts), axis=1)]
        score = -np.inf
        turns = sorted(np.arange(-REST_MAX_TURN_DEG, REST_MAX_TURN_DEG + 1, 10.0), key=abs)
        for turn in np.radians(turns):
            c, sn = np.cos(turn), np.sin(turn)
            xy = base[:2] + h * np.array([c * u[0] - sn * u[1], sn * u[0] + c * u[1]])
            # the distance to the other arm: to its base-to-point segments (its links over them)
            d = pts - other[:2]
            w = np.clip(((xy - other[:2]) @ d.T) / np.maximum((d * d).sum(axis=1), 1e-12), 0, 1)
            near = float(np.min(np.hypot(*(other[:2] + w[:, None] * d - xy).T)))
            if near > score + 1e-6:  # (ties: the least turned, tried first in |turn| order)
                score, best = near, xy
    z = max(REST_Z, top + frames.robot.finger_below_tcp + 0.05)
    p = np.array([best[0], best[1], z])
    return np.array([*p, float(frames.natural_yaw(p))])


def within_reach(points: np.ndarray, base: np.ndarray, arm: Any) -> np.ndarray:
    """TCP points (n, 3; top-down) pulled in horizontally towards ``base`` where their wrist
    would be farther than the arm's reach (:attr:`~lfd.reproduce.arm.Robot.reach`, 0.55 m for
    a ViperX) from its shoulder: a person ends a take holding the object where a small arm
    cannot (the IK then lags behind, and the object ends off its goal)."""
    out = np.array(points, dtype=np.float64, copy=True)
    dz = out[:, 2] + arm.tcp_offset - (base[2] + arm.shoulder_z)
    room = np.sqrt(np.maximum(arm.reach[1] ** 2 - dz**2, 0.0))
    d = out[:, :2] - base[:2]
    h = np.hypot(d[:, 0], d[:, 1])
    far = h > room
    out[far, :2] = base[:2] + d[far] * (room[far] / h[far])[:, None]
    return out


def clear_of_base(
    points: np.ndarray, fixed: np.ndarray, base: np.ndarray, radius: float
) -> np.ndarray:
    """TCP points (n, 3) pushed out horizontally to at least ``radius`` (m) from another arm's
    ``base``, the radius no more than the distance of every point ``fixed`` (a mask: the
    skills' own ticks, which stay where they are; the path stays continuous)."""
    out = np.array(points, dtype=np.float64, copy=True)
    d = out[:, :2] - base[:2]
    h = np.hypot(d[:, 0], d[:, 1])
    r = min(radius, float(h[fixed].min()) if fixed.any() else radius)
    near = (h < r) & (h > 1e-9)
    out[near, :2] = base[:2] + d[near] * (r / h[near])[:, None]
    return out


def transit_to_first(
    cur: np.ndarray, seg: Segment, frames: DemoFrames, scene: dict[str, np.ndarray]
) -> np.ndarray:
    """An arm's move (states ``[x, y, z, yaw]``) from ``cur`` (its rest) to above where a
    unit's first step ``seg`` begins: up, across at the rest's height or
    :data:`TRANSIT_CLEAR` over the object the step handles (its pose in the robot's ``scene``;
    else where the hand began the step), then down to that height over it. The one-arm
    planner then goes from there: not the human hand's path from wherever it was, which
    sweeps through the other arm's side."""
    if seg.object is not None and seg.object in scene:
        T = scene[seg.object]
        size = frames.size[frames.object_index(seg.object)]
        xy, top = T[:2, 3], float(T[2, 3] + size[2] / 2)
    else:
        xy, top = frames.tcp_pose(frames.index(seg.start_s))[:2, 3], 0.0
    z = top + frames.robot.finger_below_tcp + TRANSIT_CLEAR
    high = max(cur[2], z)
    goal = np.array([xy[0], xy[1], z, 0.0])
    goal[3] = float(wrap_near(float(frames.natural_yaw(goal[:3])), cur[3]))
    up, over = cur.copy(), goal.copy()
    up[2] = over[2] = high
    legs = [line(cur, up, min_s=0.2), line(up, over)[1:], line(over, goal, min_s=0.3)[1:]]
    return np.concatenate(legs)


def _held_name(segs: list[Segment]) -> str | None:
    """The object a run of steps ends holding (its last step a ``pick_up`` or ``move_with``)."""
    last = segs[-1] if segs else None
    return last.object if last is not None and last.skill in ("pick_up", "move_with") else None


def _initial(f: DemoFrames, i0: int, moved: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Every object at rest on the table below where it starts (at sample ``i0``), or where
    the layout puts it (``moved``)."""
    initial = {}
    for n in f.names:
        T = upright(f.object_pose(n, i0))
        T[2, 3] = f.size[f.object_index(n), 2] / 2
        initial[n] = T
    initial.update({n: upright(T) for n, T in moved.items()})
    return initial


def plan_sequence(
    trajs: dict[str, Any],
    hands: HandsProgram,
    mode: str,
    bases: dict[str, np.ndarray],
    robot: TwoArmRobot,
    moved: dict[str, np.ndarray] | None = None,
) -> dict[str, tuple[DemoFrames, dict[str, np.ndarray], Any]]:
    """Both lanes' plans, unit after unit (the module docstring): ``{side: (frames, initial
    poses, PlanResult)}`` as :func:`~lfd.reproduce.displacement.plan_layout` gives one lane;
    ``moved``: objects where a layout puts them (each unit starts from where the layout and the
    units before left the objects). A lane's scenes: the objects after each unit it acts in."""
    from .modes import PlanResult

    sides = list(hands.lanes)
    frames = {s: DemoFrames(trajs[s], bases[s], robot.ik) for s in sides}
    f = frames[sides[0]]
    i0 = f.index(min(hands.lanes[s][0].start_s for s in sides if hands.lanes[s]))
    initial = _initial(f, i0, moved or {})
    centre = np.mean([T[:3, 3] for T in initial.values()], axis=0)
    top = max(T[2, 3] + f.size[f.object_index(n), 2] / 2 for n, T in initial.items())
    # where the skills act (both hands) and the objects start: the idle arm rests away from them
    avoid = np.concatenate(
        [*task_points(trajs, hands).values(), [T[:3, 3] for T in initial.values()]]
    )
    others = {s: next((bases[o] for o in sides if o != s), None) for s in sides}
    rest = {s: rest_pose(bases[s], others[s], centre, top, frames[s], avoid) for s in sides}
    cur = dict(rest)
    parts: dict[str, list[Plan]] = {s: [_hold(rest[s], TICK, -1)] for s in sides}
    scene = dict(initial)
    scenes: dict[str, list[dict[str, np.ndarray]]] = {s: [] for s in sides}
    widest = grasp_max_width(robot.ik)
    fits = {n for k, n in enumerate(f.names) if float(min(f.size[k, :2])) <= widest}
    for _, who, unit in _units(hands, fits):
        ticks = max(sum(len(q) for q in parts[s]) for s in sides)
        for s in sides:  # one unit at a time: every arm waits for the one before to end
            have = sum(len(q) for q in parts[s])
            if have < ticks:
                parts[s].append(_hold(cur[s], (ticks - have) * TICK, -1))
        if who == "both":
            blocks, T_end = carry_unit(frames, hands, unit, mode, cur, scene, robot)
            scene[str(unit.object)] = T_end
            done = {s: True for s in blocks}
        else:
            segs = [hands.lanes[who][k] for k in unit]
            lead = None
            if np.allclose(cur[who], rest[who]):  # from its rest: over to the first step
                lead = Plan.of_path(transit_to_first(cur[who], segs[0], frames[who], scene), -1)
                lead.opening[:] = robot.ik.max_opening
                cur[who] = np.array([*lead.position[-1], lead.yaw[-1]])
            res = _lane_part(frames[who], segs, mode, scene, start=cur[who], cap=Z_CAP)
            plan = res.plan
            seg = np.where(plan.segment >= 0, plan.segment + unit[0], -1)
            position = within_reach(plan.position, bases[who], robot.ik)
            moving = np.isin(
                plan.segment, [k for k, g in enumerate(segs) if g.skill == "move_with"]
            )
            for o in sides:  # the carries away from the other arm's base (where it rests)
                if o != who:
                    position = clear_of_base(position, ~moving, bases[o], OTHER_BASE_CLEAR)
            done = {who: segs[-1].skill not in ("pick_up", "move_with")}
            if not done[who]:  # it ends holding the object: where the pulled-in gripper holds it
                shift = position[-1] - plan.position[-1]
                held = _held_name(segs)
                if held is not None and held in res.expected:
                    T = res.expected[held].copy()
                    T[:3, 3] += shift
                    res.expected[held] = T
            block = Plan(position, plan.yaw, plan.opening, seg)
            blocks = {who: block if lead is None else Plan.concat([lead, block])}
            scene.update(res.expected)
        for s in blocks:
            scenes[s].append(dict(scene))
        for s, block in blocks.items():
            # a person lifts an object to look at it higher than a small arm reaches: the
            # path is flattened there (both arms of a carry alike: they stay rigid)
            block.position[:, 2] = np.minimum(block.position[:, 2], Z_CAP)
            parts[s].append(block)
            cur[s] = np.array([*block.position[-1], block.yaw[-1]])
            if done[s]:  # back to its rest, over the objects
                up = cur[s].copy()
                up[2] = max(up[2], rest[s][2])
                home = rest[s].copy()
                home[3] = float(wrap_near(home[3], up[3]))
                back = np.concatenate([line(cur[s], up, min_s=0.3), line(up, home)[1:]])
                parts[s].append(Plan.of_path(back, -1, robot.ik.max_opening))
                cur[s] = rest[s].copy()
    out = {}
    for s in sides:
        plan = Plan.concat(parts[s])
        result = PlanResult(plan, dict(scene), [], hands.program(s), scenes[s] or [dict(scene)])
        out[s] = (frames[s], initial, result)
    return out
