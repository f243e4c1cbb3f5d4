"""A hold by pressing, on two arms: one hand holds an object still (a ``hold_until`` of a
:class:`~lfd.reproduce.program.HandsProgram`) that the robot's gripper cannot close across
(the simulator's ``hold_stack`` plank, 65 mm at its narrowest, for a ViperX gripper that takes
objects up to 61 mm).

A hold keeps the object still while the other arm acts on it; a press does the same: the
holding arm comes down, gripper closed, on the object's top at the end where its hand held
it (Eq. 2; :data:`PRESS_EDGE` inside the top's edges, leaving the most room to the other arm)
and presses :data:`PRESS_DEPTH` into it, so the
friction with the table keeps it where it lies; after the other arm's step it rises again.
Its lane's ``pick_up`` is the approach and press, its ``move_with`` the holding still, its
``place`` the lift off; the steps before and after are the one-arm planner's. The gripper's
closing axis lies across the object's longer side, so the pressing fingers take as little of
it as they can (the other arm stacks or acts on the rest).

An object the gripper can close across is held by a grasp, as before
(:func:`~lfd.reproduce.displacement.plan_layout`), unless the other arm stacks meanwhile: a
grasp's ``pick_up`` lifts the object off the table, and the box stacked on a lifted plank lands
where the plank was held, not where it rests after (the two Pandas, whose hands close across
the plank, stacked 36-46 mm off target so). A hold whose gripper comes too near the
other arm (:mod:`.two_arm_holds`) is pressed instead at the end of the top farthest from
the other arm's step, whichever axis (``away``, :func:`press_pose`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .aloha import TwoArmRobot
from .controller import TICK, Plan
from .goals import DemoFrames, grasp_max_width, upright, wrap_near, yaw_of
from .motion import line
from .program import HandsProgram, SyncPoint

PRESS_DEPTH = 0.002
"""How far below the object's top the fingertips are commanded (m)."""
PRESS_EDGE = 0.015
"""The pressing fingertips stay this far inside the top's edges (m)."""
ABOVE = 0.03
"""The press is approached from this far above the top (m, fingertips), vertically."""


def press_holds(
    hands: HandsProgram, sizes: dict[str, np.ndarray], robot: TwoArmRobot
) -> dict[str, SyncPoint]:
    """The ``hold_until`` points whose held object is too wide for the gripper (every
    horizontal side wider than :func:`~lfd.reproduce.goals.grasp_max_width`) or is held while
    the other arm stacks (on it), by holding hand, when its lane holds it between its own
    ``pick_up`` and ``place`` (else the grasp is planned, and refused as ever)."""
    out = {}
    widest = grasp_max_width(robot.ik)
    for p in hands.sync:
        if p.kind != "hold_until" or p.object not in sizes:
            continue
        other = hands.lanes[p.other]
        under = p.other_step < len(other) and other[p.other_step].skill == "stack"
        if float(min(sizes[p.object][:2])) <= widest and not under:
            continue
        lane = hands.lanes[p.hand]
        k = p.step
        if (
            0 < k < len(lane) - 1
            and lane[k - 1].skill == "pick_up"
            and lane[k + 1].skill == "place"
        ):
            if lane[k - 1].object == lane[k + 1].object == p.object:
                out[p.hand] = p
    return out


def press_pose(
    frames: DemoFrames,
    name: str,
    i: int,
    T_obj: np.ndarray,
    away: np.ndarray | None = None,
) -> np.ndarray:
    """The pressing TCP state ``[x, y, z, yaw]``: where the hand held the object at sample ``i``
    (relative to it, Eq. 2, inside its top), on the object now at ``T_obj``. ``away`` (world
    points, the other arm's path): the press is centred at the end of the top farthest from
    them instead (either axis), the gripper's closing axis across that end."""
    size = frames.size[frames.object_index(name)]
    T_demo = upright(frames.object_pose(name, i))
    held = (np.linalg.inv(T_demo) @ frames.tcp_pose(i))[:3, 3]
    free = np.maximum(size[:2] / 2 - PRESS_EDGE, 0.0)
    xy = np.clip(held[:2], -free, free)
    long_axis = 0 if size[0] >= size[1] else 1
    # at the end of the object on the hand's side: the most room for the other arm
    xy[long_axis] = (1.0 if held[long_axis] >= 0 else -1.0) * free[long_axis]
    T = upright(T_obj)
    if away is not None and len(away):
        xy, long_axis = _far_end(T, free, np.asarray(away, dtype=np.float64)[:, :2])
    world = T[:3, :3] @ np.array([*xy, 0.0]) + T[:3, 3]
    top = T[2, 3] + size[2] / 2
    z = top + frames.robot.finger_below_tcp - PRESS_DEPTH
    yaw = yaw_of(T[:3, :3]) + (np.pi / 2 if long_axis == 0 else 0.0)
    yaw = float(wrap_near(yaw, float(frames.natural_yaw(world))))
    return np.array([world[0], world[1], z, yaw])


def _far_end(T: np.ndarray, free: np.ndarray, away: np.ndarray) -> tuple[np.ndarray, int]:
    """Of the four ends of an upright object's top (``free``: the half extents a press may
    use), the one farthest from the points ``away`` (x, y), in the object's frame, and its
    axis."""
    best: tuple[float, np.ndarray, int] | None = None
    for axis in (0, 1):
        for sign in (1.0, -1.0):
            xy = np.zeros(2)
            xy[axis] = sign * free[axis]
            world = T[:2, :2] @ xy + T[:2, 3]
            d = float(np.min(np.linalg.norm(away - world, axis=1)))
            if best is None or d > best[0] + 1e-9:
                best = (d, xy, axis)
    assert best is not None
    return best[1], best[2]


def plan_press_lane(
    traj: Any,
    hands: HandsProgram,
    point: SyncPoint,
    mode: str,
    base: np.ndarray,
    robot: TwoArmRobot,
    moved: dict[str, np.ndarray] | None = None,
    away: np.ndarray | None = None,
) -> tuple[DemoFrames, dict[str, np.ndarray], Any]:
    """The holding lane of ``point`` with its hold done by pressing (the module docstring), as
    :func:`~lfd.reproduce.displacement.plan_layout` gives a lane: ``(frames, initial poses,
    PlanResult)``; ``moved``: objects where a layout puts them (upright 4x4 poses), the press
    and the steps re-grounded there. The steps after the press are planned with the objects
    where the steps before leave them. ``away``: as :func:`press_pose`'s."""
    from .modes import PlanResult
    from .timescale import retime
    from .two_arm_carry import _lane_part

    side, name, k = point.hand, str(point.object), point.step
    lane = hands.lanes[side]
    frames = DemoFrames(traj, base, robot.ik)
    i0 = frames.index(lane[0].start_s)
    initial = {n: upright(frames.object_pose(n, i0)) for n in frames.names}
    initial.update({n: upright(T) for n, T in (moved or {}).items()})
    before = _lane_part(frames, lane[: k - 1], mode, initial)
    mid = dict(initial)  # the objects once the steps before have run (the pressed one still)
    if before is not None:
        mid.update({n: T for n, T in before.expected.items() if n != name})
    if before is not None:
        cur = np.array([*before.plan.position[-1], before.plan.yaw[-1]])
    else:
        j = frames.index(lane[k - 1].start_s)
        cur = np.array([*frames.tcp[j], frames.yaw[j]])
    press = press_pose(frames, name, frames.index(lane[k - 1].end_s), mid[name], away)
    size = frames.size[frames.object_index(name)]
    top = mid[name][2, 3] + size[2] / 2
    hover = press.copy()
    hover[2] = max(cur[2], top + frames.robot.finger_below_tcp + ABOVE)
    up = cur.copy()
    up[2] = max(cur[2], hover[2])
    path = np.concatenate(
        [line(cur, up, min_s=0.3), line(up, hover)[1:], line(hover, press, min_s=0.8)[1:]]
    )
    approach = Plan.of_path(path, k - 1)
    approach.opening[: len(path) // 3] = frames.robot.max_opening
    held_s = max(lane[k].end_s - lane[k].start_s, TICK)
    lift = press.copy()
    lift[2] = hover[2]
    block = retime(
        Plan.concat(
            [
                approach,
                Plan.of_path(np.repeat(press[None], max(1, round(held_s / TICK)), 0), k),
                Plan.of_path(line(press, lift, min_s=0.6)[1:], k + 1),
            ]
        ),
        robot.ik.limits,
    )
    parts = ([before.plan] if before is not None else []) + [block]
    expected = dict(mid)
    after = _lane_part(frames, lane[k + 2 :], mode, mid, start=lift)
    if after is not None:
        seg = np.where(after.plan.segment >= 0, after.plan.segment + k + 2, -1)
        parts.append(Plan(after.plan.position, after.plan.yaw, after.plan.opening, seg))
        expected.update({n: T for n, T in after.expected.items() if n != name})
    plan = Plan.concat(parts)
    scenes = [mid, dict(expected)]
    return frames, initial, PlanResult(plan, expected, [], hands.program(side), scenes)


def plan_lanes(
    trajs: dict[str, Any],
    hands: HandsProgram,
    mode: str,
    bases: dict[str, np.ndarray],
    robot: TwoArmRobot,
) -> dict[str, tuple[DemoFrames, dict[str, np.ndarray], Any]]:
    """Every lane planned alone: a hold of an object too wide for the gripper by pressing
    (:func:`plan_press_lane`), else by the one-arm planner
    (:func:`~lfd.reproduce.displacement.plan_layout`)."""
    from .displacement import plan_layout

    sides = [s for s in hands.sides if s in trajs and s in bases]
    t = trajs[sides[0]]
    sizes = {
        n: np.asarray(s, dtype=np.float64)
        for n, s in zip(t.object_names, t.object_size, strict=True)
    }
    presses = press_holds(hands, sizes, robot)
    return {
        s: plan_press_lane(trajs[s], hands, presses[s], mode, bases[s], robot)
        if s in presses
        else plan_layout(trajs[s], hands.program(s), mode, {}, base=bases[s], robot=robot.ik)
        for s in sides
    }
