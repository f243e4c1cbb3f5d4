"""Online (fixed-lag or causal) preprocessing and features: the live counterpart of :func:`preprocess` and
:func:`lfd.features.compute_features`, one sample at a time while a demonstration is recorded.

:class:`OnlinePreprocessor` takes the raw messages as they arrive — hand keypoint frames
(:meth:`~OnlinePreprocessor.add_hand`) and object poses (:meth:`~OnlinePreprocessor.add_object`),
in any interleaving — and returns :class:`OnlineSample` rows on the uniform output clock as soon as
they are determined. :class:`OnlineFeatures` turns those rows into the Table I feature rows the
segmentation consumes (:class:`FeatureSample`). :func:`replay` feeds a loaded
:class:`~lfd.demo.Demonstration` through both in timestamp order (tests, benches, ``--follow``).
The offline path (:func:`preprocess`) is unchanged.

What differs from the offline path, step by step (docs/live.md measures the differences):

0. Confidence: keypoints below ``min_keypoint_confidence`` are dropped (NaN) as offline; the kept
   ones are *not* confidence-weighted (the offline weighting solves a system over the neighbours
   on both sides).
1. Clock: the same grid as offline, ``start + round(i / rate_hz)``; ``start`` is fixed when the
   hand (thumb tip, index tip and base) and one object (``fill_hidden``; every object otherwise)
   have been seen, as offline. The clock ends with :meth:`~OnlinePreprocessor.flush`.
2. Resample: *linear* interpolation between the real samples on either side (offline: cubic
   splines), slerp for orientations (as offline); gaps longer than ``max_gap_s`` are invalid
   (NaN, ``hand_valid`` / ``object_valid`` False) exactly as offline. A sample at ``t`` is
   emitted once every stream has a real sample at or after ``t``, or has shown a gap longer than
   ``max_gap_s`` around ``t``, or ``max_wait_s`` of newer data (any stream) has arrived since
   ``t`` (a stalled stream: decided with what is there). Emission latency is therefore one hand
   frame period (about 200 ms for a 5 Hz hand-pose estimator) in steady state, and up to
   ``max_wait_s`` while a stream is silent.
   ``fill_hidden``: an object not seen for longer than ``max_gap_s`` is held at its last pose,
   and carried with the TCP (constant offset) once the TCP has come within grasp distance of it
   and passed its closest point (offline fills the whole gap knowing where the object
   reappears); it is marked valid as offline and flagged in ``object_filled``.
3. Filter (``smoother="fixed-lag"``, the default): the offline filter itself (MATLAB
   ``filtfilt`` of the same 4th-order Butterworth, same cut-offs) on a sliding window
   (:class:`FixedLagLowpass`): a sample comes out once ``lookahead_s`` (default 0.3 s, 9
   samples at 30 Hz) of newer samples are there, filtered over ``window_s`` (2 s) before it
   and the lookahead after it. The rows carry the time they describe
   (:attr:`~OnlinePreprocessor.shift_samples` 0) and come out ``lookahead_s`` late
   (:meth:`~OnlinePreprocessor.lag_s`); hand and objects are equally late, so nothing is
   delayed to match. On the shipped recordings the TCP is within 0.7 mm (mean; 3.8 mm at
   worst) of the offline one at 0.3 s (1.6 / 15 mm at 0.2 s, 0.02 / 0.4 mm at 1 s).
   ``smoother="causal"``: the Butterworth run *forward only* (``scipy.signal.sosfilt``
   recursion with kept state, started at steady state on the first sample of each valid run)
   instead of ``filtfilt``. Its group delay at low frequency is ``lag_s``: for order 4,
   ``2.61 / (2 pi fc)`` — 208 ms (6.2 samples at 30 Hz) for the hand at 2 Hz, 42 ms (1.2
   samples) for objects at 10 Hz; its gain at ``fc`` is ``1/sqrt(2)`` where ``filtfilt``'s is
   ``1/2``, and its rows lag their time stamps by the hand's delay (``shift_samples``); with
   ``match_lag`` (default) the object poses are delayed by the difference of the two lags
   (5 samples). Both smoothers run the Euler angles (0.0625 Hz, not used by the features)
   through the causal filter.
4. Hand -> gripper: the same :func:`~lfd.preprocessing.mapping.gripper_frame` and
   :func:`~lfd.preprocessing.grasp.grasp_aperture` per sample; Euler angles unwrapped against
   the previous sample.

Features (:class:`OnlineFeatures`) call the engine's :func:`lfd.features.compute_features` on a
window of three samples around each one, so every formula is the offline one:

- velocities (``tcp_rise_fall``, ``object_velocity``, ``hand_velocity``) are central differences
  as offline, so the row of sample ``i`` is emitted when sample ``i + 1`` arrives
  (``derivative="central"``, one more sample of latency); ``derivative="backward"`` emits at once
  with backward differences (half a sample of delay in the velocities);
- gap filling (offline: linear interpolation across the gap) holds the last valid value, and
  the sample is marked ``valid=False``;
- the ``object_height`` threshold is the resting height known at ``i`` (median height before
  the first motion, on the samples so far; identical to offline once the object has moved);
- the target object (offline: the object of the *next* motion or dwell) is causal: the moving
  object, then the object just released while the hand stays in its proximity zone, else the
  object with the smallest clearance, switched only when another is ``approach_margin`` closer.

On the emitted trajectory (:meth:`OnlinePreprocessor.trajectory`), with the same targets, every
column equals ``compute_features`` of that trajectory, except the ``object_height`` threshold
before the object first moves.
"""

from __future__ import annotations

import bisect
import math
from collections import deque
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from ..demo import INDEX_MCP, INDEX_TIP, THUMB_TIP, Demonstration
from ..errors import DemonstrationError, UsageError
from ..features import FeatureParams, checked_params, feature_rows
from ..trajectory import Trajectory
from .carry import REST_TOLERANCE
from .filters import butter_ba, filtfilt_runs, matlab_padlen
from .grasp import APERTURES, Aperture, grasp_aperture
from .mapping import EULER_SEQ, euler_from_rotation, gripper_frame, rotation_from_euler
from .pipeline import AUTO_CUTOFF_MAX_HZ, CARRY_RADIUS_MARGIN, MIN_KEYPOINT_CONFIDENCE, auto_cutoff

__all__ = [
    "CausalLowpass",
    "FeatureSample",
    "FixedLagLowpass",
    "HandMessage",
    "ObjectMessage",
    "OnlineFeatures",
    "OnlinePreprocessor",
    "OnlineSample",
    "demo_messages",
    "replay",
]

GRIPPER_KEYPOINTS = (THUMB_TIP, INDEX_MCP, INDEX_TIP)
_IDENTITY_Q = np.array([0.0, 0.0, 0.0, 1.0])

Smoother = Literal["fixed-lag", "causal"]
DEFAULT_LOOKAHEAD_S = 0.3
"""Lag of the fixed-lag smoother: samples come out once this much newer data is there."""
DEFAULT_WINDOW_S = 2.0
"""How far back the fixed-lag smoother's window reaches."""


# --- the causal filter -------------------------------------------------------------------
class CausalLowpass:
    """Butterworth low-pass run forward one sample at a time, per column, with kept state.

    The recursion is ``scipy.signal.sosfilt``'s (transposed direct form II, second-order
    sections); a column's state starts at the steady state of its first value of each valid run
    (``sosfilt_zi * x0``: a constant signal passes unchanged) and is dropped when the column
    becomes invalid.

    Parameters
    ----------
    cutoff_hz, fs : float
        Cut-off and sampling rate, Hz (checked as :func:`~lfd.preprocessing.filters.butter_ba`).
    columns : int
        Number of independent signals.
    order : int
        Butterworth order.
    """

    def __init__(self, cutoff_hz: float, fs: float, columns: int, order: int = 4) -> None:
        from scipy.signal import butter, sosfilt_zi

        butter_ba(cutoff_hz, fs, order)  # the offline checks and messages
        self.sos = np.asarray(butter(order, cutoff_hz, btype="low", fs=fs, output="sos"))
        self.cutoff_hz, self.fs, self.order = float(cutoff_hz), float(fs), int(order)
        self._zi = np.asarray(sosfilt_zi(self.sos))[:, :, None]  # (sections, 2, 1)
        self._z = np.zeros((self.sos.shape[0], 2, columns))
        self._active = np.zeros(columns, dtype=bool)

    @property
    def delay_s(self) -> float:
        """Group delay at zero frequency, seconds: per section
        ``(b1 + 2 b2) / sum(b) - (a1 + 2 a2) / sum(a)`` samples."""
        b, a = self.sos[:, :3], self.sos[:, 3:]
        tau = (b[:, 1] + 2 * b[:, 2]) / b.sum(axis=1) - (a[:, 1] + 2 * a[:, 2]) / a.sum(axis=1)
        return float(tau.sum()) / self.fs

    def step(self, x: np.ndarray, valid: np.ndarray) -> np.ndarray:
        """Filter one sample ``x`` (columns,); NaN where ``valid`` is False."""
        x = np.asarray(x, dtype=np.float64)
        valid = np.asarray(valid, dtype=bool)
        start = valid & ~self._active
        if start.any():
            self._z[:, :, start] = self._zi * x[start]
        self._active = valid.copy()
        z = self._z
        if valid.all():  # the common case, without masks
            y = x
            for s, (b0, b1, b2, _, a1, a2) in enumerate(self.sos):
                out = b0 * y + z[s, 0]
                z[s, 0] = b1 * y - a1 * out + z[s, 1]
                z[s, 1] = b2 * y - a2 * out
                y = out
            return np.asarray(y)
        y = np.where(valid, x, 0.0)
        for s, (b0, b1, b2, _, a1, a2) in enumerate(self.sos):
            out = b0 * y + z[s, 0]
            z0 = b1 * y - a1 * out + z[s, 1]
            z1 = b2 * y - a2 * out
            z[s, 0] = np.where(valid, z0, z[s, 0])
            z[s, 1] = np.where(valid, z1, z[s, 1])
            y = out
        return np.where(valid, y, np.nan)


class FixedLagLowpass:
    """The offline zero-phase filter (MATLAB ``filtfilt``, as
    :func:`~lfd.preprocessing.filters.lowpass`) applied to a sliding window: a fixed-lag smoother.

    The value of sample ``i`` is taken from ``filtfilt`` over the window from ``back`` samples
    before it to the newest sample, at least ``lag`` samples after it. Each column's valid run
    around ``i`` is filtered on its own (as offline, runs too short to filter are left as they
    are). Past a few time constants of the filter the window's ends no longer matter: with the
    default lag of 0.3 s (9 samples at 30 Hz) and 2 s back the features are 1.4-4 times closer
    to the offline ones than with a causal Butterworth (docs/live.md).

    Parameters
    ----------
    cutoff_hz, fs : float
        Cut-off and sampling rate, Hz (checked as :func:`~lfd.preprocessing.filters.butter_ba`).
    order : int
        Butterworth order.
    """

    def __init__(self, cutoff_hz: float, fs: float, order: int = 4) -> None:
        self.b, self.a = butter_ba(cutoff_hz, fs, order)
        self.pad = matlab_padlen(self.b, self.a)
        self.cutoff_hz, self.fs, self.order = float(cutoff_hz), float(fs), int(order)

    def window(self, x: np.ndarray, ok: np.ndarray) -> np.ndarray:
        """``filtfilt`` of a window ``x`` (w, columns) along axis 0, each column's runs of
        ``ok`` filtered separately (runs of at most the pad length left unfiltered); NaN where
        not ``ok`` (:func:`~lfd.preprocessing.filters.filtfilt_runs`)."""
        x = np.asarray(x, dtype=np.float64)
        ok = np.asarray(ok, dtype=bool)
        if ok.all() and x.shape[0] > self.pad:  # the common case, in one call
            from scipy.signal import filtfilt

            return np.asarray(filtfilt(self.b, self.a, x, axis=0, padlen=self.pad))
        return filtfilt_runs(x, ok, self.b, self.a)


# --- messages ------------------------------------------------------------------------------
@dataclass(frozen=True)
class HandMessage:
    """One hand keypoint frame: ``keypoints`` (21, 3) metres, ``confidence`` (21,) or None."""

    t_ns: int
    keypoints: np.ndarray
    confidence: np.ndarray | None = None


@dataclass(frozen=True)
class ObjectMessage:
    """One object pose: ``position`` (3,), ``quaternion`` (4,) (x, y, z, w), ``visible``."""

    t_ns: int
    name: str
    position: np.ndarray
    quaternion: np.ndarray
    visible: bool = True


def demo_messages(demo: Demonstration) -> Iterator[HandMessage | ObjectMessage]:
    """A demonstration's hand frames and object poses as messages in timestamp order (ties:
    the hand first, then the objects in ``demo.objects`` order)."""
    keys: list[tuple[int, int, int]] = [(int(t), 0, i) for i, t in enumerate(demo.hand.t_ns)]
    names = list(demo.objects)
    for j, name in enumerate(names):
        keys += [(int(t), j + 1, i) for i, t in enumerate(demo.objects[name].t_ns)]
    keys.sort()
    hand = demo.hand
    for t, src, i in keys:
        if src == 0:
            yield HandMessage(t, hand.keypoints[i], hand.confidence[i])
        else:
            ob = demo.objects[names[src - 1]]
            yield ObjectMessage(
                t, names[src - 1], ob.position[i], ob.quaternion[i], bool(ob.visible[i])
            )


# --- buffered source streams ---------------------------------------------------------------
class _Stream:
    """Recent real samples of one source (hand: 21 keypoint columns, object: 1 pose column)."""

    def __init__(self, columns: int, width: int) -> None:
        self.t: list[int] = []
        self.x: list[np.ndarray] = []  # (columns, width)
        self.ok: list[np.ndarray] = []  # (columns,)
        self.latest: int | None = None
        self.first_ok: int | None = None  # first time the blocking columns were all valid
        self.last_ok: int | None = None
        self.columns, self.width = columns, width
        self._arrays: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None

    def insert(self, t: int, x: np.ndarray, ok: np.ndarray) -> bool:
        """Insert in time order; False for a duplicate timestamp (the first is kept)."""
        i = bisect.bisect_left(self.t, t)
        if i < len(self.t) and self.t[i] == t:
            return False
        self.t.insert(i, t)
        self.x.insert(i, x)
        self.ok.insert(i, ok)
        self._arrays = None
        self.latest = t if self.latest is None else max(self.latest, t)
        return True

    def prune(self, before: int) -> None:
        """Drop samples older than ``before`` (they can only bracket gaps longer than allowed)."""
        i = bisect.bisect_left(self.t, before)
        if i:
            del self.t[:i], self.x[:i], self.ok[:i]
            self._arrays = None

    def bracket(self, t: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Per column: index of the last valid sample <= t and of the first >= t (-1: none),
        and the stacked times and values."""
        if not self.t:
            none = np.full(self.columns, -1)
            return none, none, np.zeros(0, np.int64), np.zeros((0, self.columns, self.width))
        if self._arrays is None:
            self._arrays = (
                np.asarray(self.t, dtype=np.int64),
                np.asarray(self.ok),
                np.asarray(self.x),
            )
        ts, ok, xs = self._arrays
        m = ts.size
        before = ok & (ts <= t)[:, None]
        after = ok & (ts >= t)[:, None]
        prev = np.where(before.any(axis=0), m - 1 - np.argmax(before[::-1], axis=0), -1)
        nxt = np.where(after.any(axis=0), np.argmax(after, axis=0), -1)
        return prev, nxt, ts, xs

    def bracket1(self, t: int) -> tuple[int, int]:
        """:meth:`bracket` of a one-column stream, without arrays: (prev, next), -1 for none."""
        ts, ok = self.t, self.ok
        i = bisect.bisect_left(ts, t)
        nxt = i
        while nxt < len(ts) and not ok[nxt][0]:
            nxt += 1
        prev = i if i < len(ts) and ts[i] == t and ok[i][0] else i - 1
        while prev >= 0 and not ok[prev][0]:
            prev -= 1
        return prev, (nxt if nxt < len(ts) else -1)

    def at1(self, t: int, max_gap: int) -> tuple[np.ndarray, np.ndarray, float] | None:
        """The two bracketing values of a one-column stream and the weight of the second;
        None where ``t`` is not interpolated (outside the data or in a long gap)."""
        p, n = self.bracket1(t)
        if p >= 0 and self.t[p] == t:
            return self.x[p][0], self.x[p][0], 0.0
        if n >= 0 and self.t[n] == t:
            return self.x[n][0], self.x[n][0], 0.0
        if p < 0 or n < 0 or self.t[n] - self.t[p] > max_gap:
            return None
        return self.x[p][0], self.x[n][0], (t - self.t[p]) / (self.t[n] - self.t[p])

    def decided(self, t: int, cols: Sequence[int], max_gap: int, now: int, max_wait: int) -> bool:
        """Whether the columns ``cols`` at time ``t`` no longer depend on data to come.

        Messages of one stream arrive in time order and at most ``max_wait`` after newer
        messages of the others (``now``): a sample is decided when a valid sample at or after
        ``t`` is there, or the stream has shown (or, by the wait bound, must have) a gap longer
        than ``max_gap`` around ``t``, or ``now`` is ``max_wait`` past ``t``. (A stream silent for
        longer than ``max_gap + max_wait`` after a valid sample is decided at once: a late sample
        exactly at ``t`` would have made ``t`` valid, a measure-zero case.)"""
        if now >= t + max_wait:
            return True
        if self.t and self.t[-1] >= t and self.ok[-1][list(cols)].all():
            return True  # the newest sample brackets t
        latest = -(2**62) if self.latest is None else self.latest
        if self.columns == 1:
            p, n = self.bracket1(t)
            if n >= 0 or (p >= 0 and self.t[p] == t):
                return True
            tp = self.t[p] if p >= 0 else -(2**62)
            silent = p >= 0 and tp + max_gap < now - max_wait
            return (latest >= t and latest > tp + max_gap) or silent
        prev, nxt, ts, _ = self.bracket(t)
        for c in cols:
            if nxt[c] >= 0 or (prev[c] >= 0 and ts[prev[c]] == t):
                continue
            tp = ts[prev[c]] if prev[c] >= 0 else -(2**62)
            if latest >= t and latest > tp + max_gap:  # the next valid sample comes too late
                continue
            if prev[c] >= 0 and tp + max_gap < now - max_wait:  # silent for a gap + the wait
                continue
            return False
        return True

    def at(self, t: int, max_gap: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per column the two bracketing values, the weight of the second, and validity."""
        prev, nxt, ts, xs = self.bracket(t)
        if not ts.size:
            nothing = np.zeros(self.columns, dtype=bool)
            return np.full((2, self.columns, self.width), np.nan), np.zeros(self.columns), nothing
        c = np.arange(self.columns)
        has_p, has_n = prev >= 0, nxt >= 0
        tp = np.where(has_p, ts[np.maximum(prev, 0)], 0)
        tn = np.where(has_n, ts[np.maximum(nxt, 0)], 0)
        on_p = has_p & (tp == t)
        on_n = has_n & (tn == t)
        both = has_p & has_n & ((tn - tp) <= max_gap)
        valid = on_p | on_n | both
        xp = xs[np.maximum(prev, 0), c]
        xn = xs[np.maximum(nxt, 0), c]
        span = np.where(both & (tn > tp), tn - tp, 1)
        w = np.where(on_p, 0.0, np.where(on_n, 1.0, (t - tp) / span))
        xp = np.where(on_n[:, None], xn, xp)
        xn = np.where(on_p[:, None], xp, xn)
        return np.stack([xp, xn]), np.where(valid, w, 0.0), valid


def _slerp(q0: np.ndarray, q1: np.ndarray, w: float) -> np.ndarray:
    """Spherical interpolation of unit quaternions (x, y, z, w), shortest arc."""
    q0 = q0 / np.linalg.norm(q0)
    q1 = q1 / np.linalg.norm(q1)
    d = float(q0 @ q1)
    if d < 0:
        q1, d = -q1, -d
    if d > 0.9995:
        q = q0 + w * (q1 - q0)
        return np.asarray(q / np.linalg.norm(q))
    th = math.acos(min(d, 1.0))
    s = math.sin(th)
    return np.asarray((math.sin((1 - w) * th) * q0 + math.sin(w * th) * q1) / s)


# --- output rows ---------------------------------------------------------------------------
@dataclass
class OnlineSample:
    """One sample of the online trajectory (the fields of one :class:`Trajectory` row).

    ``index`` counts samples on the clock from 0; ``t_ns`` is the clock time. ``tcp`` (3,),
    ``rotation`` (3, 3), ``euler`` (3,), ``opening`` and ``keypoints`` (21, 3) are NaN where
    ``hand_valid`` is False; ``object_position`` (k, 3) and ``object_quaternion`` (k, 4) NaN where
    ``object_valid`` (k,) is False; ``object_filled`` (k,) marks poses held or carried through
    a long gap (``fill_hidden``).
    """

    index: int
    t_ns: int
    tcp: np.ndarray
    rotation: np.ndarray
    euler: np.ndarray
    opening: float
    keypoints: np.ndarray
    object_position: np.ndarray
    object_quaternion: np.ndarray
    hand_valid: bool
    object_valid: np.ndarray
    object_filled: np.ndarray


@dataclass
class _Hidden:
    """An object through a long gap: its last pose, and the grasp once the hand has it."""

    position: np.ndarray
    quaternion: np.ndarray
    closest: float = math.inf
    offset: np.ndarray | None = None  # object - TCP at the closest approach
    held: bool = False


_RAW_FIELDS = ("kp", "kp_ok", "pos", "quat", "valid", "filled")


@dataclass
class _Raw:
    """Resampled, filled, not yet filtered rows: keypoints (m, 21, 3) and their validity
    (m, 21), object positions (m, k, 3), quaternions (m, k, 4), validity and filled (m, k)."""

    kp: np.ndarray
    kp_ok: np.ndarray
    pos: np.ndarray
    quat: np.ndarray
    valid: np.ndarray
    filled: np.ndarray

    @classmethod
    def empty(cls, m: int, k: int) -> _Raw:
        return cls(
            np.zeros((m, 21, 3)),
            np.zeros((m, 21), dtype=bool),
            np.zeros((m, k, 3)),
            np.zeros((m, k, 4)),
            np.zeros((m, k), dtype=bool),
            np.zeros((m, k), dtype=bool),
        )

    def fields(self) -> tuple[np.ndarray, ...]:
        return tuple(getattr(self, f) for f in _RAW_FIELDS)


class _History:
    """The newest resampled rows, for the fixed-lag smoother's window."""

    def __init__(self, k: int) -> None:
        self._rows = _Raw.empty(0, k)

    def __len__(self) -> int:
        return int(self._rows.kp.shape[0])

    def extend(self, raw: _Raw) -> None:
        self._rows = _Raw(
            *(
                np.concatenate([a, b])
                for a, b in zip(self._rows.fields(), raw.fields(), strict=True)
            )
        )

    def stack(self, name: str) -> np.ndarray:
        return np.asarray(getattr(self._rows, name))

    def trim(self, keep: int) -> None:
        """Keep the newest ``keep`` rows."""
        if len(self) > keep:
            self._rows = _Raw(*(a[len(self) - keep :] for a in self._rows.fields()))


class OnlinePreprocessor:
    """Causal :func:`~lfd.preprocessing.preprocess`: raw messages in, clock samples out.

    Parameters
    ----------
    object_names : sequence of str
        The objects, in the order of the output arrays.
    object_sizes : array_like, shape (k, 3)
        Their box dimensions, metres.
    side : {"right", "left"}
        The demonstrating hand.
    rate_hz, euler_cutoff_hz, feature_cutoff_hz, object_cutoff_hz, aperture, max_gap_s,
    fill_hidden, filter, min_keypoint_confidence
        As :func:`~lfd.preprocessing.preprocess` (``fill_hidden``: see the module docs).
    hand_rate_hz : float, optional
        The hand-pose estimator's frame rate, for ``feature_cutoff_hz="auto"`` (offline it is
        measured on the whole recording; ``None``: the 6 Hz maximum of ``auto``) and to check
        ``max_wait_s``.
    filter_order : int
        Order of the Butterworth filters (offline: 4, run twice).
    match_lag : bool
        ``smoother="causal"`` only: delay the object poses by the difference of the hand's and
        the objects' filter lag (:meth:`object_delay_samples`), so that features relating the
        hand to an object (proximity, TCP in the object frame, grasp aperture) compare the two
        at the same time. The whole row then lags by the hand's filter delay.
    smoother : {"fixed-lag", "causal"}
        ``fixed-lag``: the offline ``filtfilt`` on a sliding window, each sample out once
        ``lookahead_s`` of newer samples are there (:class:`FixedLagLowpass`); ``causal``: the
        Butterworth forward only (:class:`CausalLowpass`), out at once but with the filter's
        group delay and distortion (module docs).
    lookahead_s, window_s : float
        The fixed-lag smoother's lag (default 0.3 s) and how far back its window reaches
        (default 2 s).
    max_wait_s : float, optional
        Longest wait for a silent stream, in seconds of newer data from the others; ``None``:
        ``max_gap_s`` (then gaps are decided exactly as offline). It must be longer than the
        slowest stream's frame period (the hand's), else that stream's samples become gaps;
        shorter waits lower the latency while a tag is occluded (docs/live.md).

    Attributes
    ----------
    warnings : list of str
        Dropped messages (older than what was already emitted), in order.
    """

    def __init__(
        self,
        object_names: Sequence[str],
        object_sizes: npt.ArrayLike,
        *,
        side: str = "right",
        rate_hz: float = 30.0,
        euler_cutoff_hz: float = 0.0625,
        feature_cutoff_hz: float | Literal["auto"] = 0.625,
        hand_rate_hz: float | None = None,
        object_cutoff_hz: float | None = None,
        aperture: Aperture = "grasp",
        max_gap_s: float = 0.5,
        max_wait_s: float | None = None,
        fill_hidden: bool = True,
        filter: bool = True,
        filter_order: int = 4,
        match_lag: bool = True,
        min_keypoint_confidence: float = MIN_KEYPOINT_CONFIDENCE,
        smoother: Smoother = "fixed-lag",
        lookahead_s: float = DEFAULT_LOOKAHEAD_S,
        window_s: float = DEFAULT_WINDOW_S,
    ) -> None:
        self.object_names = [str(n) for n in object_names]
        k = len(self.object_names)
        if k == 0:
            raise DemonstrationError("demonstration has no objects")
        sizes = np.asarray(object_sizes, dtype=np.float64)
        if sizes.shape != (k, 3) or not np.all(np.isfinite(sizes) & (sizes > 0)):
            raise DemonstrationError(f"object_sizes must be {k} positive (x, y, z) sizes")
        if aperture not in APERTURES:
            raise DemonstrationError(
                f"aperture must be one of {', '.join(APERTURES)}, got {aperture!r}"
            )
        if side not in ("right", "left"):
            raise DemonstrationError(f"hand side must be 'right' or 'left', got {side!r}")
        if not (0.0 <= min_keypoint_confidence <= 1.0):
            raise DemonstrationError(
                f"min_keypoint_confidence must be in [0, 1], got {min_keypoint_confidence!r}"
            )
        if not (rate_hz > 0 and math.isfinite(rate_hz)):
            raise DemonstrationError(f"rate must be positive, got {rate_hz}")
        if max_gap_s < 0 or (max_wait_s is not None and max_wait_s < 0):
            raise UsageError("max_gap_s and max_wait_s must not be negative")
        if hand_rate_hz and (max_wait_s is not None and max_wait_s * hand_rate_hz <= 1.0):
            raise UsageError(
                f"max_wait_s ({max_wait_s} s) must be longer than a hand frame period "
                f"({1.0 / hand_rate_hz:.3f} s), or every hand sample becomes a gap"
            )
        if smoother not in ("fixed-lag", "causal"):
            raise UsageError(f"smoother must be 'fixed-lag' or 'causal', got {smoother!r}")
        if not (0.0 <= lookahead_s <= 10.0 and 0.0 < window_s <= 60.0):
            raise UsageError(
                f"lookahead_s must be in [0, 10] s and window_s in (0, 60] s, got "
                f"{lookahead_s!r} and {window_s!r}"
            )
        if feature_cutoff_hz == "auto":
            hand_fc = auto_cutoff(hand_rate_hz) if hand_rate_hz else AUTO_CUTOFF_MAX_HZ
        else:
            hand_fc = float(feature_cutoff_hz)
        obj_fc = hand_fc if object_cutoff_hz is None else float(object_cutoff_hz)
        self.object_sizes = sizes
        self.side, self.rate_hz, self.aperture = side, float(rate_hz), aperture
        self.fill_hidden, self.filtered = bool(fill_hidden), bool(filter)
        self.min_keypoint_confidence = float(min_keypoint_confidence)
        self.hand_filter_hz, self.object_filter_hz = hand_fc, obj_fc
        self.euler_cutoff_hz = float(euler_cutoff_hz)
        self._period = 1e9 / self.rate_hz
        self._max_gap = round(max_gap_s * 1e9)
        self._max_wait = round((max_gap_s if max_wait_s is None else max_wait_s) * 1e9)
        self._index = {n: j for j, n in enumerate(self.object_names)}
        self._hand = _Stream(21, 3)
        self._objects = [_Stream(1, 7) for _ in range(k)]
        self._now: int | None = None
        self._start: int | None = None
        self._next = 0  # index of the next clock sample to emit
        self._emitted_t: int | None = None
        self.smoother: Smoother = smoother
        self._lag = round(lookahead_s * self.rate_hz)
        self._back = max(1, round(window_s * self.rate_hz))
        self._kp_filter = self._obj_filter = self._euler_filter = None
        self._kp_zp: FixedLagLowpass | None = None
        self._obj_zp: FixedLagLowpass | None = None
        if self.filtered and smoother == "fixed-lag":
            self._kp_zp = FixedLagLowpass(hand_fc, rate_hz, filter_order)
            self._obj_zp = FixedLagLowpass(obj_fc, rate_hz, filter_order)
        elif self.filtered:
            self._kp_filter = CausalLowpass(hand_fc, rate_hz, 63, filter_order)
            self._obj_filter = CausalLowpass(obj_fc, rate_hz, 3 * k, filter_order)
        if self.filtered:
            self._euler_filter = CausalLowpass(euler_cutoff_hz, rate_hz, 3, filter_order)
        self._hist = _History(k)
        self._out_next = 0  # clock index of the next sample the smoother lets out
        self._euler_prev: np.ndarray | None = None
        self._quat_prev: list[np.ndarray | None] = [None] * k
        self._hidden: list[_Hidden | None] = [None] * k
        self._last_pose: list[tuple[np.ndarray, np.ndarray] | None] = [None] * k
        self._radius = np.max(sizes, axis=1) / 2 + CARRY_RADIUS_MARGIN
        self.match_lag = bool(match_lag)
        lag = self.lag_s()
        self._delay = (
            max(0, round((lag["hand"] - lag["objects"]) * self.rate_hz))
            if match_lag and self._kp_zp is None
            else 0
        )
        self._fifo: deque[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = deque(
            maxlen=self._delay + 1
        )
        self.samples: list[OnlineSample] = []
        self.warnings: list[str] = []
        self.dropped = 0

    @classmethod
    def for_demonstration(cls, demo: Demonstration, **options: Any) -> OnlinePreprocessor:
        """A preprocessor for a recording like ``demo`` (its objects, sizes, hand side and hand
        frame rate), with ``options`` as the keyword arguments of the constructor."""
        steps = np.diff(np.unique(demo.hand.t_ns)) * 1e-9
        options.setdefault("hand_rate_hz", 1.0 / float(np.median(steps)) if steps.size else None)
        return cls(
            list(demo.objects),
            np.array([o.size for o in demo.objects.values()], dtype=np.float64).reshape(-1, 3),
            side=demo.hand.side,
            **options,
        )

    # --- lag ---------------------------------------------------------------------------
    @property
    def object_delay_samples(self) -> int:
        """Samples the object poses are delayed by to match the hand's lag (``match_lag``)."""
        return self._delay

    @property
    def shift_samples(self) -> int:
        """Samples by which the emitted rows' values lag behind their time stamps: the causal
        filters' delay (``smoother="causal"``), 0 for the fixed-lag smoother, whose rows carry
        the time they describe (they come out :meth:`lag_s` later)."""
        if self._kp_zp is not None:
            return 0
        return round(self.lag_s()["hand"] * self.rate_hz)

    def lag_s(self) -> dict[str, float]:
        """Delay (s) of the filter of each signal: the fixed-lag smoother's lag (the rows come
        out that much after the newest sample), or the causal filter's group delay: ``hand``
        (keypoints, TCP, opening), ``objects`` (positions; with ``match_lag`` they are further
        delayed by :attr:`object_delay_samples`), ``euler``; 0 without filtering."""
        out = {"hand": 0.0, "objects": 0.0, "euler": 0.0}
        if self._kp_zp is not None:
            out["hand"] = out["objects"] = self._lag / self.rate_hz
        for key, f in (
            ("hand", self._kp_filter),
            ("objects", self._obj_filter),
            ("euler", self._euler_filter),
        ):
            if f is not None:
                out[key] = f.delay_s
        return out

    # --- input -------------------------------------------------------------------------
    def push(self, message: HandMessage | ObjectMessage) -> list[OnlineSample]:
        """Add one message (:meth:`add_hand` or :meth:`add_object`)."""
        if isinstance(message, HandMessage):
            return self.add_hand(message.t_ns, message.keypoints, message.confidence)
        return self.add_object(
            message.name, message.t_ns, message.position, message.quaternion, message.visible
        )

    def add_hand(
        self, t_ns: int, keypoints: npt.ArrayLike, confidence: npt.ArrayLike | None = None
    ) -> list[OnlineSample]:
        """Add one hand frame (keypoints (21, 3), NaN where unseen; confidence (21,)); returns
        the clock samples it determined."""
        t = int(t_ns)
        kp = np.array(keypoints, dtype=np.float64).reshape(21, 3)
        ok = np.asarray(np.isfinite(kp).all(axis=1), dtype=bool)
        if confidence is not None and self.min_keypoint_confidence > 0:
            conf = np.asarray(confidence, dtype=np.float64).reshape(21)
            ok &= conf >= self.min_keypoint_confidence
        if not self._accept("hand", t):
            return []
        if self._hand.insert(t, kp, ok):
            if ok[list(GRIPPER_KEYPOINTS)].all():
                self._seen(self._hand, t)
        return self._advance()

    def add_object(
        self,
        name: str,
        t_ns: int,
        position: npt.ArrayLike,
        quaternion: npt.ArrayLike,
        visible: bool = True,
    ) -> list[OnlineSample]:
        """Add one object pose; returns the clock samples it determined."""
        if name not in self._index:
            raise DemonstrationError(f"unknown object {name!r}; known: {self.object_names}")
        t = int(t_ns)
        p = np.asarray(position, dtype=np.float64).reshape(3)
        q = np.asarray(quaternion, dtype=np.float64).reshape(4)
        ok = bool(visible) and bool(np.isfinite(p).all() and np.isfinite(q).all())
        ok = ok and float(np.linalg.norm(q)) > 0
        if not self._accept(name, t):
            return []
        stream = self._objects[self._index[name]]
        if stream.insert(t, np.concatenate([p, q])[None, :], np.array([ok])) and ok:
            self._seen(stream, t)
        return self._advance()

    def flush(self) -> list[OnlineSample]:
        """End of the recording: emit the samples up to the last time the hand and the objects
        were seen together (offline's end of the clock)."""
        if self._start is None:
            return []
        h_last = self._hand.last_ok
        obj_last = [s.last_ok for s in self._objects if s.last_ok is not None]
        if h_last is None or not obj_last:
            return []
        end = min(h_last, max(obj_last) if self.fill_hidden else min(obj_last))
        self._now = 2**62
        return self._advance(end)

    def _accept(self, what: str, t: int) -> bool:
        if self._emitted_t is not None and t <= self._emitted_t:
            self.dropped += 1
            self.warnings.append(
                f"{what} message at {t} ns is not newer than the last emitted sample "
                f"({self._emitted_t} ns); dropped"
            )
            return False
        self._now = t if self._now is None else max(self._now, t)
        return True

    def _seen(self, stream: _Stream, t: int) -> None:
        stream.first_ok = t if stream.first_ok is None else min(stream.first_ok, t)
        stream.last_ok = t if stream.last_ok is None else max(stream.last_ok, t)
        if self._start is not None:
            return
        firsts = [s.first_ok for s in self._objects]
        seen = [f for f in firsts if f is not None]
        h = self._hand.first_ok
        if h is None or not seen or (not self.fill_hidden and len(seen) < len(firsts)):
            return
        self._start = max(h, min(seen) if self.fill_hidden else max(seen))

    # --- emission ----------------------------------------------------------------------
    def _clock(self, i: int) -> int:
        assert self._start is not None
        return self._start + round(i * self._period)

    def _advance(self, end: int | None = None) -> list[OnlineSample]:
        if self._now is None:
            return []
        if self._start is None:  # the clock starts after the hand's first frame, >= now - wait
            floor = self._now - self._max_wait - self._max_gap - 1
            self._hand.prune(floor)
            for s in self._objects:
                s.prune(floor)
            return []
        times: list[int] = []
        while True:
            t = self._clock(self._next + len(times))
            if end is not None and t > end:
                break
            if end is None and not self._decided(t, self._now):
                break
            times.append(t)
        drain = end is not None
        if not times and not drain:
            return []
        out = self._emit(times, drain=drain)
        if not times:
            self.samples.extend(out)
            return out
        self._emitted_t = times[-1]
        self._next += len(times)
        floor = times[-1] - self._max_gap - 1
        self._hand.prune(floor)
        for s in self._objects:
            s.prune(floor)
        self.samples.extend(out)
        return out

    def _decided(self, t: int, now: int) -> bool:
        g, w = self._max_gap, self._max_wait
        if not self._hand.decided(t, GRIPPER_KEYPOINTS, g, now, w):
            return False
        return all(s.decided(t, (0,), g, now, w) for s in self._objects)

    def _emit(self, times: list[int], *, drain: bool = False) -> list[OnlineSample]:
        """The samples at ``times`` (decided), in a batch: resampled and filled per sample in
        order, smoothed (:meth:`_smooth`), then mapped over the batch. With the fixed-lag
        smoother the samples that come out are the ones ``lag`` samples older (all of the rest
        with ``drain``)."""
        raw = self._resample(times)
        kp, kp_ok, pos, quat, valid, filled, first = self._smooth(raw, drain=drain)
        m = kp.shape[0]
        if m == 0:
            return []
        grip = list(GRIPPER_KEYPOINTS)
        tcp, rot_raw, opening = gripper_frame(kp, side=self.side)
        hand_valid = kp_ok[:, grip].all(axis=1) & np.isfinite(rot_raw).all(axis=(1, 2))
        euler = euler_from_rotation(rot_raw)
        for i in range(m):
            euler[i] = self._unwrap(euler[i], bool(hand_valid[i]))
            if self._euler_filter is not None:
                euler[i] = self._euler_filter.step(euler[i], np.full(3, hand_valid[i]))
        rotation = rotation_from_euler(euler)
        tcp[~hand_valid] = np.nan
        if self.aperture == "grasp":
            opening = grasp_aperture(
                kp, pos.transpose(1, 0, 2), quat.transpose(1, 0, 2), self.object_sizes
            )
        opening[~hand_valid] = np.nan
        euler[~hand_valid] = np.nan
        rotation[~hand_valid] = np.nan
        return [
            OnlineSample(
                first + i,
                self._clock(first + i),
                tcp[i],
                rotation[i],
                euler[i],
                float(opening[i]),
                kp[i],
                pos[i],
                quat[i],
                bool(hand_valid[i]),
                valid[i],
                filled[i],
            )
            for i in range(m)
        ]

    def _resample(self, times: list[int]) -> _Raw:
        """Keypoints and object poses at ``times``, interpolated and filled (not filtered)."""
        k, m = len(self.object_names), len(times)
        grip = list(GRIPPER_KEYPOINTS)
        kp = np.empty((m, 21, 3))
        kp_ok = np.empty((m, 21), dtype=bool)
        raw_tcp = np.empty((m, 3))
        for i, t in enumerate(times):
            (x0, x1), w, ok = self._hand.at(t, self._max_gap)
            kp[i] = np.where(ok[:, None], x0 + w[:, None] * (x1 - x0), np.nan)
            kp_ok[i] = ok
            raw_tcp[i] = 0.5 * (kp[i, INDEX_TIP] + kp[i, THUMB_TIP])  # unfiltered: no lag
        # objects: fill what was hidden (carried with the unfiltered TCP, in step with the
        # object's own unfiltered samples)
        raw_ok = np.asarray(kp_ok[:, grip].all(axis=1), dtype=bool)
        pos = np.full((m, k, 3), np.nan)
        quat = np.full((m, k, 4), np.nan)
        valid = np.zeros((m, k), dtype=bool)
        filled = np.zeros((m, k), dtype=bool)
        for i, t in enumerate(times):
            for j, s in enumerate(self._objects):
                got = s.at1(t, self._max_gap)
                if got is not None:
                    a, b, wj = got
                    pos[i, j] = a[:3] + wj * (b[:3] - a[:3])
                    quat[i, j] = _slerp(a[3:], b[3:], wj)
                    valid[i, j] = True
                    self._hidden[j] = None
                    self._last_pose[j] = (pos[i, j].copy(), quat[i, j].copy())
                elif self.fill_hidden and self._last_pose[j] is not None:
                    pos[i, j], quat[i, j] = self._fill(j, raw_tcp[i], bool(raw_ok[i]))
                    valid[i, j] = filled[i, j] = True
                prev = self._quat_prev[j]
                if valid[i, j] and prev is not None and float(quat[i, j] @ prev) < 0:
                    quat[i, j] = -quat[i, j]
                self._quat_prev[j] = quat[i, j].copy() if valid[i, j] else None
        return _Raw(kp, kp_ok, pos, quat, valid, filled)

    def _smooth(
        self, raw: _Raw, *, drain: bool
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]:
        """Filter the resampled rows: keypoints, object positions, and the clock index of the
        first row that comes out."""
        if self._kp_zp is not None:
            return self._smooth_window(raw, drain=drain)
        k, m = len(self.object_names), raw.kp.shape[0]
        kp, pos, quat = raw.kp.copy(), raw.pos.copy(), raw.quat.copy()
        kp_ok, valid, filled = raw.kp_ok.copy(), raw.valid.copy(), raw.filled.copy()
        first = self._next
        for i in range(m):
            if self._kp_filter is not None:
                kp[i] = self._kp_filter.step(kp[i].reshape(63), np.repeat(kp_ok[i], 3)).reshape(
                    21, 3
                )
            if self._obj_filter is not None:
                pos[i] = self._obj_filter.step(
                    pos[i].reshape(3 * k), np.repeat(valid[i], 3)
                ).reshape(k, 3)
            if self._delay:  # objects as late as the hand (match_lag)
                self._fifo.append(
                    (pos[i].copy(), quat[i].copy(), valid[i].copy(), filled[i].copy())
                )
                pos[i], quat[i], valid[i], filled[i] = self._fifo[0]
        return kp, kp_ok, pos, quat, valid, filled, first

    def _smooth_window(
        self, raw: _Raw, *, drain: bool
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]:
        """:meth:`_smooth` by the fixed-lag smoother: the rows ``lag`` samples behind the
        newest come out, filtered over the window of kept rows."""
        assert self._kp_zp is not None and self._obj_zp is not None
        h = self._hist
        h.extend(raw)
        newest = self._next + raw.kp.shape[0] - 1  # clock index of the newest row
        last = newest if drain else newest - self._lag
        first = self._out_next
        if last < first:
            e = _Raw.empty(0, len(self.object_names))
            return e.kp, e.kp_ok, e.pos, e.quat, e.valid, e.filled, first
        base = newest - len(h) + 1  # clock index of the oldest kept row
        k = len(self.object_names)
        kp_ok, kp_lin = h.stack("kp_ok"), h.stack("kp")
        valid, pos_raw = h.stack("valid"), h.stack("pos")
        m = last - first + 1
        kp = np.empty((m, 21, 3))
        pos = np.empty((m, k, 3))
        for i, o in enumerate(range(first, last + 1)):
            # each row from the same window, whatever the batches: [o - back, o + lag]
            lo, hi = max(o - self._back, base) - base, min(o + self._lag, newest) - base + 1
            at = o - base - lo
            ok = np.repeat(kp_ok[lo:hi], 3, axis=1)
            kp[i] = self._kp_zp.window(kp_lin[lo:hi].reshape(-1, 63), ok)[at].reshape(21, 3)
            pos[i] = self._obj_zp.window(
                pos_raw[lo:hi].reshape(-1, 3 * k), np.repeat(valid[lo:hi], 3, axis=1)
            )[at].reshape(k, 3)
        sel = slice(first - base, last - base + 1)
        quat, filled = h.stack("quat"), h.stack("filled")
        out = (kp, kp_ok[sel], pos, quat[sel], valid[sel], filled[sel], first)
        self._out_next = last + 1
        h.trim(self._back + (newest - last))  # the rows later windows reach back to
        return out

    def _unwrap(self, e: np.ndarray, valid: bool) -> np.ndarray:
        if not valid:
            self._euler_prev = None
            return np.full(3, np.nan)
        if self._euler_prev is not None:
            e = self._euler_prev + np.mod(e - self._euler_prev + np.pi, 2 * np.pi) - np.pi
        self._euler_prev = e.copy()
        return e

    def _fill(self, j: int, tcp: np.ndarray, hand_valid: bool) -> tuple[np.ndarray, np.ndarray]:
        """The pose of object ``j`` through a long gap: held, then carried with the TCP."""
        h = self._hidden[j]
        if h is None:
            last = self._last_pose[j]
            assert last is not None
            h = self._hidden[j] = _Hidden(last[0].copy(), last[1].copy())
        if hand_valid:
            if h.held and h.offset is not None:
                return tcp + h.offset, h.quaternion
            d = float(np.linalg.norm(tcp - h.position))
            if d <= self._radius[j] and d < h.closest - REST_TOLERANCE * 0.1:
                h.closest, h.offset = d, h.position - tcp
            elif h.offset is not None:  # past the closest approach: the hand has it
                h.held = True
                return tcp + h.offset, h.quaternion
        return h.position, h.quaternion

    # --- the result so far -------------------------------------------------------------
    def trajectory(self) -> Trajectory:
        """The samples emitted so far as a :class:`Trajectory` (``meta["online"]`` True)."""
        s = self.samples
        k = len(self.object_names)
        n = len(s)

        def stack(get: Any, shape: tuple[int, ...]) -> np.ndarray:
            return np.array([get(x) for x in s], dtype=np.float64).reshape((n, *shape))

        return Trajectory(
            t_ns=np.array([x.t_ns for x in s], dtype=np.int64),
            tcp=stack(lambda x: x.tcp, (3,)),
            rotation=stack(lambda x: x.rotation, (3, 3)),
            euler=stack(lambda x: x.euler, (3,)),
            opening=stack(lambda x: x.opening, ()),
            keypoints=stack(lambda x: x.keypoints, (21, 3)),
            object_names=list(self.object_names),
            object_position=stack(lambda x: x.object_position, (k, 3)).transpose(1, 0, 2),
            object_quaternion=stack(lambda x: x.object_quaternion, (k, 4)).transpose(1, 0, 2),
            object_size=self.object_sizes.copy(),
            hand_valid=np.array([x.hand_valid for x in s], dtype=bool),
            object_valid=np.array([x.object_valid for x in s], dtype=bool).reshape(n, k).T,
            meta={
                "online": True,
                "rate_hz": self.rate_hz,
                "hand_filter_hz": self.hand_filter_hz,
                "object_filter_hz": self.object_filter_hz,
                "euler_cutoff_hz": self.euler_cutoff_hz,
                "aperture": self.aperture,
                "filtered": self.filtered,
                "euler_seq": EULER_SEQ,
                "lag_s": self.lag_s(),
                "dropped": self.dropped,
            },
        )


# --- features ------------------------------------------------------------------------------
@dataclass
class FeatureSample:
    """The feature rows of one clock sample.

    Attributes
    ----------
    index, t_ns : int
        The clock sample.
    values, thresholds : ndarray, shape (10,)
        The hand's row of ``compute_features(traj)`` (:data:`lfd.features.FEATURE_NAMES`), for
        the causal ``target``.
    target : int
        Target object (index into the object names).
    object_values, object_thresholds : ndarray, shape (k, 10)
        Row ``o``: the row of ``compute_features(traj, target=o)``.
    tcp_z : float
        TCP height (gap-filled like the features).
    object_position : ndarray, shape (k, 3)
        Object centres (gap-filled).
    valid : bool
        The hand and every object were tracked (not held through a gap) at this sample; values
        are NaN (and ``valid`` False) before the hand and every object have been seen once.
    sample : OnlineSample
        The preprocessed sample the row was computed from.
    """

    index: int
    t_ns: int
    values: np.ndarray
    thresholds: np.ndarray
    target: int
    object_values: np.ndarray
    object_thresholds: np.ndarray
    tcp_z: float
    object_position: np.ndarray
    valid: bool
    sample: OnlineSample


@dataclass
class _Row:
    """A gap-filled sample the features are computed from."""

    sample: OnlineSample
    tcp: np.ndarray | None
    opening: float
    position: np.ndarray | None
    quaternion: np.ndarray | None
    valid: bool

    @property
    def ready(self) -> bool:
        return self.tcp is not None and self.position is not None


@dataclass
class _Rest:
    """Resting height of one object as known so far (median height before its first motion)."""

    min_len: int
    v_th: float
    heights: list[float] = field(default_factory=list)  # sorted, outside a fast run
    run: list[float] = field(default_factory=list)  # the current fast run (not yet motion)
    first_z: float | None = None
    frozen: float | None = None
    n: int = 0

    def update(self, z: float, speed: float) -> float:
        if self.first_z is None:
            self.first_z = z
        self.n += 1
        if self.frozen is None:
            if speed > self.v_th:
                self.run.append(z)
                if len(self.run) >= self.min_len:  # the first motion: the rest is over
                    self.frozen = _median(self.heights) if self.heights else self.first_z
            else:
                for r in self.run:
                    bisect.insort(self.heights, r)
                self.run.clear()
                bisect.insort(self.heights, z)
        if self.frozen is not None:
            return self.frozen
        if self.run:
            return float(np.median(np.concatenate([self.heights, self.run])))
        return _median(self.heights)


def _median(x: list[float]) -> float:
    h = len(x) // 2
    return x[h] if len(x) % 2 else 0.5 * (x[h - 1] + x[h])


class OnlineFeatures:
    """Table I features of :class:`OnlineSample` rows, one sample at a time.

    Parameters
    ----------
    object_names : sequence of str
    object_sizes : array_like, shape (k, 3)
    rate_hz : float
        The clock rate of the samples.
    params : FeatureParams, mapping, JSON string, optional
        As :func:`lfd.features.compute_features`.
    derivative : {"central", "backward"}
        ``central``: the offline central differences, each row emitted one sample later;
        ``backward``: emitted at once, velocities by backward differences.
    """

    def __init__(
        self,
        object_names: Sequence[str],
        object_sizes: npt.ArrayLike,
        rate_hz: float,
        *,
        params: FeatureParams | dict[str, Any] | str | None = None,
        derivative: Literal["central", "backward"] = "central",
    ) -> None:
        if derivative not in ("central", "backward"):
            raise UsageError(f"derivative must be 'central' or 'backward', got {derivative!r}")
        self.object_names = list(object_names)
        self.k = len(self.object_names)
        self.sizes = np.ascontiguousarray(object_sizes, dtype=np.float64).reshape(self.k, 3)
        if isinstance(params, FeatureParams):
            p = params
        elif params is None:
            p = FeatureParams()
        elif isinstance(params, str):
            import json

            p = FeatureParams.from_dict(json.loads(params))
        else:
            p = FeatureParams.from_dict(params)
        self.params = p
        self._json = checked_params(p)
        self.dt = 1.0 / float(rate_hz)
        self.derivative = derivative
        self.min_len = max(round(p.min_motion_s / self.dt), 1)
        self._rows: list[_Row] = []  # the last (up to) three rows
        self._tcp: np.ndarray | None = None
        self._opening = math.nan
        self._pos: np.ndarray | None = None
        self._quat: np.ndarray | None = None
        self._rest = [_Rest(self.min_len, p.v_th) for _ in range(self.k)]
        self._fast = np.zeros(self.k, dtype=np.int64)  # consecutive samples above v_th
        self._target: int | None = None
        self._releasing: int | None = None
        self._targets = [np.full(3, o, dtype=np.int64) for o in range(self.k)]
        self.emitted: list[FeatureSample] = []

    @property
    def lag_samples(self) -> int:
        """Samples between a preprocessed sample's arrival and its feature row (1 central)."""
        return 1 if self.derivative == "central" else 0

    def push(self, sample: OnlineSample) -> list[FeatureSample]:
        """Add one preprocessed sample; returns the feature rows it determined."""
        self._rows.append(self._fill(sample))
        self._rows = self._rows[-3:]
        if self.derivative == "backward":
            return self._out(len(self._rows) - 1)
        if len(self._rows) < 2:
            return []
        return self._out(len(self._rows) - 2)

    def flush(self) -> list[FeatureSample]:
        """End of the samples: the last row (central differences)."""
        if self.derivative == "central" and self._rows:
            row = self._out(len(self._rows) - 1)
            self._rows = []
            return row
        return []

    def _fill(self, s: OnlineSample) -> _Row:
        """Hold the last valid values through gaps (offline: interpolated across)."""
        if s.hand_valid:
            self._tcp, self._opening = np.asarray(s.tcp, dtype=np.float64), float(s.opening)
        ov = np.asarray(s.object_valid, dtype=bool)
        if ov.any():
            if self._pos is None or self._quat is None:
                self._pos = np.full((self.k, 3), np.nan)
                self._quat = np.full((self.k, 4), np.nan)
            self._pos = np.where(ov[:, None], s.object_position, self._pos)
            self._quat = np.where(ov[:, None], s.object_quaternion, self._quat)
        pos = self._pos if self._pos is not None and np.isfinite(self._pos).all() else None
        quat = self._quat if pos is not None else None
        return _Row(s, self._tcp, self._opening, pos, quat, bool(s.hand_valid and ov.all()))

    def _out(self, i: int) -> list[FeatureSample]:
        rows = self._rows
        row = rows[i]
        window = [r for r in rows[max(i - 1, 0) : i + 2] if r.ready]
        if not row.ready or len(window) < 1:
            fs = self._nan(row)
        else:
            if len(window) == 1:
                window = [window[0], window[0]]
            at = next(j for j, r in enumerate(window) if r is row)
            fs = self._compute(window, at, row)
        self.emitted.append(fs)
        return [fs]

    def _nan(self, row: _Row) -> FeatureSample:
        s = row.sample
        nan10 = np.full(10, np.nan)
        return FeatureSample(
            s.index,
            s.t_ns,
            nan10,
            nan10.copy(),
            -1,
            np.full((self.k, 10), np.nan),
            np.full((self.k, 10), np.nan),
            math.nan,
            np.full((self.k, 3), np.nan),
            False,
            s,
        )

    def _compute(self, window: list[_Row], at: int, row: _Row) -> FeatureSample:
        w = len(window)
        tcp = np.array([r.tcp for r in window], dtype=np.float64)
        opening = np.array([r.opening for r in window], dtype=np.float64)
        pos = np.ascontiguousarray(
            np.stack([np.asarray(r.position) for r in window], axis=1), dtype=np.float64
        )
        quat = np.ascontiguousarray(
            np.stack([np.asarray(r.quaternion) for r in window], axis=1), dtype=np.float64
        )
        vals = np.empty((self.k, 10))
        thr = np.empty((self.k, 10))
        for o in range(self.k):
            v, th, _ = feature_rows(
                tcp, opening, pos, quat, self.sizes, self.dt, self._targets[o][:w], self._json
            )
            vals[o], thr[o] = v[at], th[at]
        g = self.params.gamma
        for o in range(self.k):
            thr[o, 4] = self._rest[o].update(float(vals[o, 4]), float(vals[o, 8])) + g
        target = self._label(vals, thr)
        assert row.tcp is not None and row.position is not None
        return FeatureSample(
            row.sample.index,
            row.sample.t_ns,
            vals[target].copy(),
            thr[target].copy(),
            target,
            vals,
            thr,
            float(row.tcp[2]),
            row.position.copy(),
            row.valid,
            row.sample,
        )

    def _label(self, vals: np.ndarray, thr: np.ndarray) -> int:
        """The causal target (module docs): moving, releasing, else the nearest (hysteresis)."""
        p = self.params
        fast = vals[:, 8] > p.v_th
        self._fast = np.where(fast, self._fast + 1, 0)
        clearance = vals[:, 2] - 0.5 * thr[:, 3]  # |TCP - p| - d / 2 (threshold 3 is d)
        moving = np.flatnonzero(self._fast >= self.min_len)
        if moving.size:
            j = int(moving[np.argmin(clearance[moving])])
            self._releasing = self._target = j
            return j
        if self._releasing is not None and clearance[self._releasing] <= p.gamma:
            self._target = self._releasing
            return self._releasing
        self._releasing = None
        nearest = int(np.argmin(clearance))
        cur = self._target
        if cur is None or clearance[nearest] < clearance[cur] - p.approach_margin:
            cur = nearest
        self._target = cur
        return cur

    def arrays(self) -> dict[str, np.ndarray]:
        """The rows emitted so far stacked: ``values``, ``thresholds`` (n, 10), ``target`` (n,),
        ``object_values``, ``object_thresholds`` (k, n, 10), ``t_ns``, ``index``, ``valid``."""
        e = self.emitted
        n = len(e)
        return {
            "t_ns": np.array([f.t_ns for f in e], dtype=np.int64),
            "index": np.array([f.index for f in e], dtype=np.int64),
            "values": np.array([f.values for f in e]).reshape(n, 10),
            "thresholds": np.array([f.thresholds for f in e]).reshape(n, 10),
            "target": np.array([f.target for f in e], dtype=np.int64),
            "object_values": np.array([f.object_values for f in e])
            .reshape(n, self.k, 10)
            .transpose(1, 0, 2),
            "object_thresholds": np.array([f.object_thresholds for f in e])
            .reshape(n, self.k, 10)
            .transpose(1, 0, 2),
            "valid": np.array([f.valid for f in e], dtype=bool),
        }


def replay(
    demo: Demonstration,
    *,
    preprocessing: dict[str, Any] | None = None,
    feature_params: FeatureParams | dict[str, Any] | str | None = None,
    derivative: Literal["central", "backward"] = "central",
    preprocessor: OnlinePreprocessor | None = None,
    features: OnlineFeatures | None = None,
) -> Iterator[FeatureSample]:
    """Feed a recording's messages in timestamp order through an :class:`OnlinePreprocessor`
    (``preprocessing``: its keyword arguments) and :class:`OnlineFeatures`; yields every feature
    row as soon as it is determined, the last ones after the end of the recording. Pass your own
    ``preprocessor`` / ``features`` to read their reports (warnings, lag) afterwards."""
    pre = preprocessor or OnlinePreprocessor.for_demonstration(demo, **(preprocessing or {}))
    feats = features or OnlineFeatures(
        pre.object_names, pre.object_sizes, pre.rate_hz, params=feature_params,
        derivative=derivative,
    )  # fmt: skip
    for msg in demo_messages(demo):
        for s in pre.push(msg):
            yield from feats.push(s)
    for s in pre.flush():
        yield from feats.push(s)
    yield from feats.flush()
