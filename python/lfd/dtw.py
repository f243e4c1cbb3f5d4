"""Dynamic time warping and [0, 1] normalisation (Rust engine ``lfd._hmmseg``).

Sequences are arrays whose **rows are time steps**: shape ``(n, d)``, or ``(n,)`` for a
one-dimensional series. The distance is ``sqrt`` of the smallest sum of squared Euclidean
differences along a warping path — the value of ``dtaidistance.dtw.distance_fast`` and
``tslearn.metrics.dtw``.

``band=r`` is a Sakoe-Chiba band of radius ``r``: only ``|i - j| <= r`` is allowed (tslearn's
``sakoe_chiba_radius=r``; for equal lengths dtaidistance's ``window=r + 1``). The band is not
widened for different lengths, so ``|n - m| > r`` is an :class:`~lfd.errors.InvalidParameterError`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from . import _hmmseg
from .errors import InvalidParameterError, ShapeMismatchError

__all__ = ["align_to_reference", "dtw", "dtw_distance", "normalize"]


def _as_seq(x: npt.ArrayLike, name: str) -> np.ndarray:
    """``x`` as a C-contiguous float64 array of shape (n, d)."""
    arr = np.asarray(x, dtype=np.float64)
    if arr.ndim == 1:
        arr = arr[:, None]
    if arr.ndim != 2:
        raise ShapeMismatchError(f"{name} must have shape (n,) or (n, d), got {arr.shape}")
    return np.ascontiguousarray(arr)


def _check_band(band: int | None) -> int | None:
    if band is None:
        return None
    if isinstance(band, bool) or not isinstance(band, int | np.integer) or band < 0:
        raise InvalidParameterError(f"band must be a non-negative integer or None, got {band!r}")
    return int(band)


def dtw(a: npt.ArrayLike, b: npt.ArrayLike, *, band: int | None = None) -> tuple[float, np.ndarray]:
    """DTW distance and optimal warping path.

    Parameters
    ----------
    a : array_like, shape (n, d) or (n,)
    b : array_like, shape (m, d) or (m,)
    band : int, optional
        Sakoe-Chiba radius ``r`` (``|i - j| <= r``); ``None`` for no band.

    Returns
    -------
    distance : float
        ``sqrt`` of the summed squared differences along the path.
    path : ndarray of int64, shape (L, 2)
        Index pairs ``(i, j)`` from ``(0, 0)`` to ``(n - 1, m - 1)``, both non-decreasing.

    Raises
    ------
    EmptySequenceError, ShapeMismatchError, NonFiniteError, InvalidParameterError
    """
    distance, path = _hmmseg.dtw(_as_seq(a, "a"), _as_seq(b, "b"), _check_band(band))
    return distance, path


def dtw_distance(a: npt.ArrayLike, b: npt.ArrayLike, *, band: int | None = None) -> float:
    """DTW distance only (``O(m)`` memory, faster than :func:`dtw`); arguments as :func:`dtw`."""
    return _hmmseg.dtw_distance(_as_seq(a, "a"), _as_seq(b, "b"), _check_band(band))


def align_to_reference(
    reference: npt.ArrayLike, seqs: Sequence[npt.ArrayLike], *, band: int | None = None
) -> list[np.ndarray]:
    """Warp every sequence onto the time axis of ``reference``.

    Output row ``i`` of each sequence is the mean of its samples that DTW matches to reference
    index ``i``; use it to average several demonstrations into a template.

    Parameters
    ----------
    reference : array_like, shape (n, d) or (n,)
    seqs : sequence of array_like, each shape (m_s, d) or (m_s,)
    band : int, optional
        Sakoe-Chiba radius, see :func:`dtw`.

    Returns
    -------
    list of ndarray, each shape (n, d) — or (n,) if ``reference`` is one-dimensional.
    """
    ref = np.asarray(reference, dtype=np.float64)
    out = _hmmseg.align_to_reference(
        _as_seq(ref, "reference"),
        [_as_seq(s, f"seqs[{k}]") for k, s in enumerate(seqs)],
        _check_band(band),
    )
    return [o[:, 0] for o in out] if ref.ndim == 1 else out


def normalize(
    x: npt.ArrayLike, lo: npt.ArrayLike | None = None, hi: npt.ArrayLike | None = None
) -> np.ndarray:
    """Map each column linearly onto [0, 1].

    Without bounds each column uses its own min and max; with ``lo`` and ``hi`` (scalars or one
    value per column, e.g. a template's range) ``lo -> 0`` and ``hi -> 1`` and values outside
    map outside [0, 1]. A constant column (``hi == lo``) becomes 0.5.

    Parameters
    ----------
    x : array_like, shape (n, d) or (n,)
    lo, hi : float or array_like of shape (d,), optional
        Give both or neither.

    Returns
    -------
    ndarray, same shape as ``x``.
    """
    arr = np.asarray(x, dtype=np.float64)
    seq = _as_seq(arr, "x")
    if (lo is None) != (hi is None):
        raise InvalidParameterError("give both lo and hi, or neither")
    if lo is None or hi is None:
        out = _hmmseg.minmax(seq)
    else:
        d = seq.shape[1]
        try:
            lo_a = np.broadcast_to(np.asarray(lo, dtype=np.float64), (d,)).copy()
            hi_a = np.broadcast_to(np.asarray(hi, dtype=np.float64), (d,)).copy()
        except ValueError as err:
            raise ShapeMismatchError(f"lo and hi must be scalars or have {d} entries") from err
        out = _hmmseg.minmax_with(seq, lo_a, hi_a)
    return out.reshape(arr.shape)
