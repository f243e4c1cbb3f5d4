"""Time scaling: a planned path re-timed so the arm can follow it (the demonstration's timing is
a wish, not a command).

People move faster than the simulated arm can follow: a real hand reaches 1-2 m/s and several
m/s², and an arm driven at that pace falls up to 16 cm behind its planned path. :func:`retime`
keeps the geometric path of a plan and slows it down wherever it exceeds the TCP limits
(:class:`Limits`: speed and acceleration of the position, and of the yaw). It never speeds a
plan up.

How: a local slowdown ``r(t) >= 1`` is the largest of ``|v| / v_max``, ``sqrt(|a| / a_max)``
and the same for the yaw (a path played ``r`` times slower has ``1/r`` of the speed and ``1/r²``
of the acceleration). ``r`` is widened by a running maximum over :data:`SMOOTH_S` and then
averaged over a shorter window (so it stays at least the required value everywhere and changes
gently: a changing ``r`` adds acceleration of its own; where the path holds still, a dwell, time
runs as planned), the plan's phase advances at ``1/r`` of
real time and the path is sampled there (cubic interpolation). The result is checked again and
the step repeated on it while any limit is still exceeded (:data:`MAX_PASSES`). A time-varying
speed override like this keeps the path exactly; it is not time-optimal like TOPP-RA, but its
output satisfies the same limits.
"""

from __future__ import annotations

import numpy as np

from .arm import Limits
from .controller import TICK, Plan
from .robot import KUKA_LWR4

__all__ = ["LIMITS", "Limits", "derivatives", "durations", "retime", "retime_together", "slowdown"]


LIMITS = KUKA_LWR4.limits
"""The default robot's limits (:attr:`~lfd.reproduce.arm.Robot.limits`: each robot has its
own, :class:`~lfd.reproduce.arm.Limits`)."""
SMOOTH_S = 0.3
"""Width (s) of the running maximum that spreads a slowdown around its cause."""
MAX_PASSES = 6
"""Re-timing passes at most; each pass handles what the previous one's changing rate added."""
TOLERANCE = 1.02
"""A pass is repeated while a limit is exceeded by more than this factor."""


def derivatives(y: np.ndarray, dt: float = TICK) -> tuple[np.ndarray, np.ndarray]:
    """Velocity and acceleration of samples ``y`` (n, d) at ``dt`` (central differences)."""
    y = np.asarray(y, dtype=np.float64)
    if y.shape[0] < 3:
        z = np.zeros_like(y)
        return z, z
    v = np.gradient(y, dt, axis=0)
    a = np.gradient(v, dt, axis=0)
    return v, a


def slowdown(position: np.ndarray, yaw: np.ndarray, limits: Limits = LIMITS) -> np.ndarray:
    """Per-sample factor (>= 1) by which a path at :data:`TICK` exceeds ``limits``, shape (n,)."""
    v, a = derivatives(np.asarray(position))
    w, al = derivatives(np.asarray(yaw, dtype=np.float64)[:, None])
    r = np.maximum.reduce(
        [
            np.ones(v.shape[0]),
            np.linalg.norm(v, axis=1) / limits.speed,
            np.sqrt(np.linalg.norm(a, axis=1) / limits.acceleration),
            np.abs(w[:, 0]) / limits.yaw_rate,
            np.sqrt(np.abs(al[:, 0]) / limits.yaw_acceleration),
        ]
    )
    return np.asarray(r)


def _smooth(r: np.ndarray) -> np.ndarray:
    """A rate at least ``r`` everywhere that changes gently (running maximum, then mean)."""
    from scipy.ndimage import maximum_filter1d, uniform_filter1d

    w = max(1, round(SMOOTH_S / TICK))
    wide = maximum_filter1d(r, size=2 * w + 1, mode="nearest")
    # a mean over at most the maximum's half width never drops below r (every term covers it)
    return np.asarray(uniform_filter1d(wide, size=w | 1, mode="nearest"))


def _resample_plan(plan: Plan, phase: np.ndarray) -> Plan:
    """``plan`` sampled at fractional tick indices ``phase`` (increasing, from 0 to n - 1)."""
    from scipy.interpolate import make_interp_spline

    n = len(plan)
    x = np.arange(n, dtype=np.float64)
    y = np.column_stack([plan.position, plan.yaw])
    k = 3 if n >= 4 else 1
    path = np.asarray(make_interp_spline(x, y, k=k)(phase))
    # a cubic through a path that holds still (a dwell) overshoots next to a sudden start:
    # never leave the hull of the two neighbouring samples
    lo_i = np.clip(np.floor(phase).astype(int), 0, n - 1)
    hi_i = np.clip(lo_i + 1, 0, n - 1)
    path = np.clip(path, np.minimum(y[lo_i], y[hi_i]), np.maximum(y[lo_i], y[hi_i]))
    near = np.clip(np.rint(phase).astype(int), 0, n - 1)
    # the gripper command and the segment index are steps: the one in force at that phase
    return Plan(path[:, :3], path[:, 3], plan.opening[lo_i].copy(), plan.segment[near].copy())


def _pass(plans: list[Plan], limits: list[Limits]) -> list[Plan]:
    """One pass over plans of one length played on one clock: the largest slowdown of any."""
    r = np.ones(len(plans[0]))
    for plan, lim in zip(plans, limits, strict=True):
        rp = _smooth(slowdown(plan.position, plan.yaw, lim))
        # where the path holds still (a dwell) nothing is gained by slowing: time runs as planned
        y = np.column_stack([plan.position, plan.yaw])
        step = np.r_[np.abs(np.diff(y, axis=0)).max(axis=1), 0.0]
        still = (step < 1e-9) & (np.r_[0.0, step[:-1]] < 1e-9)
        rp[still] = 1.0
        r = np.maximum(r, rp)
    if r.max() <= 1.0:
        return plans
    n = len(plans[0])
    x = np.arange(n, dtype=np.float64)
    steps = [0.0]
    # the phase (in ticks of the old plan) advances 1/r ticks per tick
    while steps[-1] < n - 1:
        steps.append(steps[-1] + 1.0 / float(np.interp(steps[-1], x, r)))
    phase = np.minimum(np.array(steps), n - 1)
    return [_resample_plan(plan, phase) for plan in plans]


def retime(plan: Plan, limits: Limits = LIMITS) -> Plan:
    """The same path as ``plan``, slowed down wherever it exceeds ``limits`` (never sped up).

    Parameters
    ----------
    plan : Plan
        TCP path, yaw, gripper command and segment index at :data:`TICK`.
    limits : Limits

    Returns
    -------
    Plan
        At :data:`TICK` spacing, at least as long as ``plan``; positions and yaws lie on the
        same path in the same order, the gripper commands and segment indices follow them.
    """
    return retime_together([plan], [limits])[0]


def retime_together(plans: list[Plan], limits: list[Limits]) -> list[Plan]:
    """Plans of one length that run on one clock (two arms carrying one object), slowed down
    together wherever any exceeds its arm's ``limits``: the same phase for every plan, so they
    stay the same length and tick for tick together (:func:`retime` of one plan)."""
    if len({len(p) for p in plans}) > 1:
        raise ValueError("retime_together needs plans of one length")
    out = list(plans)
    for _ in range(MAX_PASSES):
        worst = max(
            slowdown(p.position, p.yaw, lim).max() for p, lim in zip(out, limits, strict=True)
        )
        if len(out[0]) < 4 or worst <= TOLERANCE:
            break
        out = _pass(out, limits)
    return out


def durations(plan: Plan, n_segments: int) -> np.ndarray:
    """Robot time (s) of each segment, including the dwell and lift-off ticks (-1) after it."""
    seg = np.asarray(plan.segment)
    out = np.zeros(n_segments)
    owner = -1
    for s in seg:
        if s >= 0:
            owner = int(s)
        if 0 <= owner < n_segments:
            out[owner] += TICK
    return out
