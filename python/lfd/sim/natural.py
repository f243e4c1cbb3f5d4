"""The natural demonstrator's grasping skills: timed like people in motion capture.

Same label semantics as :mod:`lfd.sim.skills` (the TCP rises only in Move and Move with; a Pick
up ends grasped at the grasp point and the object has not moved; a Place ends released), but
fast, without hesitation, with several grasp types, and with a hand that stays at the object
between repeated cycles (docs/skills.md, "Two demonstrator styles"):

- **pick_up**: reach to 3-8 mm above the grasp point, descend in 0.04-0.08 s, close the grasp
  (pinch, thumb-middle or whole hand) in 0.15-0.22 s. The object leaves the table 0.34-0.56 s
  after the fingers started closing (Move with waits for it).
- **move_with**: lift the object 5-45 cm, carry it to a free spot (within 12 cm when the task
  repeats the lift, like ``exp5``) and end 4-6 cm above it, at about twice the careful speed.
- **place** / **stack**: lower in 0.15-0.3 s plus a final 3-8 mm, release, and open the grasp
  1.5-3.5 cm wider than the object — only 0.5-1.5 cm when the next skill grasps it again (the
  hand lingers on it).
- **move**: a re-grasp (the hand is at the object it grasps next) is short and low: the TCP rises
  4-12 mm and the hand stays at the object; other moves travel like the careful ones, faster.

Push and Locate are the careful skills (with no pauses: the natural style has none).
"""

from __future__ import annotations

import numpy as np

from .hand import FINGERTIP_RADIUS, POSTURES, grasp_posture
from .motion import HandState, minjerk
from .planner import Detach, ObjectPose, Planner
from .skills import _deg, _grasp, _max_top, attach, carry_target

LIFT_OFF_M = 0.01
"""Height the object must rise to count as lifted off (m)."""

REPEAT_SPOT_M = 0.12
"""A repeated lift puts the object down at most this far (m) from where it was picked up."""


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


def pick_up(P: Planner, name: str) -> None:
    """Reach to the object with the grasp pre-shaped and close it, without hesitation."""
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
    P.pending[("lift", name)] = {"t": t_close + rng.uniform(0.34, 0.56)}
    P.label("pick_up", t0, name)


def _rise_time(fraction: float) -> float:
    """The progress ``tau`` at which a minimum-jerk profile has covered ``fraction``."""
    tau = np.linspace(0.0, 1.0, 2001)
    return float(np.interp(fraction, minjerk(tau), tau))


def move_with(P: Planner, name: str, onto: str | None = None, *, repeat: bool = False) -> None:
    """Lift the held object 5-45 cm and carry it above a free spot (near by with ``repeat``) or
    above ``onto``; the lift-off keeps the time drawn by the Pick up."""
    if P.held != name or P.grasp_rel is None:
        raise RuntimeError(f"move_with needs {name} in the hand")
    P.begin_skill()
    t0, rng, s = P.t, P.rng, P.state
    spot = (0.0, REPEAT_SPOT_M) if repeat else (0.10, None)
    hand_yaw, tcp_final = carry_target(P, name, onto, spot=spot, turn_deg=20.0)
    above = tcp_final + np.array([0.0, 0.0, rng.uniform(0.04, 0.06)])
    below_tcp = 0.5 * P.specs[name].size[2] - P.grasp_rel[0][2]  # object bottom below the TCP
    z_peak = s.tcp[2] + 0.05 + 0.4 * rng.uniform() ** 1.5  # 5-45 cm, mostly the lower half
    z_peak = max(z_peak, above[2] + 0.01)
    if not repeat:  # a carry across the table clears every object; a repeated lift stays apart
        z_peak = max(z_peak, _max_top(P, name) + below_tcp + 0.03)
    dist = float(np.linalg.norm(above[:2] - s.tcp[:2]) + 2 * z_peak - s.tcp[2] - above[2])
    duration = P.dur(0.25, 0.4) + 1.5 * dist / P.skill_speed
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


def move(P: Planner, target: HandState, obj: str | None) -> None:
    """Travel (not holding) to ``target``: a short, low re-grasp when the hand is at ``obj``
    already, else rise above every object and travel."""
    P.begin_skill()
    t0, rng, s = P.t, P.rng, P.state
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
        dist = float(
            np.linalg.norm(target.tcp[:2] - s.tcp[:2]) + 2 * z_peak - s.tcp[2] - target.tcp[2]
        )
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
    P.label("move", t0, obj)
