"""The natural demonstrator's grasping skills: timed like people in motion capture.

Same label semantics as :mod:`lfd.sim.skills` (the TCP rises only in Move and Move with; a Pick
up ends grasped at the grasp point and the object has not moved; a Place ends released), but
fast, without hesitation, with several grasp types, and with a hand that stays at the object
between repeated cycles (docs/skills.md, "Two demonstrator styles"):

- **pick_up**: reach to 3-8 mm above the grasp point, descend in 0.04-0.08 s, close the grasp
  (pinch, thumb-middle or whole hand) in 0.15-0.22 s. The object leaves the table 0.34-0.56 s
  after the fingers started closing (Move with waits for it). A Pick up that is not a re-grasp
  at the object turns (30-90 deg about z) and/or slides (2-8 cm) the object on the table with
  probability :data:`TURN_P`, in one or two strokes, re-grasping it after a stroke or lifting
  it in the grasp that turned it (the turn is part of the Pick up: docs/skills.md,
  "Boundaries").
- **move_with**: lift the object 5-45 cm, carry it to a free spot (within 12 cm when the task
  repeats the lift, like ``exp5``) and end 4-6 cm above it, at about twice the careful speed.
  A quick low lift (``exp7``) rises 5.5-10 cm in 0.25-0.5 s to a spot within 8 cm; a lift that
  turns the object in the hand turns it (and the hand) 40-120 deg about z (25-70 deg when quick).
- **place** / **stack**: lower in 0.15-0.3 s plus a final 3-8 mm, release, and open the grasp
  1.5-3.5 cm wider than the object — only 0.5-1.5 cm when the next skill grasps it again (the
  hand lingers on it).
- **move**: a re-grasp (the hand is at the object it grasps next) is short and low: the TCP rises
  4-12 mm and the hand stays at the object; other moves travel like the careful ones, faster.
  Between two cycles of ``exp7`` the hand may instead back off 3-6 cm from the box (never 8 cm)
  and come back, or rest near the body for 0.4-2.5 s and come back.
  A Move to a Pick up ends, with probability :data:`HOVER_P`, with an idle hover of 1-4 s
  beside the object, 8.7-12 cm from its box (the Pick up starts there: where the TCP was last 8
  cm away).

Push and Locate are the careful skills (with no pauses: the natural style has none).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..contact import box_distance
from .hand import FINGERTIP_RADIUS, POSTURES, grasp_posture
from .motion import HandState, minjerk
from .planner import Detach, ObjectPose, Planner
from .skills import _deg, _grasp, _max_top, attach, carry_target, over_length, rest_pose
from .tasks import WORKSPACE_X, WORKSPACE_Y

LIFT_OFF_M = 0.01
"""Height the object must rise to count as lifted off (m)."""

REPEAT_SPOT_M = 0.12
"""A repeated lift puts the object down at most this far (m) from where it was picked up."""

HOVER_P = 0.35
"""Probability that a Move to a Pick up (not a re-grasp) ends with an idle hover."""

HOVER_S = (1.0, 4.0)
"""Duration of a hover (s)."""

HOVER_M = (0.087, 0.12)
"""Distance of a hover from the object's box (m): beyond the Pick up's 8 cm."""

TURN_P = 0.3
"""Probability that a Pick up (not a re-grasp) turns or slides the object on the table first."""

TURN_DEG = (30.0, 90.0)
"""Turn of one stroke about z (deg, either sign); two strokes turn up to 180 deg."""

SLIDE_M = (0.02, 0.08)
"""Slide of one stroke on the table (m)."""

QUICK_S = (0.25, 0.5)
"""Duration of a quick low lift's motion (s; its label also holds the wait for lift-off)."""

QUICK_RISE_M = (0.055, 0.10)
"""How high a quick low lift raises the object (m): above the 5 cm at which a Place starts."""

QUICK_SPOT_M = 0.08
"""A quick low lift puts the object down at most this far (m) from where it was picked up."""

TURN_IN_HAND_DEG = (40.0, 120.0)
"""Turn of the object in the hand during a lift that turns it (deg about z, either sign; 25-70
deg when the lift is quick)."""

NEAR_M = (0.03, 0.06)
"""How far from the box (m) the hand backs off between two cycles (``leave="near"``)."""

AWAY_S = (0.4, 2.5)
"""How long the hand stays away between two cycles (``leave="away"``, s)."""


def _at(P: Planner, name: str) -> bool:
    """The empty hand is still at ``name`` (TCP within 8 cm horizontally, below its top + 3 cm)."""
    if P.hand is None or P.held is not None:
        return False
    d = float(np.linalg.norm(P.hand.tcp[:2] - P.poses[name].pos[:2]))
    return d < 0.08 and float(P.hand.tcp[2]) < P.top(name) + 0.03


def pick_up_entry(P: Planner, name: str) -> HandState:
    """Hand state from which a Pick up starts: a few mm above the grasp when the hand is still
    at the object, else 3-8 cm above its top face."""
    G, rng = _grasp(P, name), P.rng
    tcp = np.array(G["tcp"], float)
    yaw, pitch, roll = float(G["yaw"]), float(G["pitch"]), float(G["roll"])
    q_pre = grasp_posture(str(G["kind"]), float(G["g_pre"]))
    if _at(P, name):
        p = tcp + np.array([*rng.uniform(-0.004, 0.004, 2), rng.uniform(0.006, 0.014)])
        return HandState(p, yaw, pitch, roll, q_pre)
    back = np.array([np.cos(yaw), np.sin(yaw)]) * -rng.uniform(0.0, 0.03)
    p = np.array([*(tcp[:2] + back), P.top(name) + rng.uniform(0.03, 0.08)])
    q = 0.3 * POSTURES["relaxed"] + 0.7 * q_pre
    return HandState(p, yaw + _deg(-8, 8, rng), pitch - _deg(0, 8, rng), roll, q)


def pick_up(P: Planner, name: str, *, turn: bool = False) -> None:
    """Reach to the object with the grasp pre-shaped and close it, without hesitation; with
    ``turn`` (not a re-grasp) the object may be turned or slid on the table first."""
    P.begin_skill()
    t0, G, rng = P.t, _grasp(P, name), P.rng
    P.pending.pop(("pick_up", name), None)
    tcp = np.array(G["tcp"], float)
    ang = {k: float(G[k]) for k in ("yaw", "pitch", "roll")}
    kind = str(G["kind"])
    above = tcp + np.array([0.0, 0.0, rng.uniform(0.003, 0.008)])
    above[2] = min(above[2], P.state.tcp[2])
    reach = HandState(above, q=grasp_posture(kind, float(G["g_pre"])), **ang)
    dist = float(np.linalg.norm(above - P.state.tcp))
    P.go(
        P.dur(0.06, 0.12) + 1.1 * dist / P.skill_speed,
        reach,
        detour=P.detour(P.state.tcp, above, frac=(0.0, 0.1)),
        posture_window=(0.0, 0.8),
        orient_window=(0.0, 0.9),
    )
    P.go(rng.uniform(0.04, 0.08), reach.moved(tcp=tcp))
    t_close = P.t
    P.go(rng.uniform(0.15, 0.22), P.state.moved(q=grasp_posture(kind, float(G["g"]))))
    attach(P, name, G, t_close)
    P.hold(rng.uniform(0.02, 0.06))
    t_lift = t_close + rng.uniform(0.34, 0.56)
    if turn and rng.random() < TURN_P:
        t_lift = _turn_on_table(P, name, G, t_lift)
    P.pending[("lift", name)] = {"t": t_lift}
    P.label("pick_up", t0, name)


def _yaw_quat(yaw: float) -> np.ndarray:
    return np.array([0.0, 0.0, np.sin(0.5 * yaw), np.cos(0.5 * yaw)])


def _clear(P: Planner, name: str, centre: np.ndarray) -> bool:
    """``name`` may stand (at any yaw) with its centre at ``centre``: on the table, inside the
    workspace and clear of every other object."""
    if abs(float(P.poses[name].pos[2]) - 0.5 * P.specs[name].size[2]) > 1e-3:
        return False  # stacked: not on the table
    if not (
        WORKSPACE_X[0] - 0.03 <= centre[0] <= WORKSPACE_X[1] + 0.03
        and WORKSPACE_Y[0] - 0.03 <= centre[1] <= WORKSPACE_Y[1] + 0.03
    ):
        return False
    r = 0.5 * float(np.hypot(*P.specs[name].size[:2]))
    return all(
        float(np.linalg.norm(centre[:2] - pose.pos[:2]))
        > r + 0.5 * float(np.hypot(*P.specs[other].size[:2])) + 0.01
        for other, pose in P.poses.items()
        if other != name
    )


def _turn_on_table(P: Planner, name: str, G: dict[str, Any], t_lift: float) -> float:
    """Turn and/or slide the grasped ``name`` on the table in one or two strokes (the TCP never
    rises), re-grasping it after a stroke the way the hand first held it (cubes: the same face
    grasp, rotated back by a multiple of 90 deg), or keeping the grasp for the lift. Returns the
    lift-off time (s). Nothing happens when the object has no room to turn."""
    rng = P.rng
    strokes = 1 if rng.random() < 0.7 else 2
    regrasp_last = rng.random() < 0.5
    pose0 = P.poses[name].copy()
    rel0 = P.state.tcp - pose0.pos  # the grasp relative to the object, hand yaw G["yaw"]
    yaw0 = P.state.yaw
    log: dict[str, object] = {"table_turn": name, "t0_s": round(P.t, 6)}
    total, moved = 0.0, np.zeros(2)
    for k in range(strokes):
        pose = P.poses[name]
        theta = float(np.deg2rad(rng.uniform(*TURN_DEG))) * (1.0 if rng.random() < 0.5 else -1.0)
        a = rng.uniform(-np.pi, np.pi)
        slide = rng.uniform(*SLIDE_M) * np.array([np.cos(a), np.sin(a)])
        mode = rng.choice(3, p=[0.45, 0.25, 0.3])  # turn, slide, both
        if mode == 1:
            theta = 0.0
        elif mode == 0:
            slide = np.zeros(2)
        centre = pose.pos[:2] + slide
        if not _clear(P, name, centre):
            slide, centre = np.zeros(2), pose.pos[:2].copy()
            if theta == 0.0 or not _clear(P, name, centre):
                break
        c, s_ = np.cos(theta), np.sin(theta)
        d = P.state.tcp[:2] - pose.pos[:2]
        tcp = P.state.tcp.copy()
        tcp[:2] = centre + np.array([c * d[0] - s_ * d[1], s_ * d[0] + c * d[1]])
        P.go(P.dur(0.35, 0.7) + 0.25 * abs(theta), P.state.moved(tcp=tcp, yaw=P.state.yaw + theta))
        new = ObjectPose(np.array([centre[0], centre[1], pose.pos[2]]), pose.yaw + theta)
        total, moved = total + theta, moved + slide
        P.hold(rng.uniform(0.05, 0.15))
        if k == strokes - 1 and not regrasp_last:
            P.poses[name] = new
            P.hold(rng.uniform(0.1, 0.25))  # at rest before the lift
            t_lift = P.t + rng.uniform(0.25, 0.45)
            break
        # let go, open a little wider and take it again as first held (cube faces: turned back
        # by the multiple of 90 deg nearest to the turn so far)
        P.events.append(Detach(P.t, name, new.copy()))
        P.poses[name] = new
        P.held, P.grasp_rel = None, None
        P.grasps[-1]["table_turn"] = True
        kind = str(G["kind"])
        g_open = P.kin.grasp_for_aperture(
            kind, float(G["width"]) + 2 * FINGERTIP_RADIUS * P.scale + rng.uniform(0.02, 0.04)
        )
        P.go(rng.uniform(0.1, 0.18), P.state.moved(q=grasp_posture(kind, g_open)))
        back = total - 0.5 * np.pi * round(total / (0.5 * np.pi))
        c, s_ = np.cos(back), np.sin(back)
        tcp = P.state.tcp.copy()
        tcp[:2] = new.pos[:2] + np.array([c * rel0[0] - s_ * rel0[1], s_ * rel0[0] + c * rel0[1]])
        P.go(P.dur(0.25, 0.45), P.state.moved(tcp=tcp, yaw=yaw0 + back))
        t_close = P.t
        P.go(rng.uniform(0.15, 0.22), P.state.moved(q=grasp_posture(kind, float(G["g"]))))
        attach(P, name, {**G, "yaw": yaw0 + back}, t_close)
        P.hold(rng.uniform(0.02, 0.06))
        t_lift = t_close + rng.uniform(0.34, 0.56)
    if total or moved.any():
        log.update(
            t1_s=round(P.t, 6),
            turn_deg=round(float(np.rad2deg(total)), 2),
            slide_m=round(float(np.linalg.norm(moved)), 4),
        )
        P.log.append(log)
    return t_lift


def _rise_time(fraction: float) -> float:
    """The progress ``tau`` at which a minimum-jerk profile has covered ``fraction``."""
    tau = np.linspace(0.0, 1.0, 2001)
    return float(np.interp(fraction, minjerk(tau), tau))


def move_with(
    P: Planner,
    name: str,
    onto: str | None = None,
    *,
    repeat: bool = False,
    quick: bool = False,
    turn: bool = False,
) -> None:
    """Lift the held object 5-45 cm and carry it above a free spot (near by with ``repeat``) or
    above ``onto``; with ``quick`` a quick low lift (:data:`QUICK_RISE_M` in :data:`QUICK_S`),
    with ``turn`` turning the object in the hand (:data:`TURN_IN_HAND_DEG`); the lift-off keeps
    the time drawn by the Pick up."""
    if P.held != name or P.grasp_rel is None:
        raise RuntimeError(f"move_with needs {name} in the hand")
    P.begin_skill()
    t0, rng, s = P.t, P.rng, P.state
    spot = (0.0, QUICK_SPOT_M if quick else REPEAT_SPOT_M) if repeat or quick else (0.10, None)
    yaw_turn = None
    if turn and onto is None:
        lo, hi = (25.0, 70.0) if quick else TURN_IN_HAND_DEG
        yaw_turn = _deg(lo, hi, rng) * (1.0 if rng.random() < 0.5 else -1.0)
    hand_yaw, tcp_final = carry_target(P, name, onto, spot=spot, turn_deg=20.0, turn=yaw_turn)
    below_tcp = 0.5 * P.specs[name].size[2] - P.grasp_rel[0][2]  # object bottom below the TCP
    if quick:
        above = tcp_final + np.array([0.0, 0.0, rng.uniform(0.04, 0.05)])
        z_peak = max(s.tcp[2] + rng.uniform(*QUICK_RISE_M), above[2] + 0.01)
        duration = rng.uniform(*QUICK_S) / P.skill_speed * (1.0 + 0.3 * abs(yaw_turn or 0.0))
    else:
        above = tcp_final + np.array([0.0, 0.0, rng.uniform(0.04, 0.06)])
        # 5-45 cm, mostly the lower half (x lift_scale: a carry that starts in the air rises less)
        z_peak = s.tcp[2] + 0.05 + 0.4 * P.lift_scale * rng.uniform() ** 1.5
        z_peak = max(z_peak, above[2] + 0.01)
        if not repeat:  # a carry across the table clears every object; a repeated lift stays apart
            z_peak = max(z_peak, _max_top(P, name) + below_tcp + 0.03)
        dist = over_length(s.tcp, above, z_peak)
        duration = P.dur(0.25, 0.4) + 1.5 * dist / P.skill_speed
        if yaw_turn is not None:  # turning the object about takes its time
            duration += P.dur(0.2, 0.6) * abs(yaw_turn)
    rise = rng.uniform(0.4, 0.5)
    lift = P.pending.pop(("lift", name), None)
    if lift is not None:  # hold still until the drawn lift-off time
        t_off = _rise_time(LIFT_OFF_M / (z_peak - s.tcp[2])) * rise * duration
        P.hold(float(lift["t"]) - P.t - t_off)
    P.go(
        duration,
        s.moved(tcp=above, yaw=hand_yaw),
        detour=P.detour(s.tcp, above, frac=(0.0, 0.08)),
        z_peak=z_peak,
        rise_frac=rise,
        xy_delay=rng.uniform(0.05, 0.2),
    )
    P.label("move_with", t0, name)


def put_down(P: Planner, name: str, skill: str, *, linger: bool = False) -> None:
    """Place or stack the held object quickly and release it; with ``linger`` the grasp opens
    only a little (the hand stays at the object for the next grasp)."""
    if P.held != name:
        raise RuntimeError(f"{skill} needs {name} in the hand")
    P.begin_skill()
    t0, rng = P.t, P.rng
    target = P.pending.pop(("place", name))
    tcp = np.array(target["tcp"], float)
    pose = target["pose"]
    assert isinstance(pose, ObjectPose)
    near = tcp + np.array([0.0, 0.0, rng.uniform(0.003, 0.008)])
    dist = float(np.linalg.norm(near - P.state.tcp))
    P.go(
        P.dur(0.15, 0.3) + 1.2 * dist / P.skill_speed,
        P.state.moved(tcp=near),
        detour=P.detour(P.state.tcp, near, frac=(0, 0.05)),
    )
    P.go(rng.uniform(0.05, 0.1), P.state.moved(tcp=tcp))
    P.events.append(Detach(P.t, name, pose.copy()))
    P.poses[name] = pose.copy()
    P.held, P.grasp_rel = None, None
    grasp = P.grasps[-1]
    kind = str(grasp["type"])
    margin = rng.uniform(0.005, 0.015) if linger else rng.uniform(0.015, 0.035)
    g_open = P.kin.grasp_for_aperture(
        kind, float(grasp["width"]) + 2 * FINGERTIP_RADIUS * P.scale + margin
    )
    P.go(rng.uniform(0.1, 0.16), P.state.moved(q=grasp_posture(kind, g_open)))
    P.hold(rng.uniform(0.0, 0.04))
    P.label(skill, t0, name)


def hover_state(
    P: Planner, name: str, target: HandState, heading: float | None = None
) -> HandState:
    """An idle hand beside ``name``, 8.7-12 cm from its box (:data:`HOVER_M`), back along the
    approach of ``target`` (the Pick up's entry; or towards ``heading`` from the object), at 0-2
    cm above the grasp's height (real hands rest low beside the object; the TCP must not rise in
    the Pick up that follows), loosely pre-shaped, the wrist turned up to 15 deg."""
    rng, pose, size = P.rng, P.poses[name], np.asarray(P.specs[name].size, float)
    G = _grasp(P, name)
    dist = rng.uniform(*HOVER_M)
    if heading is None:
        heading = target.yaw + np.pi + _deg(-30, 30, rng)
    base = np.array([pose.pos[0], pose.pos[1], float(G["tcp"][2]) + rng.uniform(0.0, 0.02)])
    u = np.array([np.cos(heading), np.sin(heading), 0.0])
    lo, hi = 0.0, 0.6
    for _ in range(30):  # the point along u at the drawn distance from the box
        mid = 0.5 * (lo + hi)
        p = base + mid * u
        d = float(box_distance(p[None], pose.pos[None], _yaw_quat(pose.yaw)[None], size)[0])
        lo, hi = (mid, hi) if d < dist else (lo, mid)
    w = rng.uniform(0.5, 0.8)
    q = w * POSTURES["relaxed"] + (1.0 - w) * target.q
    return target.moved(tcp=base + hi * u, q=q, yaw=target.yaw + _deg(-15, 15, rng))


def _leave(P: Planner, obj: str, leave: str) -> None:
    """Take the empty hand off ``obj`` between two cycles: back off (``"near"``) 3-6 cm from its
    box and wait there 0.1-0.6 s, or go away (``"away"``) to a rest pose near the body (clear of
    every object: not a hover above one), idle for :data:`AWAY_S`; the fingers relax."""
    rng, s, pose = P.rng, P.state, P.poses[obj]
    size = np.asarray(P.specs[obj].size, float)
    w = rng.uniform(0.2, 0.5)
    q = w * POSTURES["relaxed"] + (1.0 - w) * s.q
    if leave == "near":
        d = s.tcp[:2] - pose.pos[:2]
        heading = float(np.arctan2(d[1], d[0])) if np.linalg.norm(d) > 1e-3 else s.yaw + np.pi
        u = np.array([np.cos(heading), np.sin(heading), 0.0])
        want = rng.uniform(*NEAR_M)
        up = rng.uniform(0.01, 0.03)
        lo, hi = 0.0, 0.3
        for _ in range(30):  # back along u (and up) until the box is ``want`` away
            mid = 0.5 * (lo + hi)
            p = s.tcp + mid * u + np.array([0.0, 0.0, up])
            dist = float(box_distance(p[None], pose.pos[None], _yaw_quat(pose.yaw)[None], size)[0])
            lo, hi = (mid, hi) if dist < want else (lo, mid)
        p = s.tcp + lo * u + np.array([0.0, 0.0, up])
        P.go(P.dur(0.15, 0.3), s.moved(tcp=p, q=q), posture_window=(0.0, 1.0))
        P.hold(rng.uniform(0.1, 0.6))
        return
    rest = rest_pose(P)  # back towards the body, clear of every object
    rest = rest.moved(q=0.5 * POSTURES["relaxed"] + 0.5 * rest.q)
    z_peak = max(s.tcp[2], rest.tcp[2]) + rng.uniform(0.02, 0.05)
    z_peak = max(z_peak, _max_top(P) + 0.05)
    dist = over_length(s.tcp, rest.tcp, z_peak)
    P.go(
        P.dur(0.2, 0.35) + 1.1 * dist / P.skill_speed,
        rest,
        detour=P.detour(s.tcp, rest.tcp, frac=(0.02, 0.1)),
        z_peak=z_peak,
        rise_frac=rng.uniform(0.3, 0.45),
        posture_window=(0.0, 1.0),
        orient_window=(0.1, 1.0),
    )
    t_idle = rng.uniform(*AWAY_S)
    for _ in range(2):  # idle, never still
        drift = P.state.tcp + np.array([*rng.uniform(-0.02, 0.02, 2), rng.uniform(-0.01, 0.01)])
        P.go(0.5 * t_idle, P.state.moved(tcp=drift), posture_window=(0.0, 1.0))


def move(
    P: Planner, target: HandState, obj: str | None, *, reach: bool = False, leave: str = ""
) -> None:
    """Travel (not holding) to ``target``: a short, low re-grasp when the hand is at ``obj``
    already, else rise above every object and travel; before a reach (``reach``: a Pick up of
    ``obj`` follows) the hand may hover idle near the object instead (the Pick up then starts
    from the hover). Between two cycles of ``obj`` (``leave``: ``"near"`` or ``"away"``) the
    hand first backs off or goes away (:func:`_leave`), then comes back to ``target``."""
    P.begin_skill()
    t0, rng, s = P.t, P.rng, P.state
    hover = None
    if leave == "near" and obj is not None:
        _leave(P, obj, leave)
        s = P.state
        z_peak = max(s.tcp[2], target.tcp[2]) + rng.uniform(0.002, 0.008)
        P.go(
            P.dur(0.2, 0.35),
            target,
            z_peak=z_peak,
            rise_frac=0.3,
            posture_window=(0.1, 0.9),
            orient_window=(0.0, 0.9),
        )
        P.label("move", t0, obj)
        return
    if leave == "away" and obj is not None:  # back from afar: the reach starts above the object
        _leave(P, obj, leave)
        s, target = P.state, pick_up_entry(P, obj)
    if reach and obj is not None and not _at(P, obj) and rng.random() < HOVER_P:
        hover, target = target, hover_state(P, obj, target)
    if obj is not None and _at(P, obj):
        z_peak = max(s.tcp[2], target.tcp[2]) + rng.uniform(0.004, 0.012)
        kind = str(P.pending[("pick_up", obj)]["kind"])
        if kind == P.last_grasp:
            P.go(P.dur(0.1, 0.2), target, z_peak=z_peak, rise_frac=rng.uniform(0.35, 0.5))
        else:  # another grasp type: lift the fingers over the object while changing them
            low = min(
                float(P.relative_keypoints(h.q, h.yaw, h.pitch, h.roll)[:, 2].min())
                for h in (s, target)
            )
            z_peak = max(z_peak, P.top(obj) + 0.003 - low)
            P.go(
                P.dur(0.25, 0.4),
                target,
                z_peak=z_peak,
                rise_frac=0.5,
                xy_delay=0.3,
                posture_window=(0.25, 0.85),
                orient_window=(0.2, 0.9),
            )
    else:
        z_peak = max(s.tcp[2], target.tcp[2]) + rng.uniform(0.02, 0.06)
        z_peak = max(z_peak, _max_top(P) + 0.05)
        dist = over_length(s.tcp, target.tcp, z_peak)
        P.go(
            P.dur(0.2, 0.35) + 1.1 * dist / P.skill_speed,
            target,
            detour=P.detour(s.tcp, target.tcp, frac=(0.02, 0.1)),
            z_peak=z_peak,
            rise_frac=rng.uniform(0.3, 0.45),
            xy_delay=rng.uniform(0.05, 0.2),
            posture_window=(0.1, 1.0),
            orient_window=(0.1, 1.0),
        )
    if hover is not None and obj is not None:  # idle, never still: the hand drifts about
        # beside the object (each pose 8.7-12 cm from its box, within +-12 deg around it)
        t_h, entry = P.t, hover
        d = target.tcp[:2] - P.poses[obj].pos[:2]
        heading = float(np.arctan2(d[1], d[0]))
        n = int(rng.integers(2, 5))
        for _ in range(n):
            pose = hover_state(P, obj, entry, heading + _deg(-12, 12, rng))
            P.go(rng.uniform(*HOVER_S) / n, pose, posture_window=(0.0, 1.0))
        P.log.append({"hover": obj, "t0_s": round(t_h, 6), "t1_s": round(P.t, 6)})
    P.label("move", t0, obj)
