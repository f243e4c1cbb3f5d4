"""The two skills that do not grasp: Push and Locate (definitions in :mod:`lfd.sim.skills`)."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..demo import INDEX_TIP
from ..errors import DemonstrationError
from .hand import POSTURES
from .motion import HandState
from .planner import Planner, Push
from .scene import WORKSPACE_X, WORKSPACE_Y


def _deg(lo: float, hi: float, rng: np.random.Generator) -> float:
    return float(np.deg2rad(rng.uniform(lo, hi)))


# --- Push ------------------------------------------------------------------------------------
def _push_plan(P: Planner, name: str) -> dict[str, Any]:
    key = ("push", name)
    if key in P.pending:
        return P.pending[key]
    rng, spec, pose, s = P.rng, P.specs[name], P.poses[name], P.scale
    r_obj = 0.5 * float(np.hypot(spec.size[0], spec.size[1]))
    others = [
        (p.pos[:2], 0.5 * float(np.hypot(*P.specs[o].size[:2])))
        for o, p in P.poses.items()
        if o != name
    ]
    wanted = float(rng.uniform(0.05, 0.12))
    options: list[tuple[int, np.ndarray, float]] = []
    # strict first (forward/sideways, inside the workspace, room for the hand); then relaxed
    for margin, hand_room, toward_ok in ((0.03, 0.06, False), (0.07, 0.045, True)):
        for k in range(4):
            ang = pose.yaw + k * np.pi / 2
            direction = np.array([np.cos(ang), np.sin(ang)])
            if direction[1] < -0.5 and not toward_ok:  # people rarely push towards themselves
                continue
            for dist in (wanted, 0.05, 0.035):
                end = pose.pos[:2] + direction * dist
                if not (WORKSPACE_X[0] - margin <= end[0] <= WORKSPACE_X[1] + margin):
                    continue
                if not (WORKSPACE_Y[0] - margin <= end[1] <= WORKSPACE_Y[1] + margin):
                    continue
                path = [pose.pos[:2] + direction * dist * f for f in (0.5, 1.0)]
                hand = pose.pos[:2] - direction * 0.12
                if all(
                    min(np.linalg.norm(c - q) for q in path) > r_obj + r + 0.015
                    and np.linalg.norm(hand - c) > hand_room
                    for c, r in others
                ):
                    options.append((k, direction, float(dist)))
                    break
        if options:
            break
    if not options:
        raise DemonstrationError(f"no free direction to push {name}")
    k, direction, dist = options[int(rng.integers(len(options)))]
    half = 0.5 * spec.size[k % 2]
    yaw = float(np.arctan2(direction[1], direction[0])) + _deg(-8, 8, rng)
    pitch, roll = _deg(55, 70, rng), _deg(-6, 6, rng)
    q = POSTURES["push"]
    rel = P.relative_keypoints(q, yaw, pitch, roll)
    z = 0.004 + 0.0075 * s - float(rel[:, 2].min()) + rng.uniform(0.0, 0.006)
    low = (z + rel[:, 2]) < spec.size[2]
    low[0] = False
    front = float(np.max(rel[low, :2] @ direction)) + 0.009 * s if low.any() else 0.02
    contact = np.array([*(pose.pos[:2] - direction * (half + front)), z])
    standoff = contact - np.array([*(direction * rng.uniform(0.015, 0.04)), 0.0])
    standoff[:2] += np.array([-direction[1], direction[0]]) * rng.uniform(-0.01, 0.01)
    plan: dict[str, Any] = {
        "direction": np.array([direction[0], direction[1], 0.0]),
        "distance": dist,
        "contact": contact,
        "standoff": standoff,
        "hand": HandState(standoff, yaw, pitch, roll, q),
    }
    P.pending[key] = plan
    return plan


def push_entry(P: Planner, name: str) -> HandState:
    """Hand state above and behind ``name`` from which a Push starts."""
    plan, rng = _push_plan(P, name), P.rng
    hand = plan["hand"]
    assert isinstance(hand, HandState)
    tcp = hand.tcp + np.array([0.0, 0.0, rng.uniform(0.04, 0.08)])
    q = 0.5 * POSTURES["relaxed"] + 0.5 * POSTURES["push"]
    return hand.moved(tcp=tcp, pitch=hand.pitch - _deg(5, 20, rng), q=q)


def push(P: Planner, name: str) -> None:
    """Lower the hand behind the object, then slide the object along the table."""
    P.begin_skill()
    t0, rng = P.t, P.rng
    plan = _push_plan(P, name)
    P.pending.pop(("push", name), None)
    hand = plan["hand"]
    assert isinstance(hand, HandState)
    direction = np.asarray(plan["direction"], float)
    dist = float(plan["distance"])
    contact = np.asarray(plan["contact"], float)
    P.go(
        P.dur(0.6, 1.0),
        hand,
        detour=P.detour(P.state.tcp, hand.tcp, frac=(0.0, 0.08)),
        posture_window=(0.0, 0.7),
    )
    P.maybe_pause()
    t_push = P.t
    end = contact + direction * dist - np.array([0.0, 0.0, rng.uniform(0.0, 0.002)])
    P.go(
        P.dur(0.5, 0.8) + 7.0 * dist / P.skill_speed,
        hand.moved(tcp=end, yaw=hand.yaw + _deg(-4, 4, rng)),
        detour=P.detour(hand.tcp, end, frac=(0.0, 0.04)),
    )
    P.events.append(Push(t_push, P.t, name, direction, contact))
    P.log.append({"push": name, "distance": dist, "direction": direction[:2].round(6).tolist()})
    P.poses[name].pos = P.poses[name].pos + direction * dist
    P.hold(P.dur(0.1, 0.3))
    P.maybe_pause()
    P.label("push", t0, name)


# --- Locate ----------------------------------------------------------------------------------
def _point_plan(P: Planner, name: str) -> HandState:
    key = ("locate", name)
    if key not in P.pending:
        rng, pose = P.rng, P.poses[name]
        yaw, pitch, roll = P.natural_yaw(pose.pos), _deg(40, 60, rng), _deg(-5, 5, rng)
        q = POSTURES["point"]
        rel = P.relative_keypoints(q, yaw, pitch, roll)
        tip = np.array(
            [*(pose.pos[:2] + np.clip(rng.normal(0, 0.005, 2), -0.008, 0.008)), P.top(name)]
        )
        tip[2] += rng.uniform(0.04, 0.08)
        P.pending[key] = {"hand": HandState(tip - rel[INDEX_TIP], yaw, pitch, roll, q)}
    hand = P.pending[key]["hand"]
    assert isinstance(hand, HandState)
    return hand


def locate_entry(P: Planner, name: str) -> HandState:
    """Hand state above and behind the pointing pose from which a Locate starts."""
    hand, rng = _point_plan(P, name), P.rng
    back = -np.array([np.cos(hand.yaw), np.sin(hand.yaw), 0.0]) * rng.uniform(0.02, 0.06)
    side = np.array([-np.sin(hand.yaw), np.cos(hand.yaw), 0.0]) * rng.uniform(-0.03, 0.03)
    up = np.array([0.0, 0.0, rng.uniform(0.02, 0.06)])
    q = 0.6 * POSTURES["relaxed"] + 0.4 * POSTURES["point"]
    return hand.moved(tcp=hand.tcp + back + side + up, pitch=hand.pitch - _deg(5, 15, rng), q=q)


def locate(P: Planner, name: str) -> None:
    """Point at the object from 4-8 cm above its top face and hover there about a second."""
    P.begin_skill()
    t0, rng = P.t, P.rng
    hand = _point_plan(P, name)
    P.pending.pop(("locate", name), None)
    P.go(
        P.dur(0.7, 1.1),
        hand,
        detour=P.detour(P.state.tcp, hand.tcp, frac=(0.0, 0.1)),
        posture_window=(0.0, 0.7),
    )
    drift = np.array([*rng.uniform(-0.003, 0.003, 2), -rng.uniform(0.0, 0.003)])
    P.go(P.dur(0.8, 1.5), hand.moved(tcp=hand.tcp + drift))
    P.maybe_pause()
    P.label("locate", t0, name)
