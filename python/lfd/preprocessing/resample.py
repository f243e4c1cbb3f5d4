"""Resampling irregular, gappy streams onto one clock (cubic splines, slerp for orientations).

Samples that are NaN (unobserved keypoints, invisible markers) are ignored; a target time is
interpolated when the surrounding real samples are at most ``max_gap_s`` apart, else it is NaN
and marked invalid. Nothing is extrapolated beyond a stream's first and last real sample.

Samples can carry weights in (0, 1] (a hand-pose estimator's per-keypoint confidence):
:func:`weighted_nodes` then pulls each sample towards its neighbours in proportion to
``1 - weight`` before the spline is fitted; weight 1 keeps a sample exactly, and all-ones weights
give the unweighted result bit for bit.

The splines, the tridiagonal solve and the slerp are the engine's (``lfd._hmmseg``), the same
numbers as scipy's ``CubicSpline``, ``solve_banded`` and ``Slerp``: no scipy import.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from .. import _hmmseg, rotations
from ..errors import DemonstrationError

__all__ = [
    "clock",
    "find_gaps",
    "gap_mask",
    "resample_positions",
    "resample_quaternions",
    "weighted_nodes",
]


def clock(start_ns: int, end_ns: int, rate_hz: float) -> np.ndarray:
    """Regular timestamps from ``start_ns`` to at most ``end_ns`` at ``rate_hz``, int64 ns."""
    if not (rate_hz > 0 and np.isfinite(rate_hz)):
        raise DemonstrationError(f"rate must be positive, got {rate_hz}")
    if end_ns < start_ns:
        raise DemonstrationError("the hand and object streams do not overlap in time")
    period = 1e9 / rate_hz
    n = int(np.floor((end_ns - start_ns) / period + 1e-9)) + 1
    return start_ns + np.round(np.arange(n) * period).astype(np.int64)


def gap_mask(t_src: np.ndarray, t_dst: np.ndarray, max_gap_s: float) -> np.ndarray:
    """True where ``t_dst`` lies within the span of ``t_src`` and not inside a long gap.

    Parameters
    ----------
    t_src : array, shape (m,)
        Sorted times (any unit consistent with ``t_dst``, here seconds) of real samples.
    t_dst : array, shape (n,)
        Target times.
    max_gap_s : float
        Longest interval between real samples that is still interpolated.
    """
    if t_src.size == 0:
        return np.zeros(t_dst.shape, dtype=bool)
    inside = (t_dst >= t_src[0]) & (t_dst <= t_src[-1])
    i = np.clip(np.searchsorted(t_src, t_dst, side="right"), 1, max(t_src.size - 1, 1))
    if t_src.size == 1:
        return inside
    gap = t_src[i] - t_src[i - 1]
    on_sample = (t_dst == t_src[i - 1]) | (t_dst == t_src[i])
    return inside & ((gap <= max_gap_s) | on_sample)


def find_gaps(t_ns: np.ndarray, valid: np.ndarray, max_gap_s: float) -> list[tuple[int, int]]:
    """``(last_valid_ns, next_valid_ns)`` of every interval longer than ``max_gap_s`` without
    a valid sample, from sorted timestamps and a validity mask of the source stream."""
    t = t_ns[np.asarray(valid, dtype=bool)]
    if t.size < 2:
        return []
    d = np.diff(t)
    idx = np.flatnonzero(d > max_gap_s * 1e9)
    return [(int(t[k]), int(t[k + 1])) for k in idx]


def weighted_nodes(t_s: np.ndarray, x: np.ndarray, w: np.ndarray, max_gap_s: float) -> np.ndarray:
    """Sample values adjusted by their weights: the nodes a spline is then fitted through.

    Solves ``y_i = w_i x_i + (1 - w_i) yhat_i`` for all samples at once, where ``yhat_i`` is
    the linear interpolation at ``t_i`` of the adjusted neighbours ``y_(i-1)``, ``y_(i+1)`` (the
    one neighbour at an end or next to a gap longer than ``max_gap_s``; a sample without
    neighbours is kept). A sample of weight 1 is kept exactly; an isolated sample of weight
    ``w`` between weight-1 neighbours becomes ``w x_i + (1 - w) yhat_i``; a run of low-weight
    samples is bridged by its better neighbours. The system is strictly diagonally dominant
    for weights in (0, 1], so it always has one solution.

    Parameters
    ----------
    t_s : array, shape (m,)
        Strictly increasing times, seconds.
    x : array, shape (m, c)
        Finite values.
    w : array, shape (m,)
        Weights in (0, 1].
    max_gap_s : float
        Samples further apart do not pull on each other.
    """
    m = t_s.size
    if m < 2 or np.all(w == 1.0):
        return x

    step = np.diff(t_s)
    near = step <= max_gap_s  # near[i]: samples i and i+1 pull on each other
    has_left = np.concatenate([[False], near])
    has_right = np.concatenate([near, [False]])
    left = np.concatenate([[np.inf], step])
    right = np.concatenate([step, [np.inf]])
    both = has_left & has_right
    alpha = np.where(both, right / np.where(both, left + right, 1.0), has_left.astype(float))
    beta = np.where(both, 1.0 - alpha, has_right.astype(float))
    upper = -(1.0 - w[:-1]) * beta[:-1]  # row i, column i + 1
    lower = -(1.0 - w[1:]) * alpha[1:]  # row i + 1, column i
    rhs = np.ascontiguousarray(w[:, None] * x, dtype=np.float64)
    return _hmmseg.solve_tridiagonal(lower, np.ones(m), upper, rhs)


def resample_positions(
    t_src_s: npt.ArrayLike,
    x: npt.ArrayLike,
    t_dst_s: npt.ArrayLike,
    *,
    max_gap_s: float,
    weights: npt.ArrayLike | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Cubic-spline resampling with gaps, each column on its own finite samples.

    Parameters
    ----------
    t_src_s : array, shape (m,)
        Strictly increasing source times, seconds.
    x : array, shape (m, ...)
        Values, NaN where not observed.
    t_dst_s : array, shape (n,)
        Target times, seconds.
    max_gap_s : float
        Longer gaps between finite samples are left NaN.
    weights : array, optional
        Weights in (0, 1] of the finite samples, broadcastable to ``x`` (e.g. shape (m, 21, 1)
        for keypoints): the spline goes through :func:`weighted_nodes` instead of the samples.
        ``None`` or all ones: plain interpolation.

    Returns
    -------
    y : array, shape (n, ...)
        Resampled values, NaN outside the data or in long gaps.
    valid : array, shape (n, ...)
        Where ``y`` is an interpolation of real data.
    """
    ts = np.asarray(t_src_s, dtype=np.float64)
    td = np.asarray(t_dst_s, dtype=np.float64)
    arr = np.asarray(x, dtype=np.float64)
    if arr.shape[0] != ts.shape[0]:
        raise DemonstrationError(f"{arr.shape[0]} samples but {ts.shape[0]} timestamps")
    if ts.size > 1 and not np.all(np.diff(ts) > 0):
        raise DemonstrationError("source timestamps must be strictly increasing")
    m = arr.shape[0]
    flat = np.ascontiguousarray(arr.reshape(m, int(np.prod(arr.shape[1:]))))
    finite = np.isfinite(flat)
    wcols = None
    if weights is not None:
        w = np.asarray(weights, dtype=np.float64)
        try:
            wfull = np.broadcast_to(w, arr.shape)
        except ValueError:
            raise DemonstrationError(
                f"weights of shape {np.shape(weights)} do not fit values of shape {arr.shape}"
            ) from None
        if arr.ndim >= 2 and w.shape == (*arr.shape[:-1], 1):
            # one weight per row of the last axis (a keypoint's x, y, z): passed as it is
            wcols = np.ascontiguousarray(w.reshape(m, -1))
            seen = finite.reshape(m, wcols.shape[1], -1).any(axis=2)
        else:
            wcols = np.ascontiguousarray(wfull).reshape(flat.shape)
            seen = finite
        wk = wcols[seen]
        if not np.all((wk > 0) & (wk <= 1)):
            raise DemonstrationError("weights of observed samples must be in (0, 1]")
    # each column on its own finite samples (the engine: gaps, weighted nodes, not-a-knot
    # cubic splines as scipy's CubicSpline)
    out, valid = _hmmseg.resample_columns(ts, flat, wcols, td, float(max_gap_s))
    return out.reshape((td.size, *arr.shape[1:])), valid.reshape((td.size, *arr.shape[1:]))


def resample_quaternions(
    t_src_s: npt.ArrayLike,
    quat: npt.ArrayLike,
    t_dst_s: npt.ArrayLike,
    *,
    max_gap_s: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Slerp resampling of orientations, signs made continuous over time.

    Parameters
    ----------
    t_src_s : array, shape (m,)
        Strictly increasing source times, seconds.
    quat : array, shape (m, 4)
        Quaternions (x, y, z, w), NaN where not observed.
    t_dst_s : array, shape (n,)
        Target times, seconds.
    max_gap_s : float
        Longer gaps are left NaN.

    Returns
    -------
    q : array, shape (n, 4)
        Unit quaternions with ``q[i] . q[i-1] >= 0`` within each valid run; NaN where invalid.
    valid : array, shape (n,)
    """
    ts = np.asarray(t_src_s, dtype=np.float64)
    td = np.asarray(t_dst_s, dtype=np.float64)
    q = np.asarray(quat, dtype=np.float64)
    if q.shape != (ts.size, 4):
        raise DemonstrationError(f"quaternions must have shape ({ts.size}, 4), got {q.shape}")
    keep = np.isfinite(q).all(axis=1) & (np.linalg.norm(np.nan_to_num(q), axis=1) > 0)
    tk = ts[keep]
    ok = gap_mask(tk, td, max_gap_s)
    out = np.full((td.size, 4), np.nan)
    if tk.size == 0 or not ok.any():
        return out, ok
    if tk.size == 1:
        out[ok] = rotations.normalize(q[keep][0])
    else:
        out[ok] = rotations.slerp(tk, q[keep], td[ok])
    return rotations.make_continuous(out), ok
