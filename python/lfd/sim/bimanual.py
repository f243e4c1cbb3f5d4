"""The two-hand demonstrator: both hands of one person, each performing the seven skills, with
handovers, a two-handed carry and one hand holding an object still while the other acts.

The left hand is the right one mirrored (:class:`~lfd.sim.hand.MirroredKinematics`), its arm
from the left shoulder. Each hand has its own :class:`~lfd.sim.planner.Planner` (its own time,
hand state, grasp and labels) over one table (the object poses are shared); the hands meet at
synchronisation points: one waits (holds still) until the other is there. Labels follow
docs/skills.md "Two hands" (each hand's lane of the seven skills):

- ``handover``: the giver picks an object (a bar, 14-18 cm) up at its end, carries it up to a
  point in the air between the hands; the taker reaches its other end and grasps it
  (``pick_up``, until the handover's ``start_ns``: the taker has grasped it), the giver lets go
  (``place`` from ``start_ns`` to ``end_ns``: the giver has let go) and withdraws (``move``);
  the taker carries it to its side of the table (``move_with``) and puts it down. Either hand
  may give.
- ``carry``: both hands grasp a large box (26-30 cm long) at its ends, each at its own time;
  they lift, carry and lower it together and let go, each at its own time. Both lanes are
  ``move`` / ``pick_up`` / ``move_with`` / ``place`` / ``move`` of the box.
- ``hold_stack``: one hand holds a plank still at one end (``pick_up``, then ``move_with`` of
  the still plank, then ``place``: letting go where it lies) while the other stacks a cube on
  its other half; the holding hand lets go after the stack.
- ``hold_push``: one hand holds a cube still while the other pushes another cube.

Careful and natural styles as for one hand (:class:`~lfd.sim.Variability`); both hands are
sampled by the same estimator model, each with its own noise.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from ..demo import CameraInfo, Demonstration, Handover, SkillLabel
from ..errors import DemonstrationError
from . import natural as nat
from .hand import (
    FINGERTIP_RADIUS,
    GRASP_TYPES,
    POSTURES,
    HandKinematics,
    MirroredKinematics,
    grasp_contacts,
    grasp_posture,
)
from .motion import HandState, Plan, rotation
from .planner import Attach, Detach, ObjectPose, PlannedLabel, Planner, Push, wrap_angle
from .results import BASE_TIME_NS, SIM_VERSION, SimResult, Truth, hand_motion, quat_wxyz
from .scene import (
    DEFAULT_OBJECTS,
    DEMONSTRATOR_SHOULDER,
    LEFT_SHOULDER,
    WORKSPACE_X,
    WORKSPACE_Y,
    ObjectSpec,
    build_scene,
)
from .skills import (
    GRASP_WEIGHTS,
    _deg,
    move,
    move_with,
    pick_up,
    pick_up_entry,
    place,
    push,
    push_entry,
    stack,
)
from .variability import Variability

SIDES = ("right", "left")
SIGN = {"right": 1.0, "left": -1.0}
"""The side of the table (sign of world x) of each hand."""
OTHER = {"right": "left", "left": "right"}

_MAX_ATTEMPTS = 10
BAR = ObjectSpec("bar", 4, (0.16, 0.045, 0.045), (0.85, 0.65, 0.15, 1.0))
"""The object passed in a handover (careful style; the natural style draws its size)."""
BIG_BOX = ObjectSpec("big_box", 5, (0.28, 0.065, 0.09), (0.55, 0.35, 0.20, 1.0))
"""The large box of a two-handed carry (careful style; the natural style draws its size)."""
PLANK = ObjectSpec("plank", 6, (0.17, 0.065, 0.04), (0.45, 0.45, 0.50, 1.0))
"""The base held still in ``hold_stack`` (careful style; the natural style draws its size)."""


# --- objects and layout ----------------------------------------------------------------------
def _objects(task: str, rng: np.random.Generator, natural: bool) -> tuple[ObjectSpec, ...]:
    """The task's objects: its special one (bar, large box or plank) and two cubes."""
    cubes = DEFAULT_OBJECTS[:2]
    if natural:
        sides = rng.uniform(0.05, 0.08, 2)
        cubes = tuple(replace(o, size=(s, s, s)) for o, s in zip(cubes, sides, strict=True))
    special = {"handover": BAR, "carry": BIG_BOX, "hold_stack": PLANK}.get(task)
    if special is None:  # hold_push: three cubes
        return (*cubes, DEFAULT_OBJECTS[2]) if not natural else (*cubes, _cube3(rng))
    if natural:
        lo = np.array(
            {"handover": (0.14, 0.04, 0.04), "carry": (0.26, 0.06, 0.08)}.get(
                task, (0.15, 0.06, 0.035)
            )
        )
        size = lo + rng.uniform(0.0, 1.0, 3) * np.array([0.04, 0.01, 0.02])
        special = replace(special, size=(float(size[0]), float(size[1]), float(size[2])))
    return (special, *cubes)


def _cube3(rng: np.random.Generator) -> ObjectSpec:
    s = float(rng.uniform(0.05, 0.08))
    return replace(DEFAULT_OBJECTS[2], size=(s, s, s))


def _layout(
    rng: np.random.Generator, objects: tuple[ObjectSpec, ...], *, centred: str | None = None
) -> dict[str, ObjectPose]:
    """Random collision-free upright poses; the object ``centred`` (a long one) near x = 0,
    lying roughly along x (its ends towards the hands)."""
    for _ in range(1000):
        poses: dict[str, ObjectPose] = {}
        for spec in objects:
            r = 0.5 * float(np.hypot(spec.size[0], spec.size[1]))
            for _ in range(200):
                if spec.name == centred:
                    xy = np.array([rng.uniform(-0.05, 0.05), rng.uniform(0.2, 0.3)])
                    yaw = float(rng.uniform(-np.pi / 12, np.pi / 12))
                else:
                    xy = np.array([rng.uniform(*WORKSPACE_X), rng.uniform(*WORKSPACE_Y)])
                    yaw = float(rng.uniform(-np.pi / 4, np.pi / 4))
                if all(
                    np.linalg.norm(xy - p.pos[:2]) > r + 0.5 * np.hypot(*o.size[:2]) + 0.05
                    for o in objects
                    if (p := poses.get(o.name)) is not None
                ):
                    poses[spec.name] = ObjectPose(np.array([*xy, 0.5 * spec.size[2]]), yaw)
                    break
        if len(poses) == len(objects):
            return poses
    raise DemonstrationError("could not place the objects without collisions")


# --- hand helpers ----------------------------------------------------------------------------
def _rest(P: Planner, side: str) -> HandState:
    """A relaxed hand near the demonstrator on its own side of the table, in view (an
    idle hand waits in front of the person, not out of the camera's view)."""
    rng = P.rng
    p = np.array(
        [SIGN[side] * rng.uniform(0.18, 0.26), rng.uniform(0.0, 0.06), rng.uniform(0.12, 0.17)]
    )
    return HandState(p, P.natural_yaw(p), _deg(10, 25, rng), _deg(-8, 8, rng), POSTURES["relaxed"])


def _kind(P: Planner) -> str:
    if P.var.style != "natural":
        return "pinch"
    return str(P.rng.choice(GRASP_TYPES, p=GRASP_WEIGHTS))


def end_grasp(P: Planner, name: str, end: float, kind: str, inset: float = 0.03) -> None:
    """Plan the grasp of ``name`` across its width (y faces) at its ``end`` (+1: the end along
    its +x axis), ``inset`` (m) from that end, from above; the Pick up that follows uses it."""
    rng, spec, pose, s = P.rng, P.specs[name], P.poses[name], P.scale
    roll = _deg(-8, 8, rng)
    width = float(spec.size[1])
    g = P.kin.grasp_for_aperture(kind, width + 2.0 * FINGERTIP_RADIUS * s)
    thumb, other = grasp_contacts(P.kin.local_keypoints(grasp_posture(kind, g)), kind)
    a = rotation(np.array(0.0), np.array(0.0), np.array(roll)) @ (other - thumb)
    pitch = float(np.arctan2(a[2], a[0]))
    a = rotation(np.array(0.0), np.array(pitch), np.array(roll)) @ (other - thumb)
    c, sn = np.cos(pose.yaw), np.sin(pose.yaw)
    along = end * (0.5 * spec.size[0] - inset - rng.uniform(0.0, 0.01))
    xy = (
        pose.pos[:2]
        + np.array([c * along, sn * along])
        + np.clip(rng.normal(0, 0.002, 2), -0.004, 0.004)
    )
    natural = P.natural_yaw(np.array([*xy, 0.0]))
    yaws = [wrap_angle(pose.yaw + k * np.pi / 2 - float(np.arctan2(a[1], a[0]))) for k in (1, 3)]
    yaw = min(yaws, key=lambda y: abs(wrap_angle(y - natural))) + _deg(-4, 4, rng)
    pitch += _deg(-4, 4, rng)
    margin = rng.uniform(0.01, 0.025) if P.var.style == "natural" else rng.uniform(0.02, 0.04)
    G: dict[str, Any] = {"yaw": yaw, "pitch": pitch, "roll": roll, "g": g, "width": width}
    G["g_pre"] = P.kin.grasp_for_aperture(kind, width + 2 * FINGERTIP_RADIUS * s + margin)
    G["kind"] = kind
    rel = P.relative_keypoints(grasp_posture(kind, g), yaw, pitch, roll)
    z = P.top(name) - rng.uniform(0.012, 0.02)
    if kind != "pinch":  # the TCP (index-thumb midpoint) is off the contacts' midpoint
        offset = 0.5 * np.add(*grasp_contacts(rel, kind))
        xy, z = xy - offset[:2], z - float(offset[2])
    z = max(z, 0.009 * s - float(rel[:, 2].min()))
    G["tcp"] = np.array([xy[0], xy[1], z])
    P.pending[("pick_up", name)] = G


def _end_towards(pose: ObjectPose, side: str) -> float:
    """The end (+1 / -1 along the object's x axis) on the ``side`` hand's side of the table."""
    return SIGN[side] * (1.0 if np.cos(pose.yaw) >= 0 else -1.0)


def _entry(P: Planner, name: str, *, first: bool = False) -> HandState:
    if P.var.style == "natural":
        return nat.pick_up_entry(P, name)
    return pick_up_entry(P, name, first=first)


def _move(P: Planner, target: HandState, obj: str | None, *, reach: bool = False) -> None:
    if P.var.style == "natural":
        nat.move(P, target, obj, reach=reach)
    else:
        move(P, target, obj)


def _pick(P: Planner, name: str) -> None:
    if P.var.style == "natural":
        nat.pick_up(P, name, turn=False)
    else:
        pick_up(P, name)


def _carry(P: Planner, name: str, onto: str | None = None) -> None:
    if P.var.style == "natural":
        nat.move_with(P, name, onto)
    else:
        move_with(P, name, onto)


def _put(P: Planner, name: str, skill: str = "place") -> None:
    if P.var.style == "natural":
        nat.put_down(P, name, skill)
    elif skill == "stack":
        stack(P, name)
    else:
        place(P, name)


def _hold_until(P: Planner, t: float) -> None:
    P.hold(t - P.t)


def _extend(P: Planner) -> None:
    """The last label ends now (what was done since belongs to it)."""
    last = P.labels[-1]
    P.labels[-1] = PlannedLabel(last.skill, last.t0, P.t, last.object)


def _restart(P: Planner, t0: float) -> None:
    """The last label starts at ``t0`` (a wait before it belongs to it)."""
    last = P.labels[-1]
    P.labels[-1] = PlannedLabel(last.skill, t0 if len(P.labels) > 1 else 0.0, last.t1, last.object)


def _let_go(P: Planner, name: str, *, partly: bool = False) -> None:
    """Open the grasp on ``name`` where it is: the object stays (another hand holds it, or it
    rests on the table). ``partly``: only the first opening, the rest is the next Move's."""
    rng = P.rng
    grasp = P.grasps[-1]
    kind = str(grasp["type"])
    pose = P.poses[name]
    if not partly:
        P.events.append(Detach(P.t, name, pose.copy()))
    P.held, P.grasp_rel = None, None
    margin = rng.uniform(0.004, 0.01) if partly else rng.uniform(0.015, 0.035)
    g_open = P.kin.grasp_for_aperture(
        kind, float(grasp["width"]) + 2 * FINGERTIP_RADIUS * P.scale + margin
    )
    natural = P.var.style == "natural"
    d = (
        rng.uniform(0.06, 0.12)
        if partly
        else (rng.uniform(0.1, 0.16) if natural else P.dur(0.3, 0.5))
    )
    P.go(d, P.state.moved(q=grasp_posture(kind, g_open)))
    if partly:  # the fingers are off it now
        P.events.append(Detach(P.t, name, pose.copy()))


def _release_in_place(P: Planner, name: str) -> None:
    """Place a held object that already rests on the table: let go and open the hand."""
    P.begin_skill()
    t0, rng = P.t, P.rng
    P.hold(rng.uniform(0.05, 0.3) if P.var.style != "natural" else rng.uniform(0.0, 0.1))
    _let_go(P, name)
    P.hold(P.dur(0.05, 0.2))
    P.label("place", t0, name)


def _hold_still(P: Planner, name: str, until: float) -> None:
    """Hold the grasped ``name`` still (the object does not move) until ``until``: a Move with
    of a still object, its label from the end of the Pick up."""
    P.begin_skill()
    t0 = P.t
    P.pending.pop(("lift", name), None)
    _hold_until(P, until)
    P.label("move_with", t0, name)


def _in_air_pose(P: Planner, name: str) -> ObjectPose:
    """Where the object held by ``P`` is now (from the hand and the grasp)."""
    assert P.grasp_rel is not None
    rel_p, rel_yaw = P.grasp_rel
    s = P.state
    c, sn = np.cos(s.yaw), np.sin(s.yaw)
    pos = s.tcp + np.array([c * rel_p[0] - sn * rel_p[1], sn * rel_p[0] + c * rel_p[1], rel_p[2]])
    return ObjectPose(pos, float(s.yaw + rel_yaw))


# --- the tasks -------------------------------------------------------------------------------
Result = dict[str, Any]


def _handover(H: dict[str, Planner], rng: np.random.Generator) -> Result:
    giver = "right" if rng.random() < 0.5 else "left"
    taker = OTHER[giver]
    G, T = H[giver], H[taker]
    o = "bar"
    pose = G.poses[o]
    end_g = _end_towards(pose, giver)
    end_grasp(G, o, end_g, _kind(G))
    G.hand = _entry(G, o, first=True)
    G.hold(float(rng.uniform(0.3, 0.8)))
    _pick(G, o)
    # carry it up to a point in the air between the hands, the bar along x, the giver's end
    # on the giver's side
    base = float(rng.uniform(-np.pi / 9, np.pi / 9))
    yaw = base if SIGN[giver] * end_g > 0 else base + np.pi
    yaw += 2 * np.pi * round((pose.yaw - yaw) / (2 * np.pi))
    centre = np.array([rng.uniform(-0.03, 0.03), rng.uniform(0.22, 0.3), rng.uniform(0.1, 0.16)])
    G.carry_pose = ObjectPose(centre, yaw)
    G.lift_scale = 0.25  # presented in front of the body, not lifted high first
    _carry(G, o)
    G.pending.pop(("place", o), None)
    G.poses[o] = _in_air_pose(G, o)
    t_there = G.t
    # the taker starts while the giver carries, reaches the other end and grasps it
    T.hand = _rest(T, taker)
    _hold_until(T, max(0.3, t_there - rng.uniform(0.4, 1.4)))
    end_grasp(T, o, -end_g, _kind(T))
    _move(T, _entry(T, o), o)
    _hold_until(T, t_there + rng.uniform(0.05, 0.3))
    _extend(T)
    _pick(T, o)
    start = T.t
    _hold_until(G, start)  # the giver holds it up until the taker has it
    _extend(G)
    G.begin_skill()
    G.hold(rng.uniform(0.05, 0.3) if G.var.style != "natural" else rng.uniform(0.02, 0.1))
    _let_go(G, o, partly=True)
    G.label("place", start, o)
    end = G.t
    _move(G, _rest(G, giver), None)
    # the taker carries it to its side of the table and puts it down
    t0 = T.t
    _hold_until(T, end + rng.uniform(0.05, 0.2))
    T.pending.pop(("lift", o), None)
    T.x_range = _side_range(taker)
    T.lift_scale = 0.15  # from the handover point down to the table: a short rise
    _carry(T, o)
    _restart(T, t0)
    _put(T, o)
    _move(T, _rest(T, taker), None)
    return {
        "roles": {"giver": giver, "taker": taker, "object": o},
        "handovers": [(start, end, giver, taker, o)],
    }


def _side_range(side: str) -> tuple[float, float]:
    """The x range of the table on the ``side`` hand's side."""
    return (0.02, WORKSPACE_X[1]) if side == "right" else (WORKSPACE_X[0], -0.02)


def _carry_together(H: dict[str, Planner], rng: np.random.Generator) -> Result:
    o = "big_box"
    pose = H["right"].poses[o]
    for side, P in H.items():
        P.hand = _rest(P, side)
        P.hold(float(rng.uniform(0.2, 0.9)))
        end_grasp(P, o, _end_towards(pose, side), "whole_hand", inset=0.04)
        _move(P, _entry(P, o), o)
        _pick(P, o)
    t_lift = max(P.t for P in H.values()) + rng.uniform(0.1, 0.4)
    natural = H["right"].var.style == "natural"
    for P in H.values():
        P.begin_skill()
        P.pending.pop(("lift", o), None)
        P.labels.append(PlannedLabel("move_with", P.t, P.t, o))
        _hold_until(P, t_lift)
    # the box's new spot: 8-18 cm away, clear of the other objects, the same yaw
    R = H["right"]
    spec = R.specs[o]
    r = 0.5 * float(np.hypot(*spec.size[:2]))
    for _ in range(2000):
        d = rng.uniform(0.08, 0.18)
        a = rng.uniform(-np.pi, np.pi)
        xy = pose.pos[:2] + d * np.array([np.cos(a), np.sin(a)])
        if not (-0.08 <= xy[0] <= 0.08 and WORKSPACE_Y[0] <= xy[1] <= WORKSPACE_Y[1] + 0.04):
            continue
        if all(
            np.linalg.norm(xy - p.pos[:2]) > r + 0.5 * np.hypot(*R.specs[n].size[:2]) + 0.03
            for n, p in R.poses.items()
            if n != o
        ):
            break
    else:
        raise DemonstrationError("no free spot for the large box")
    shift = np.array([*(xy - pose.pos[:2]), 0.0])
    above = rng.uniform(0.04, 0.06)
    rise = rng.uniform(0.05, 0.3) if natural else rng.uniform(0.06, 0.14)
    speed = R.skill_speed
    dist = float(np.linalg.norm(shift) + 2 * rise)
    dur = (rng.uniform(0.4, 0.6) + 1.6 * dist) / speed * (0.7 if natural else 1.0)
    detour = R.detour(np.zeros(3), shift, frac=(0.02, 0.1))
    rise_frac, xy_delay = rng.uniform(0.3, 0.45), rng.uniform(0.1, 0.25)
    for P in H.values():
        s = P.state
        P.go(
            dur,
            s.moved(tcp=s.tcp + shift + np.array([0.0, 0.0, above])),
            detour=detour,
            z_peak=float(s.tcp[2] + rise),
            rise_frac=rise_frac,
            xy_delay=xy_delay,
        )
        _extend(P)
    # lower it together, then each hand lets go at its own time
    t_down = H["right"].t
    d1, d2 = (
        (rng.uniform(0.15, 0.3), rng.uniform(0.05, 0.1))
        if natural
        else (rng.uniform(0.6, 0.9) / speed, rng.uniform(0.25, 0.45) / speed)
    )
    near = above - rng.uniform(0.003, 0.01)
    for P in H.values():
        s = P.state
        P.go(d1, s.moved(tcp=s.tcp - np.array([0.0, 0.0, near])))
        P.go(d2, P.state.moved(tcp=s.tcp - np.array([0.0, 0.0, above])))
    new = ObjectPose(pose.pos + shift, pose.yaw)
    for P in H.values():
        P.poses[o] = new.copy()
    for side, P in H.items():
        _release_in_place(P, o)
        _restart(P, t_down)
        _move(P, _rest(P, side), None)
    return {"roles": {"object": o}, "handovers": []}


def _hold_and(task: str) -> Callable[[dict[str, Planner], np.random.Generator], Result]:
    def plan(H: dict[str, Planner], rng: np.random.Generator) -> Result:
        holder = "right" if rng.random() < 0.5 else "left"
        actor = OTHER[holder]
        Ph, Pa = H[holder], H[actor]
        cubes = [n for n in Ph.poses if n != "plank"]
        if task == "hold_stack":
            b = "plank"
            a = min(cubes, key=lambda n: SIGN[actor] * -Ph.poses[n].pos[0])
            end = _end_towards(Ph.poses[b], holder)
            end_grasp(Ph, b, end, _kind(Ph))
        else:  # the cube on the holder's side is held, one of the others is pushed
            b = max(cubes, key=lambda n: SIGN[holder] * Ph.poses[n].pos[0])
            a = max((n for n in cubes if n != b), key=lambda n: SIGN[actor] * Ph.poses[n].pos[0])
        Ph.hand = _rest(Ph, holder)
        Ph.hold(float(rng.uniform(0.2, 0.8)))
        _move(Ph, _entry(Ph, b), b, reach=True)
        _pick(Ph, b)
        grasped = Ph.t
        Pa.hand = _rest(Pa, actor)
        _hold_until(Pa, max(0.3, grasped - rng.uniform(0.5, 1.5)))
        if task == "hold_stack":
            pb = Pa.poses[b]
            off = -end * rng.uniform(0.025, 0.04)
            Pa.stack_offset[b] = np.array([np.cos(pb.yaw) * off, np.sin(pb.yaw) * off])
            _move(Pa, _entry(Pa, a), a, reach=True)
            _pick(Pa, a)
            if Pa.t < grasped:  # the base is held before anything goes on it
                _hold_until(Pa, grasped + rng.uniform(0.05, 0.2))
                _extend(Pa)
            _carry(Pa, a, b)
            _put(Pa, a, "stack")
        else:
            _move(Pa, push_entry(Pa, a), a)
            if Pa.t < grasped:
                _hold_until(Pa, grasped + rng.uniform(0.05, 0.2))
                _extend(Pa)
            push(Pa, a)
        done = Pa.t
        _move(Pa, _rest(Pa, actor), None)
        _hold_still(Ph, b, done + rng.uniform(0.2, 0.8))  # hold until the other hand is done
        _release_in_place(Ph, b)
        _move(Ph, _rest(Ph, holder), None)
        return {"roles": {"holder": holder, "actor": actor, "held": b, "other": a}, "handovers": []}

    return plan


PLANS: dict[str, Callable[[dict[str, Planner], np.random.Generator], Result]] = {
    "handover": _handover,
    "carry": _carry_together,
    "hold_stack": _hold_and("hold_stack"),
    "hold_push": _hold_and("hold_push"),
}
"""How each two-hand task is performed."""


# --- motion ----------------------------------------------------------------------------------
def _hand_motion(
    rng: np.random.Generator, var: Any, kin: HandKinematics, P: Planner, t: np.ndarray
) -> dict[str, np.ndarray]:
    """One hand's true motion on the fine grid (:func:`lfd.sim.results.hand_motion`)."""
    return hand_motion(rng, var, kin, P, Plan(P.segments), t)


def _grab(m: dict[str, np.ndarray], i: int, cur: ObjectPose) -> tuple[np.ndarray, float]:
    """The pose of an object at ``cur`` relative to a hand's TCP and yaw at grid index ``i``."""
    c, s = np.cos(-m["yaw"][i]), np.sin(-m["yaw"][i])
    d = cur.pos - m["tcp"][i]
    return np.array([c * d[0] - s * d[1], s * d[0] + c * d[1], d[2]]), float(cur.yaw - m["yaw"][i])


def _follow(
    m: dict[str, np.ndarray],
    i0: int,
    i1: int,
    rel: tuple[np.ndarray, float],
    pos: np.ndarray,
    yaw: np.ndarray,
) -> None:
    """The object rigidly in the hand ``m`` during grid indices ``[i0, i1)``."""
    Rz = rotation(m["yaw"][i0:i1], np.zeros(i1 - i0), np.zeros(i1 - i0))
    pos[i0:i1] = m["tcp"][i0:i1] + Rz @ rel[0]
    yaw[i0:i1] = m["yaw"][i0:i1] + rel[1]


def _objects_motion(
    H: dict[str, Planner],
    initial: dict[str, ObjectPose],
    t: np.ndarray,
    motion: dict[str, dict[str, np.ndarray]],
) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Object centre (n, 3) and yaw (n,): an object follows the hand that has held it longest
    of those holding it (rigidly, from when it took it); when that hand lets go and the other
    still holds it, it follows the other; when the last lets go it rests where planned."""
    positions, yaws = {}, {}
    for name, pose0 in initial.items():
        events = sorted(
            (
                (e.t if not isinstance(e, Push) else e.t0, side, e)
                for side, P in H.items()
                for e in P.events
                if e.name == name
            ),
            key=lambda x: (x[0], isinstance(x[2], Detach)),
        )
        pos = np.empty((t.size, 3))
        yaw = np.empty(t.size)
        cur, i_cur = pose0.copy(), 0
        holders: list[str] = []
        rel: tuple[np.ndarray, float] | None = None

        for te, side, ev in events:
            i = min(int(np.searchsorted(t, te)), t.size - 1)
            if isinstance(ev, Attach):
                if not holders:
                    pos[i_cur:i], yaw[i_cur:i] = cur.pos, cur.yaw
                    rel, i_cur = _grab(motion[side], i, cur), i
                holders.append(side)
            elif isinstance(ev, Detach):
                if side not in holders:
                    raise RuntimeError(f"{side} lets go of {name} it does not hold")
                driver = holders[0]
                holders.remove(side)
                if side != driver:
                    continue
                assert rel is not None
                _follow(motion[driver], i_cur, i, rel, pos, yaw)
                last_p = pos[i - 1] if i > i_cur else cur.pos
                last_y = float(yaw[i - 1]) if i > i_cur else cur.yaw
                if holders:  # the other hand has it now
                    cur = ObjectPose(np.array(last_p), last_y)
                    rel = _grab(motion[holders[0]], i, cur)
                else:
                    cur = ObjectPose(np.array([last_p[0], last_p[1], ev.pose.pos[2]]), ev.pose.yaw)
                i_cur = i
            else:  # a push
                i0, i1 = (int(v) for v in np.searchsorted(t, [ev.t0, ev.t1]))
                pos[i_cur:i0], yaw[i_cur:i0] = cur.pos, cur.yaw
                tcp = motion[side]["tcp"]
                disp = np.maximum.accumulate(
                    np.maximum(0.0, (tcp[i0:i1] - ev.contact) @ ev.direction)
                )
                pos[i0:i1] = cur.pos + np.outer(disp, ev.direction)
                yaw[i0:i1] = cur.yaw
                cur = ObjectPose(cur.pos + ev.direction * (disp[-1] if disp.size else 0.0), cur.yaw)
                i_cur = i1
        if holders:
            assert rel is not None
            _follow(motion[holders[0]], i_cur, t.size, rel, pos, yaw)
        else:
            pos[i_cur:], yaw[i_cur:] = cur.pos, cur.yaw
        positions[name], yaws[name] = pos, yaw
    return positions, yaws


# --- the demonstration -----------------------------------------------------------------------
def _plan(
    task: str,
    rng: np.random.Generator,
    var: Variability,
    kins: dict[str, HandKinematics],
    objects: tuple[ObjectSpec, ...],
) -> tuple[dict[str, Planner], dict[str, Any], dict[str, Any]]:
    """Both hands' planners after planning ``task`` from a random layout (new layouts until one
    can be done): the planners, the initial object poses and what the plan did."""
    specs = {o.name: o for o in objects}
    centred = objects[0].name if task in ("handover", "carry", "hold_stack") else None
    for attempt in range(_MAX_ATTEMPTS):
        initial = _layout(rng, objects, centred=centred)
        poses = {n: p.copy() for n, p in initial.items()}
        H = {
            side: Planner(
                rng,
                var,
                kins[side],
                specs,
                poses,
                shoulder=(DEMONSTRATOR_SHOULDER if side == "right" else LEFT_SHOULDER).copy(),
            )
            for side in SIDES
        }
        try:
            return H, initial, PLANS[task](H, rng)
        except DemonstrationError:
            if attempt == _MAX_ATTEMPTS - 1:
                raise
    raise AssertionError("unreachable")  # the last attempt returned or raised


def _metadata(
    H: dict[str, Planner],
    var: Variability,
    done: dict[str, Any],
    initial: dict[str, Any],
    rates: dict[str, float],
) -> dict[str, Any]:
    """The simulated demonstration's metadata after its task and seed."""
    return {
        "source": "simulation",
        "simulator": "lfd.sim",
        "simulator_version": SIM_VERSION,
        "variability": var.as_dict(),
        "roles": done["roles"],
        "hands": list(SIDES),
        **rates,
        "initial_objects": {
            n: {"position": p.pos.round(6).tolist(), "yaw": round(p.yaw, 6)}
            for n, p in initial.items()
        },
        "skill_sequences": {side: [lab.skill for lab in H[side].labels] for side in SIDES},
        "style": var.style,
        "grasps": {side: [g for g in H[side].grasps if not g.get("table_turn")] for side in SIDES},
        "pushes": [e for P in H.values() for e in P.log if "push" in e],
        "stacks": [e for P in H.values() for e in P.log if "stack" in e],
    }


def simulate_two_hands(
    task: str,
    seed: int,
    variability: Variability | None,
    *,
    hand_rate_hz: float,
    object_rate_hz: float,
) -> Any:
    """Simulate one two-hand demonstration of ``task`` (:data:`~lfd.sim.tasks.BIMANUAL_TASKS`);
    called by :func:`lfd.sim.simulate` (which checks the arguments). Returns a
    :class:`~lfd.sim.demonstrator.SimResult` whose demonstration has both hands, the labels of
    both lanes (``hand`` set) and the handovers, and whose truth has the left hand in
    ``other``."""
    from .sampling import sample_hand, sample_streams

    rng = np.random.default_rng(seed)
    var = (variability or Variability()).resolve(rng)
    natural = var.style == "natural"
    objects = _objects(task, rng, natural)
    scene = build_scene(objects, hand_scale=float(var.hand_scale or 1.0), sides=SIDES)
    model = scene.compile()
    kins: dict[str, HandKinematics] = {
        "right": HandKinematics(model),
        "left": MirroredKinematics(model),
    }
    H, initial, done = _plan(task, rng, var, kins, objects)
    t_end = max(P.t for P in H.values()) + float(rng.uniform(0.3, 0.8))
    for P in H.values():
        _hold_until(P, t_end)
        _extend(P)
    sub = 10
    n_frames = int(np.floor(t_end * object_rate_hz + 1e-9)) + 1
    t = np.arange((n_frames - 1) * sub + 1) / (object_rate_hz * sub)
    motion = {side: _hand_motion(rng, var, kins[side], H[side], t) for side in SIDES}
    obj_pos, obj_yaw = _objects_motion(H, initial, t, motion)
    frames = np.arange(n_frames) * sub
    t_ns = BASE_TIME_NS + np.round(np.arange(n_frames) * (1e9 / object_rate_hz)).astype(np.int64)
    op = {n: p[frames] for n, p in obj_pos.items()}
    oy = {n: y[frames] for n, y in obj_yaw.items()}

    def truth_of(side: str) -> Truth:
        m = motion[side]
        return Truth(
            t_ns=t_ns,
            tcp=m["tcp"][frames],
            keypoints=m["keypoints"][frames],
            wrist_pos=m["wrist"][frames],
            wrist_quat=quat_wxyz(m["R"][frames]),
            q=m["q"][frames],
            object_pos=op,
            object_yaw=oy,
        )

    truth = truth_of("right")
    truth.other = truth_of("left")
    hand, tracks = sample_streams(
        rng, truth, scene, var, hand_rate_hz, object_rate_hz, others=(truth.other,)
    )
    left = sample_hand(
        rng,
        t_ns,
        truth.other.keypoints,
        scene.camera.rotation_cv(),
        var,
        hand_rate_hz,
        object_rate_hz,
        side="left",
    )
    end_ns = int(t_ns[-1])

    def ns(s: float) -> int:
        return min(BASE_TIME_NS + round(s * 1e9), end_ns)

    labels = [
        SkillLabel(lab.skill, ns(lab.t0), ns(lab.t1), lab.object, hand=side)
        for side in SIDES
        for lab in H[side].labels
    ]
    labels.sort(key=lambda lab: (lab.start_ns, lab.end_ns, str(lab.hand)))  # in time order
    handovers = [Handover(ns(a), ns(b), g, k, o) for a, b, g, k, o in done["handovers"]]
    cam = scene.camera
    camera = CameraInfo(cam.width, cam.height, cam.intrinsics(), cam.world_T_camera())
    rates = {"hand_rate_hz": hand_rate_hz, "object_rate_hz": object_rate_hz}
    metadata = {"task": task, "seed": int(seed), **_metadata(H, var, done, initial, rates)}
    demo = Demonstration(
        hand=hand,
        other_hand=left,
        objects=tracks,
        labels=labels,
        camera=camera,
        metadata=metadata,
        handovers=handovers,
    )
    plan = Plan(H["right"].segments)
    return SimResult(demo=demo, truth=truth, scene=scene, plan=plan, variability=var)
