"""A two-handed carry on two arms (the ``carry`` synchronisation point of a
:class:`~lfd.reproduce.program.HandsProgram`: both hands ``move_with`` one object at once).

How the two arms carry it (docs/reproduce.md, "Two arms"):

* **Hold**: each arm presses the object with its closed gripper on the face towards its base,
  the two faces opposite (where the hands held a box carried between them: each hand on its
  side), along the face where its hand held it; the pads are commanded :data:`SQUEEZE_DEPTH` inside the face, so the two arms squeeze
  it between them. A squeeze needs no grasp that fits the gripper: a 28 cm box 65 mm wide (the
  simulator's ``carry``) is held at its ends as the two hands held it, where a ViperX gripper,
  opening 69 mm, could not close across it with room for its fingers.
* **Object path**: one trajectory of the object from where it lies to its goal (the demonstrated
  end pose of the ``place``, on the table or following its reference, Eq. 2): skills mode lifts
  it (:data:`LIFT`, over the other objects), carries it straight and lowers it; DMP mode rolls out
  a DMP of the demonstrated object motion from the robot's start to that goal.
* **Both arms**: each TCP rigidly offset from the object (its press pose in the object's frame),
  the two paths time-scaled together (:func:`~lfd.reproduce.timescale.retime_together`: the
  same clock, the limits of both arms). Before it, each arm's steps before its ``pick_up``
  (the one-arm planner) and an approach beside its face (above it, then down, closed); the first
  arm there waits for the other, both press in together. After it, both release the squeeze
  slowly back to the faces (:data:`RELAX_S`), then back off the faces and rise together, then
  each arm's steps after its ``place``.
* **Skills**: the approach and press are the ``pick_up``, the lift and transport the
  ``move_with``, the lowering the ``place`` of each arm's lane, so the one-arm checks
  (:func:`~lfd.reproduce.outcome.skill_results`: lifted, not slipping, placed) judge each arm.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from ..errors import DemonstrationError
from .aloha import TwoArmRobot
from .arm import Limits
from .controller import TICK, Plan
from .dmp import dmp_rollout, min_jerk
from .goals import PALM_CLEARANCE, DemoFrames, pose, upright, wrap_near, yaw_of
from .motion import line
from .program import HandsProgram, Segment, SyncPoint, TaskProgram

SQUEEZE_DEPTH = 0.012
"""How far inside the object's face each pressing TCP is commanded (m): the position servos
then squeeze it between the two grippers."""
MIN_TCP_GAP = 0.075
"""The two pressing TCPs are commanded at least this far apart (m; the squeeze shallower on a
narrower object): nearer, the two wrists above them touch (a 74 mm wine glass's box)."""
STANDOFF = 0.03
"""The approach ends this far outside the face (m) before pressing in."""
ABOVE = 0.03
"""An approach passes this far above the object's top (m, the fingertips)."""
LIFT = 0.06
"""Skills mode: the carried object's lowest point rises at least this far (m), and 2 cm over
every other object's top."""
PRESS_S = 0.6
"""Time (s) of the press in and of the back-off."""
SETTLE_S = 0.3
"""Time (s) held still after pressing in, after setting down and after releasing."""
RELAX_S = 0.6
"""Time (s) in which both arms release the squeeze (back to the faces) before backing off:
released at once, the arms' different lags kick the object aside."""
TABLE_MARGIN = 0.006
"""The fingertips of a pressing gripper stay this far above the table (m)."""
SQUEEZE_SPEED = 0.2
"""Largest TCP speed (m/s) of the two arms while they squeeze an object between them: faster,
the arms' lag differs and the squeezed object slips or turns out (real mugs and a teapot)."""
SQUEEZE_ACCELERATION = 0.5
"""Largest TCP acceleration (m/s^2) while squeezing."""
DMP_ABOVE = 0.02
"""DMP mode: the carried object's DMP ends this far above its goal (m), then it is lowered
straight down (a DMP arriving low may drag it over the table)."""


def carry_points(hands: HandsProgram) -> list[SyncPoint]:
    return [p for p in hands.sync if p.kind == "carry"]


def carry_steps(hands: HandsProgram, p: SyncPoint) -> dict[str, tuple[int, int, int]]:
    """Each hand's ``(pick_up, move_with, place)`` step indices of the carry ``p``.

    Raises
    ------
    DemonstrationError
        A hand's ``move_with`` is not between its own ``pick_up`` and ``place`` of the object
        (one line).
    """
    out = {}
    for side, k in ((p.hand, p.step), (p.other, p.other_step)):
        lane = hands.lanes[side]
        before = lane[k - 1] if k > 0 else None
        after = lane[k + 1] if k + 1 < len(lane) else None
        ok_b = before is not None and before.skill == "pick_up" and before.object == p.object
        ok_a = after is not None and after.skill in ("place", "stack") and after.object == p.object
        if not (ok_b and ok_a):
            what = f"its step before is {before.skill if before else 'none'}"
            what += f", after {after.skill if after else 'none'}"
            raise DemonstrationError(
                f"{p.describe(hands.lanes)}: two arms carry an object only between each hand's "
                f"pick_up and place of it (the {side} hand's move_with {k}: {what})"
            )
        out[side] = (k - 1, k, k + 1)
    return out


def check_carries(hands: HandsProgram) -> None:
    """Refuse, in one line, a two-handed carry the two arms do not run: one whose
    ``move_with`` is not between each hand's ``pick_up`` and ``place`` of the object."""
    for p in carry_points(hands):
        carry_steps(hands, p)


def _state(T: np.ndarray) -> np.ndarray:
    return np.array([*T[:3, 3], yaw_of(T[:3, :3])])


def press_poses(
    frames: dict[str, DemoFrames],
    name: str,
    i: int,
    robot: TwoArmRobot,
    T_obj: np.ndarray | None = None,
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Each arm's press pose and approach pose (``[x, y, z, yaw]`` in the object's frame): on
    opposite faces, each arm on the face towards its base (``frames[side].base``) as the object
    lies in the robot's scene (``T_obj``; default its demonstrated pose at sample ``i``: the
    robot's object may lie turned), both pads at the same place along the face: the mean of
    where the two hands held it at sample ``i`` (within the face; two pads pressing at
    different places would turn the object between them)."""
    sides = list(frames)
    f = frames[sides[0]]
    size = f.size[f.object_index(name)]
    T_o = upright(f.object_pose(name, i))
    held = {s: (np.linalg.inv(T_o) @ frames[s].tcp_pose(i))[:3, 3] for s in sides}
    T_r = T_o if T_obj is None else upright(T_obj)
    # the faces: those at the ends of the axis along which the two hands held it apart (the
    # same faces however the robot's object lies), else (a hand that did not hold it is anywhere) the
    # axis of the object, as it lies in the robot's scene, that points most from one base to
    # the other; each arm on the face towards its base
    gap = T_r[:3, :3].T @ (frames[sides[0]].base - frames[sides[1]].base)
    axis = _held_axis(held, size)
    if axis is None:
        axis = int(np.argmax(np.abs(gap[:2])))
    other = 1 - axis
    arm = robot.ik
    # low on the face (the fingertips just above the table): pressed high, a tall object tips;
    # but the palm above the pads clears the top (pressing its edge, it would tip it too)
    z = max(
        -size[2] / 2 + arm.finger_below_tcp + TABLE_MARGIN,
        size[2] / 2 - arm.palm_above_tcp + PALM_CLEARANCE,
    )
    out = {}
    depth = float(np.clip((size[axis] + 2 * arm.finger_half_x - MIN_TCP_GAP) / 2, 0, SQUEEZE_DEPTH))
    free = max(0.0, size[other] / 2 - 0.012)
    along = float(np.clip(np.mean([held[s][other] for s in sides]), -free, free))
    for s in sides:
        sign = float(np.sign(gap[axis]) or 1.0) * (1.0 if s == sides[0] else -1.0)
        c = np.zeros(3)
        c[axis] = sign * (size[axis] / 2 + arm.finger_half_x - depth)
        c[other] = along
        c[2] = z
        # the closing axis along the face: the two closed pads side by side on it
        yaw = np.pi / 2 if axis == 0 else 0.0
        out_c = c.copy()
        out_c[axis] += sign * (depth + STANDOFF)
        out[s] = (np.array([*c, yaw]), np.array([*out_c, yaw]))
    return out


def _held_axis(held: dict[str, np.ndarray], size: np.ndarray) -> int | None:
    """The horizontal axis of the object (0: x, 1: y) along which the two hands held it apart
    (``held``: each TCP in the object's frame): on opposite sides of its centre, at least half
    its length along that axis apart; None when they did not (a hand anywhere)."""
    a, b = held.values()
    axis = int(np.argmax(np.abs((a - b)[:2])))
    opposite = np.sign(a[axis]) != np.sign(b[axis])
    return axis if opposite and abs(a[axis] - b[axis]) >= size[axis] / 2 else None


def _in_world(obj: np.ndarray, rel: np.ndarray) -> np.ndarray:
    """TCP states ``[x, y, z, yaw]`` (n, 4) of a pose ``rel`` in the frame of object states
    ``obj`` (n, 4); the yaw continuous with the object's."""
    c, s = np.cos(obj[:, 3]), np.sin(obj[:, 3])
    x = obj[:, 0] + c * rel[0] - s * rel[1]
    y = obj[:, 1] + s * rel[0] + c * rel[1]
    return np.column_stack([x, y, obj[:, 2] + rel[2], obj[:, 3] + rel[3]])


def _hold(state: np.ndarray, seconds: float, seg: int) -> Plan:
    return Plan.of_path(np.repeat(state[None], max(1, round(seconds / TICK)), 0), seg)


def object_path(
    frames: DemoFrames,
    name: str,
    start: np.ndarray,
    goal: np.ndarray,
    span: tuple[int, int],
    place_start_s: float,
    objects: dict[str, np.ndarray],
    mode: str,
) -> tuple[np.ndarray, int]:
    """The carried object's states from ``start`` to ``goal`` (``[x, y, z, yaw]``) and the index
    where its lowering (the ``place``) begins. ``span``: the demonstrated carry's samples."""
    size = frames.size[frames.object_index(name)]
    goal = goal.copy()
    # a box turned half a turn occupies the same space (the goal's symmetry): turned at most a
    # quarter, the arms pressing it never swap sides
    goal[3] = start[3] + float(wrap_near(goal[3] - start[3], 0.0, np.pi))
    tops = [
        T[2, 3] + frames.size[frames.object_index(n), 2] / 2
        for n, T in objects.items()
        if n != name
    ]
    bottom = min(start[2], goal[2]) - size[2] / 2
    rise = max(LIFT, max(tops, default=0.0) + 0.02 - bottom)
    if mode == "dmp":
        i0, i1 = span
        t = frames.t[i0 : i1 + 1]
        demo = np.array([_state(upright(frames.object_pose(name, i))) for i in range(i0, i1 + 1)])
        demo[:, 3] = np.unwrap(demo[:, 3])
        above = goal + np.array([0.0, 0.0, DMP_ABOVE, 0.0])
        path = dmp_rollout(t, demo, start, above, dt=TICK)
        # no higher than skills mode lifts it (a person lifts it far higher), never into the
        # table, and the yaw turned smoothly (the hands' yaw wobbles; the squeeze must not)
        high = max(start[2], goal[2]) + rise
        path[:, 2] = np.clip(path[:, 2], size[2] / 2, max(high, above[2]))
        path[:, 3] = start[3] + min_jerk(len(path)) * (above[3] - start[3])
        k = int(np.clip(round((place_start_s - t[0]) / TICK), 1, len(path) - 1))
        # a DMP may arrive low beside another object: it ends above the goal and lowers straight
        down = line(path[-1], goal, min_s=0.5)[1:]
        return np.concatenate([path, down]), k
    up = start + np.array([0.0, 0.0, rise, 0.0])
    over = goal + np.array([0.0, 0.0, rise, 0.0])
    a, b = line(start, up, min_s=0.6), line(up, over)[1:]
    c = line(over, goal, min_s=0.8)[1:]
    return np.concatenate([a, b, c]), len(a) + len(b)


def _lane_part(
    frames: DemoFrames,
    segs: list[Segment],
    mode: str,
    objects: dict[str, Any],
    start: np.ndarray | None = None,
    cap: float | None = None,
) -> Any:
    """The one-arm plan (:func:`~lfd.reproduce.modes.plan_task`) of some of a lane's steps,
    from ``start`` (``[x, y, z, yaw]``; default where the hand was), its TCP no higher than
    ``cap`` (m); None without steps."""
    planner = lane_planner(frames, segs, mode, objects, start)
    if planner is None:
        return None
    result = planner.plan()
    if cap is not None:
        result.plan.position[:, 2] = np.minimum(result.plan.position[:, 2], cap)
    if planner.held is not None:  # the steps end holding it: where the gripper holds it
        name, rel = planner.held
        end = pose(result.plan.position[-1], float(result.plan.yaw[-1]))
        result.expected[name] = end @ np.linalg.inv(rel)
    return result


def lane_planner(
    frames: DemoFrames,
    segs: list[Segment],
    mode: str,
    objects: dict[str, Any],
    start: np.ndarray | None = None,
) -> Any:
    """The one-arm planner (``modes._TaskPlanner``) of some of a lane's steps, from ``start``
    (``[x, y, z, yaw]``; default where the hand was); None without steps."""
    from .modes import _TaskPlanner, check_grasps, repair_program

    if not segs:
        return None
    program = repair_program(frames, TaskProgram(list(segs)))
    if mode != "replay":
        check_grasps(frames, program)
    planner = _TaskPlanner(frames, program, mode, dict(objects))
    if start is not None:
        planner.cur = start.copy()
    return planner


def carry_unit(
    frames: dict[str, DemoFrames],
    hands: HandsProgram,
    p: SyncPoint,
    mode: str,
    cur: dict[str, np.ndarray],
    scene: dict[str, np.ndarray],
    robot: TwoArmRobot,
) -> tuple[dict[str, Plan], np.ndarray]:
    """Both arms' plans of the two-handed carry ``p`` from their states ``cur`` (``[x, y, z,
    yaw]``) with the objects at ``scene`` (see the module docstring): the approach (each arm's
    ``pick_up``), the first there waiting for the other, the press, the carry, the set-down and
    the back-off, on one clock (both plans of one length); and the object's end pose."""
    from .modes import _place_goal
    from .timescale import retime_together

    steps = carry_steps(hands, p)
    sides = [p.hand, p.other]
    name = str(p.object)
    f = frames[sides[0]]
    size = f.size[f.object_index(name)]
    T0 = upright(scene[name])
    # when both hold it (the later grasp), and the demonstrated carry to the end of the place
    both = max(hands.lanes[s][steps[s][0]].end_s for s in sides)
    ends = {s: hands.lanes[s][steps[s][2]] for s in sides}
    last = max(sides, key=lambda s: ends[s].end_s)
    i_both, i_end = f.index(both), frames[last].index(ends[last].end_s)
    press = press_poses(frames, name, i_both, robot, T0)
    y0 = yaw_of(T0[:3, :3])
    for s in sides:  # the gripper is symmetric: the yaw the wrist reaches most easily there
        p_in, p_out = press[s]
        at = _in_world(_state(T0)[None], p_in)[0]
        turn = float(wrap_near(y0 + p_in[3], float(frames[s].natural_yaw(at[:3])))) - y0 - p_in[3]
        press[s] = (p_in + np.array([0, 0, 0, turn]), p_out + np.array([0, 0, 0, turn]))
    before = {s: _approach(cur[s], T0, press[s][1], size, steps[s][0], robot) for s in sides}
    n = max(len(b) for b in before.values())
    for s in sides:  # the first arm there waits beside its face for the other
        last_state = np.array([*before[s].position[-1], before[s].yaw[-1]])
        if len(before[s]) < n:
            before[s] = Plan.concat([before[s], _hold(last_state, (n - len(before[s])) * TICK, -1)])
    # the object's path and both arms on it, time-scaled together
    place = hands.lanes[last][steps[last][2]]
    _, _, T_end = _place_goal(frames[last], place, dict(scene), None, i_end)
    T_end = upright(T_end)
    obj, k_low = object_path(
        f, name, _state(T0), _state(T_end), (i_both, i_end), place.start_s, scene, mode
    )
    o0, o1 = obj[:1], obj[-1:]
    T_end = pose(obj[-1, :3], float(obj[-1, 3]))  # the goal, as turned (its symmetry)
    blocks = []
    for s in sides:
        k_pick, k_with, k_place = steps[s]
        tcp_out0 = _in_world(o0, press[s][1])[0]
        tcp_in0 = _in_world(o0, press[s][0])[0]
        path = _in_world(obj, press[s][0])
        back = _in_world(o1, press[s][1])[0]
        relax = _in_world(o1, _touch(press[s]))[0]
        up = back.copy()
        up[2] = max(up[2], float(o1[0, 2] + size[2] / 2) + robot.ik.finger_below_tcp + ABOVE)
        blocks.append(
            Plan.concat(
                [
                    Plan.of_path(line(tcp_out0, tcp_in0, min_s=PRESS_S), k_pick),
                    _hold(tcp_in0, SETTLE_S, -1),
                    Plan.of_path(path[:k_low], k_with),
                    Plan.of_path(path[k_low:], k_place),
                    _hold(path[-1], SETTLE_S, -1),
                    Plan.of_path(line(path[-1], relax, min_s=RELAX_S)[1:], -1),
                    _hold(relax, SETTLE_S, -1),
                    Plan.of_path(line(relax, back, min_s=PRESS_S)[1:], -1),
                    Plan.of_path(line(back, up, min_s=0.4)[1:], -1),
                ]
            )
        )
    blocks = retime_together(blocks, [squeeze_limits(robot.arms[s].limits) for s in sides])
    return {s: Plan.concat([before[s], b]) for s, b in zip(sides, blocks, strict=True)}, T_end


def _touch(press: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """The pose (in the object's frame) between a press pose and its approach pose where the
    pads touch the face without squeezing: the squeeze released before backing off."""
    p_in, p_out = press
    d = float(np.linalg.norm(p_out[:2] - p_in[:2]))
    return p_in + (p_out - p_in) * (max(d - STANDOFF, 0.0) / max(d, 1e-9))


def squeeze_limits(limits: Limits) -> Limits:
    """An arm's limits while it squeezes an object with the other: at most
    :data:`SQUEEZE_SPEED` and :data:`SQUEEZE_ACCELERATION`."""
    return replace(
        limits,
        speed=min(limits.speed, SQUEEZE_SPEED),
        acceleration=min(limits.acceleration, SQUEEZE_ACCELERATION),
    )


def _approach(
    cur: np.ndarray,
    T_obj: np.ndarray,
    out_rel: np.ndarray,
    size: np.ndarray,
    k: int,
    robot: TwoArmRobot,
) -> Plan:
    """From ``cur`` up over the object, then down beside its face to the press approach pose
    (``out_rel`` in the object's frame), the gripper closed (open fingers reaching down beside
    the object touch it, or the other arm's gripper on a small one)."""
    goal = _in_world(_state(T_obj)[None], out_rel)[0]
    top = T_obj[2, 3] + size[2] / 2
    hover_z = max(cur[2], top + robot.ik.finger_below_tcp + ABOVE)
    up = np.array([*cur[:3], cur[3]])
    up[2] = hover_z
    above = goal.copy()
    above[2] = hover_z
    path = np.concatenate(
        [line(cur, up, min_s=0.3), line(up, above)[1:], line(above, goal, min_s=0.6)[1:]]
    )
    return Plan.of_path(path, k)
