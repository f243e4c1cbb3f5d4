"""The seven skills as parameterised human motions (see docs/skills.md).

TCP = midpoint of the index and thumb tips. The property the segmentation relies on: **Move and
Move with are the only skills in which the TCP rises**; in every other skill the TCP height is
constant or decreasing (noise-free plan; tremor and sensor noise come on top).

Each skill function appends its segments to a :class:`~lfd.sim.planner.Planner` starting from the
current hand state and closes its label (pauses after a skill belong to that skill). An
``*_entry`` function gives the hand state a preceding Move must reach for the skill to start.

- **pick_up** (not holding -> holding): from above/near the object (entry: TCP 6-12 cm above the
  top face, up to 5 cm back along the approach direction; 4-6 cm and 4 cm where the demonstration
  starts), reach down to 0.5-1.5 cm above the grasp
  point with the index and thumb pre-shaped wider than the object (2-4 cm margin), then a slow final
  descent to the grasp point (TCP 1.2-2 cm below the top face at the object's centre, +-2 mm), an
  optional hesitation, and close index and thumb until the tip distance is the object width plus
  the two fingertip pads. Ends grasped, still at the grasp point; the object has not moved.
- **move_with** (holding): lift first, then carry: the TCP rises 3-8 cm above the higher end point
  (and high enough to clear every object) and ends with the held object 4-6 cm above its
  destination (a free table spot, or the top of another object); the object may turn by +-30 deg
  around the vertical. The object is rigidly attached to the hand frame (TCP + wrist yaw).
- **place** (holding -> not holding): lower the object onto the table (fast, then a slow final
  1 cm), release it (it rests with its bottom on the table) and open the fingers; TCP does not rise.
- **stack**: like place, onto the top face of another object (centre within a few mm).
- **move** (not holding): rise first (the TCP climbs 2-6 cm above the higher end point and above
  every object), then travel on a curved path to the entry pose of the next skill or to a rest pose
  near the demonstrator; the fingers relax and pre-shape for the next skill on the way.
- **push** (not holding): from above the push start (3-8 cm over the contact height, behind the
  object), lower the hand (pitched 55-70 deg down, fingers together) to table height 1.5-4 cm behind
  the object, then move it horizontally along one of the object's axes: once the fingers reach the
  object's face, the object slides in front of the hand by the commanded distance (5-12 cm). The
  fingers are never closed on it.
- **locate** (not holding): from above and behind, approach and point: index straight, pointing
  down-forward (hand pitch 40-60 deg), index tip 4-8 cm above the centre of the object's top face
  (+-8 mm horizontally), then hover there 0.8-1.5 s (drift of a few mm, no rise). Nothing is
  touched.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import DemonstrationError
from .hand import (
    FINGERTIP_RADIUS,
    GRASP_TYPES,
    POSTURES,
    grasp_contacts,
    grasp_posture,
    pinch_posture,
)
from .motion import HandState, rotation
from .nonprehensile import locate, locate_entry, push, push_entry
from .planner import Attach, Detach, ObjectPose, Planner, wrap_angle
from .scene import WORKSPACE_X, WORKSPACE_Y

__all__ = [
    "attach",
    "carry_target",
    "free_spot",
    "locate",
    "locate_entry",
    "move",
    "move_with",
    "pick_up",
    "pick_up_entry",
    "place",
    "push",
    "push_entry",
    "rest_pose",
    "stack",
]


def _deg(lo: float, hi: float, rng: np.random.Generator) -> float:
    return float(np.deg2rad(rng.uniform(lo, hi)))


def _max_top(P: Planner, exclude: str | None = None) -> float:
    return max((P.top(n) for n in P.poses if n != exclude), default=0.0)


# --- Pick up ---------------------------------------------------------------------------------
GRASP_WEIGHTS = (0.45, 0.33, 0.22)
"""How often the natural demonstrator uses each of :data:`~lfd.sim.hand.GRASP_TYPES`."""


def _grasp_type(P: Planner) -> str:
    """``pinch`` for the careful demonstrator; a drawn grasp type for the natural one (the type
    of the previous grasp of the same object is kept with probability 0.6)."""
    if P.var.style != "natural":
        return "pinch"
    if P.last_grasp is not None and P.rng.random() < 0.6:
        return P.last_grasp
    return str(P.rng.choice(GRASP_TYPES, p=GRASP_WEIGHTS))


def _grasp(P: Planner, name: str) -> dict[str, Any]:
    key = ("pick_up", name)
    if key in P.pending:
        return P.pending[key]
    kind = _grasp_type(P)
    rng, spec, pose, s = P.rng, P.specs[name], P.poses[name], P.scale
    roll = _deg(-8, 8, rng)
    natural = P.natural_yaw(pose.pos)
    best: tuple[float, dict[str, Any]] | None = None
    for k in range(4):
        width = spec.size[k % 2]
        g = P.kin.grasp_for_aperture(kind, width + 2.0 * FINGERTIP_RADIUS * s)
        thumb, other = grasp_contacts(P.kin.local_keypoints(grasp_posture(kind, g)), kind)
        a = rotation(np.array(0.0), np.array(0.0), np.array(roll)) @ (other - thumb)
        pitch = float(np.arctan2(a[2], a[0]))
        a = rotation(np.array(0.0), np.array(pitch), np.array(roll)) @ (other - thumb)
        yaw = wrap_angle(pose.yaw + k * np.pi / 2 - float(np.arctan2(a[1], a[0])))
        cost = abs(wrap_angle(yaw - natural))
        if best is None or cost < best[0]:
            best = (cost, {"yaw": yaw, "pitch": pitch, "roll": roll, "g": g, "width": width})
    assert best is not None
    G = best[1]
    G["yaw"] = float(G["yaw"]) + _deg(-4, 4, rng)
    G["pitch"] = float(G["pitch"]) + _deg(-4, 4, rng)
    width = float(G["width"])
    margin = rng.uniform(0.01, 0.025) if P.var.style == "natural" else rng.uniform(0.02, 0.04)
    G["g_pre"] = P.kin.grasp_for_aperture(kind, width + 2 * FINGERTIP_RADIUS * s + margin)
    G["kind"] = kind
    rel = P.relative_keypoints(grasp_posture(kind, float(G["g"])), G["yaw"], G["pitch"], roll)
    z = P.top(name) - rng.uniform(0.012, 0.02)
    xy = pose.pos[:2] + np.clip(rng.normal(0.0, 0.002, 2), -0.004, 0.004)
    if kind != "pinch":  # the TCP (index-thumb midpoint) is off the contacts' midpoint
        offset = 0.5 * np.add(*grasp_contacts(rel, kind))
        xy, z = xy - offset[:2], z - float(offset[2])
    z = max(z, 0.009 * s - float(rel[:, 2].min()))
    G["tcp"] = np.array([xy[0], xy[1], z])
    P.pending[key] = G
    return G


def pick_up_entry(P: Planner, name: str, *, first: bool = False) -> HandState:
    """Hand state above/near ``name`` from which a Pick up starts: 6-12 cm above its top, up to
    5 cm back; where the demonstration starts (``first``) 4-6 cm and up to 4 cm, so that it starts
    with the Pick up itself, not with a Move (docs/skills.md "Boundaries": a Pick up starts where
    the TCP was last 8 cm from the object)."""
    G, rng = _grasp(P, name), P.rng
    yaw = float(G["yaw"])
    back_max, (lo, hi) = (0.04, (0.04, 0.06)) if first else (0.05, (0.06, 0.12))
    back = np.array([np.cos(yaw), np.sin(yaw)]) * -rng.uniform(0.0, back_max)
    side = np.array([-np.sin(yaw), np.cos(yaw)]) * rng.uniform(-0.02, 0.02)
    tcp = np.array(G["tcp"], float)
    p = np.array([*(tcp[:2] + back + side), P.top(name) + rng.uniform(lo, hi)])
    q = 0.5 * POSTURES["relaxed"] + 0.5 * grasp_posture(str(G["kind"]), float(G["g_pre"]))
    return HandState(
        p,
        yaw + _deg(-12, 12, rng),
        float(G["pitch"]) - _deg(0, 12, rng),
        float(G["roll"]),
        q,
    )


def attach(P: Planner, name: str, G: dict[str, Any], t_close: float) -> None:
    """The fingers are closed on ``name`` now: it moves with the hand from here on (the grasp
    ``G`` closed from ``t_close`` on is logged)."""
    P.events.append(Attach(P.t, name))
    pose = P.poses[name]
    c, s_ = np.cos(-P.state.yaw), np.sin(-P.state.yaw)
    d = pose.pos - P.state.tcp
    P.grasp_rel = (
        np.array([c * d[0] - s_ * d[1], s_ * d[0] + c * d[1], d[2]]),
        pose.yaw - P.state.yaw,
    )
    P.held = name
    P.last_grasp = str(G["kind"])
    P.grasps.append(
        {
            "object": name,
            "type": str(G["kind"]),
            "width": round(float(G["width"]), 6),
            "t_close_s": round(t_close, 6),
            "t_closed_s": round(P.t, 6),
        }
    )


def pick_up(P: Planner, name: str) -> None:
    """Reach down to the object with the fingers pre-shaped, then close index and thumb on it."""
    P.begin_skill()
    t0, G, rng = P.t, _grasp(P, name), P.rng
    P.pending.pop(("pick_up", name), None)
    tcp = np.array(G["tcp"], float)
    ang = {k: float(G[k]) for k in ("yaw", "pitch", "roll")}
    q_pre = grasp_posture(str(G["kind"]), float(G["g_pre"]))
    above = tcp + np.array([0.0, 0.0, rng.uniform(0.005, 0.015)])
    above[2] = min(above[2], P.state.tcp[2])
    reach = HandState(above, q=q_pre, **ang)
    dist = float(np.linalg.norm(above - P.state.tcp))
    P.go(
        P.dur(0.6, 1.0) + 1.5 * dist / P.skill_speed,
        reach,
        detour=P.detour(P.state.tcp, above, frac=(0.0, 0.15)),
        posture_window=(0.0, 0.7),
        orient_window=(0.0, 0.8),
    )
    P.go(P.dur(0.25, 0.45), reach.moved(tcp=tcp))
    P.maybe_pause()
    t_close = P.t
    P.go(P.dur(0.35, 0.6), P.state.moved(q=grasp_posture(str(G["kind"]), float(G["g"]))))
    attach(P, name, G, t_close)
    P.hold(P.dur(0.1, 0.3))
    P.maybe_pause()
    P.label("pick_up", t0, name)


# --- Move with, Place, Stack -----------------------------------------------------------------
def free_spot(
    P: Planner, name: str, *, min_move: float = 0.10, max_move: float | None = None
) -> np.ndarray:
    """A random table position (x, y) for ``name``, clear of other objects and of the marker,
    ``min_move`` to ``max_move`` (m) from where it is."""
    spec = P.specs[name]
    r = 0.5 * float(np.hypot(spec.size[0], spec.size[1]))
    here = P.poses[name].pos[:2]
    for _ in range(2000):
        xy = np.array([P.rng.uniform(*(P.x_range or WORKSPACE_X)), P.rng.uniform(*WORKSPACE_Y)])
        if np.linalg.norm(xy - here) < min_move:
            continue
        if max_move is not None and np.linalg.norm(xy - here) > max_move:
            continue
        ok = True
        for other, pose in P.poses.items():
            if other == name:
                continue
            ro = 0.5 * float(np.hypot(*P.specs[other].size[:2]))
            if np.linalg.norm(xy - pose.pos[:2]) < r + ro + 0.04:
                ok = False
                break
        if ok:
            return xy
    raise DemonstrationError(f"no free table spot for {name}")


def carry_target(
    P: Planner,
    name: str,
    onto: str | None,
    *,
    spot: tuple[float, float | None] = (0.10, None),
    turn_deg: float = 30.0,
    turn: float | None = None,
) -> tuple[float, np.ndarray]:
    """Where a Move with of the held ``name`` ends: the hand yaw and the TCP at which the object
    rests on a free table spot ``spot = (min_move, max_move)`` away (turned by up to
    ``turn_deg``, or by ``turn`` rad when given) or on top of ``onto``. The Place / Stack that
    follows is planned here."""
    rng = P.rng
    spec = P.specs[name]
    assert P.grasp_rel is not None
    rel_p, rel_yaw = P.grasp_rel
    yaw_obj = P.poses[name].yaw
    if P.carry_pose is not None and onto is None:  # a given pose (in the air)
        pos, new_yaw = P.carry_pose.pos.copy(), P.carry_pose.yaw
        P.carry_pose = None
    elif onto is None:
        xy = free_spot(P, name, min_move=spot[0], max_move=spot[1])
        pos = np.array([xy[0], xy[1], 0.5 * spec.size[2]])
        new_yaw = yaw_obj + (_deg(-turn_deg, turn_deg, rng) if turn is None else turn)
    else:
        base = P.poses[onto]
        pos = np.array([*(base.pos[:2] + np.clip(rng.normal(0, 0.003, 2), -0.006, 0.006)), 0.0])
        pos[:2] += P.stack_offset.pop(onto, np.zeros(2))
        pos[2] = P.top(onto) + 0.5 * spec.size[2]
        k = np.round((yaw_obj - base.yaw) / (np.pi / 2))
        new_yaw = base.yaw + k * np.pi / 2 + _deg(-5, 5, rng)
    hand_yaw = float(new_yaw - rel_yaw)
    c, sn = np.cos(hand_yaw), np.sin(hand_yaw)
    tcp_final = pos - np.array(
        [c * rel_p[0] - sn * rel_p[1], sn * rel_p[0] + c * rel_p[1], rel_p[2]]
    )
    P.pending[("place", name)] = {"tcp": tcp_final, "pose": ObjectPose(pos, float(new_yaw))}
    if onto is not None:
        P.log.append({"stack": name, "onto": onto})
    return hand_yaw, tcp_final


def move_with(P: Planner, name: str, onto: str | None = None) -> None:
    """Lift the held object and carry it above a free table spot or above object ``onto``."""
    if P.held != name or P.grasp_rel is None:
        raise RuntimeError(f"move_with needs {name} in the hand")
    P.begin_skill()
    t0, rng, s = P.t, P.rng, P.state
    spec = P.specs[name]
    hand_yaw, tcp_final = carry_target(P, name, onto)
    above = tcp_final + np.array([0.0, 0.0, rng.uniform(0.04, 0.06)])
    below_tcp = 0.5 * spec.size[2] - P.grasp_rel[0][2]  # object bottom below the TCP
    z_peak = max(s.tcp[2], above[2]) + rng.uniform(0.03, 0.08)
    z_peak = max(z_peak, _max_top(P, name) + below_tcp + 0.03)
    dist = over_length(s.tcp, above, z_peak)
    P.go(
        P.dur(0.6, 0.9) + 2.0 * dist / P.skill_speed,
        s.moved(tcp=above, yaw=hand_yaw),
        detour=P.detour(s.tcp, above, frac=(0.02, 0.12)),
        z_peak=z_peak,
        rise_frac=rng.uniform(0.3, 0.45),
        xy_delay=rng.uniform(0.1, 0.25),
    )
    P.maybe_pause()
    P.label("move_with", t0, name)


def _put_down(P: Planner, name: str, skill: str) -> None:
    if P.held != name:
        raise RuntimeError(f"{skill} needs {name} in the hand")
    P.begin_skill()
    t0, rng = P.t, P.rng
    target = P.pending.pop(("place", name))
    tcp = np.array(target["tcp"], float)
    pose = target["pose"]
    assert isinstance(pose, ObjectPose)
    near = tcp + np.array([0.0, 0.0, rng.uniform(0.005, 0.012)])
    P.go(
        P.dur(0.6, 0.9), P.state.moved(tcp=near), detour=P.detour(P.state.tcp, near, frac=(0, 0.05))
    )
    P.go(P.dur(0.25, 0.45), P.state.moved(tcp=tcp))
    P.maybe_pause()
    P.events.append(Detach(P.t, name, pose.copy()))
    P.poses[name] = pose.copy()
    P.held, P.grasp_rel = None, None
    width = P.specs[name].size[0]
    g_open = P.kin.pinch_for_aperture(
        width + 2 * FINGERTIP_RADIUS * P.scale + rng.uniform(0.015, 0.035)
    )
    P.go(P.dur(0.3, 0.5), P.state.moved(q=pinch_posture(g_open)))
    P.hold(P.dur(0.1, 0.25))
    P.maybe_pause()
    P.label(skill, t0, name)


def place(P: Planner, name: str) -> None:
    """Lower the held object onto the table and release it."""
    _put_down(P, name, "place")


def stack(P: Planner, name: str) -> None:
    """Lower the held object onto the object below it and release it."""
    _put_down(P, name, "stack")


# --- Move ------------------------------------------------------------------------------------
def rest_pose(P: Planner) -> HandState:
    """A relaxed hand near the demonstrator, above the table's near edge."""
    rng = P.rng
    p = np.array([rng.uniform(0.22, 0.32), rng.uniform(-0.06, 0.04), rng.uniform(0.12, 0.18)])
    return HandState(p, P.natural_yaw(p), _deg(10, 25, rng), _deg(-8, 8, rng), POSTURES["relaxed"])


def over_length(a: np.ndarray, b: np.ndarray, z_peak: float) -> float:
    """The length (m) of a path from ``a`` up to ``z_peak``, across and down to ``b`` (TCP
    positions): the horizontal distance plus both vertical legs."""
    return float(np.linalg.norm(b[:2] - a[:2]) + 2 * z_peak - a[2] - b[2])


def move(P: Planner, target: HandState, obj: str | None) -> None:
    """Rise, then travel (not holding) to ``target`` (the next skill's entry or a rest pose)."""
    P.begin_skill()
    t0, rng, s = P.t, P.rng, P.state
    z_peak = max(s.tcp[2], target.tcp[2]) + rng.uniform(0.02, 0.06)
    z_peak = max(z_peak, _max_top(P) + 0.06)
    dist = over_length(s.tcp, target.tcp, z_peak)
    P.go(
        P.dur(0.5, 0.8) + 2.2 * dist / P.skill_speed,
        target,
        detour=P.detour(s.tcp, target.tcp, frac=(0.02, 0.12)),
        z_peak=z_peak,
        rise_frac=rng.uniform(0.3, 0.45),
        xy_delay=rng.uniform(0.1, 0.25),
        posture_window=(0.15, 1.0),
        orient_window=(0.1, 1.0),
    )
    P.maybe_pause()
    P.label("move", t0, obj)
