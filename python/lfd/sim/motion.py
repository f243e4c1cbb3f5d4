"""Human-like hand motion: minimum-jerk segments with curved detours, on one continuous plan.

A :class:`Plan` is a list of contiguous :class:`Segment` s. Each segment moves the TCP (midpoint
of the index and thumb tips), the hand orientation (yaw, pitch, roll of the wrist) and the finger
posture from one state to the next with a minimum-jerk profile (Flash & Hogan 1985). Human paths
are not straight: a segment adds a bell-shaped *detour* (peak at mid-movement, zero velocity and
acceleration at both ends), which bends the path through a via point off the straight line
without stopping there. Transport segments (Move, Move with) may use a *rise-first* height
profile: the TCP climbs to ``z_peak`` during the first ``rise_frac`` of the segment while the
horizontal motion starts after ``xy_delay`` — people lift before they carry. All other segments
have a height that is monotone between its end points, and their detour is horizontal.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np


def minjerk(tau: np.ndarray) -> np.ndarray:
    """Minimum-jerk progress ``10 t^3 - 15 t^4 + 6 t^5`` of ``tau`` clipped to [0, 1]."""
    t = np.clip(tau, 0.0, 1.0)
    return t * t * t * (10.0 + t * (-15.0 + 6.0 * t))


def bump(tau: np.ndarray) -> np.ndarray:
    """Bell ``64 t^3 (1 - t)^3``: 0 at both ends (with zero slope and curvature), 1 at ``t = 0.5``."""
    t = np.clip(tau, 0.0, 1.0)
    return 64.0 * (t * (1.0 - t)) ** 3


def rotation(yaw: np.ndarray, pitch: np.ndarray, roll: np.ndarray) -> np.ndarray:
    """Wrist rotation ``Rz(yaw) Ry(pitch) Rx(roll)`` for arrays of angles, shape (..., 3, 3).

    With the wrist frame of :mod:`lfd.sim.hand`, positive pitch tilts the fingers down.
    """
    cy, sy = np.cos(yaw), np.sin(yaw)
    cp, sp = np.cos(pitch), np.sin(pitch)
    cr, sr = np.cos(roll), np.sin(roll)
    R = np.empty((*np.shape(yaw), 3, 3))
    R[..., 0, 0] = cy * cp
    R[..., 0, 1] = cy * sp * sr - sy * cr
    R[..., 0, 2] = cy * sp * cr + sy * sr
    R[..., 1, 0] = sy * cp
    R[..., 1, 1] = sy * sp * sr + cy * cr
    R[..., 1, 2] = sy * sp * cr - cy * sr
    R[..., 2, 0] = -sp
    R[..., 2, 1] = cp * sr
    R[..., 2, 2] = cp * cr
    return R


@dataclass(frozen=True)
class HandState:
    """Planned hand state: TCP position (m), wrist yaw/pitch/roll (rad), finger posture (20,)."""

    tcp: np.ndarray
    yaw: float
    pitch: float
    roll: float
    q: np.ndarray

    def moved(self, **changes: object) -> HandState:
        """A copy with some fields replaced (arrays are copied)."""
        new = replace(self, **changes)  # type: ignore[arg-type]
        return replace(new, tcp=np.array(new.tcp, float), q=np.array(new.q, float))


@dataclass
class Segment:
    """One minimum-jerk movement from ``start`` to ``end`` during ``[t0, t1]`` seconds.

    Attributes
    ----------
    detour : array, shape (3,)
        Offset of the path at mid-movement from the straight line (m).
    z_peak : float or None
        If set, the TCP height rises to ``z_peak`` during the first ``rise_frac`` of the segment,
        then goes to the end height (rise-first transport). Otherwise the height is monotone.
    xy_delay : float
        Fraction of the segment before the horizontal motion starts.
    posture_window, orient_window : tuple of float
        Fractions of the segment during which the fingers / the wrist orientation change.
    """

    t0: float
    t1: float
    start: HandState
    end: HandState
    detour: np.ndarray = field(default_factory=lambda: np.zeros(3))
    z_peak: float | None = None
    rise_frac: float = 0.4
    xy_delay: float = 0.0
    posture_window: tuple[float, float] = (0.0, 1.0)
    orient_window: tuple[float, float] = (0.0, 1.0)

    @property
    def duration(self) -> float:
        return self.t1 - self.t0

    def evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """TCP (n, 3), angles (n, 3) as yaw/pitch/roll and postures (n, 20) at times ``t``."""
        tau = (np.asarray(t, float) - self.t0) / max(self.duration, 1e-9)
        p0, p1 = self.start.tcp, self.end.tcp
        s_xy = minjerk((tau - self.xy_delay) / max(1.0 - self.xy_delay, 1e-9))
        tcp = np.empty((tau.size, 3))
        tcp[:, :2] = p0[:2] + np.outer(s_xy, p1[:2] - p0[:2])
        if self.z_peak is None:
            tcp[:, 2] = p0[2] + (p1[2] - p0[2]) * minjerk(tau)
        else:
            r = self.rise_frac
            up = p0[2] + (self.z_peak - p0[2]) * minjerk(tau / r)
            down = self.z_peak + (p1[2] - self.z_peak) * minjerk((tau - r) / (1.0 - r))
            tcp[:, 2] = np.where(tau < r, up, down)
        tcp += np.outer(bump(tau), self.detour)
        a, b = self.orient_window
        s_o = minjerk((tau - a) / max(b - a, 1e-9))
        a0 = np.array([self.start.yaw, self.start.pitch, self.start.roll])
        a1 = np.array([self.end.yaw, self.end.pitch, self.end.roll])
        angles = a0 + np.outer(s_o, a1 - a0)
        a, b = self.posture_window
        s_q = minjerk((tau - a) / max(b - a, 1e-9))
        q = self.start.q + np.outer(s_q, self.end.q - self.start.q)
        return tcp, angles, q


@dataclass
class Plan:
    """Contiguous segments from time 0 plus the skill labels laid over them."""

    segments: list[Segment] = field(default_factory=list)

    @property
    def duration(self) -> float:
        return self.segments[-1].t1 if self.segments else 0.0

    def evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """TCP (n, 3), yaw/pitch/roll (n, 3), postures (n, 20) for sorted times ``t`` (s)."""
        t = np.asarray(t, float)
        tcp = np.empty((t.size, 3))
        ang = np.empty((t.size, 3))
        q = np.empty((t.size, self.segments[0].start.q.size))
        ends = np.array([s.t1 for s in self.segments])
        idx = np.minimum(np.searchsorted(ends, t, side="right"), len(self.segments) - 1)
        for k in np.unique(idx):
            sel = idx == k
            tcp[sel], ang[sel], q[sel] = self.segments[k].evaluate(t[sel])
        return tcp, ang, q


def smooth_noise(
    rng: np.random.Generator,
    t: np.ndarray,
    n_channels: int,
    *,
    amplitude: float,
    freq_range: tuple[float, float],
    n_components: int = 3,
) -> np.ndarray:
    """A smooth random signal (sum of sinusoids), shape (len(t), n_channels), std ~ ``amplitude``."""
    f = rng.uniform(*freq_range, size=(n_components, n_channels))
    phase = rng.uniform(0.0, 2.0 * np.pi, size=(n_components, n_channels))
    w = rng.uniform(0.5, 1.0, size=(n_components, n_channels))
    w *= amplitude * np.sqrt(2.0) / np.sqrt(np.sum(w * w, axis=0, keepdims=True))
    out = np.zeros((t.size, n_channels))
    for c in range(n_components):
        out += w[c] * np.sin(2.0 * np.pi * np.outer(t, f[c]) + phase[c])
    return out
