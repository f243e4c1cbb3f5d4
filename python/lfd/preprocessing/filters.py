"""Zero-phase Butterworth low-pass filtering, identical to MATLAB's ``filtfilt``.

MATLAB pads with an odd extension of ``3 * (max(len(a), len(b)) - 1)`` samples (12 for a 4th
order filter); scipy's default is 15, which changes the ends by up to a few per cent, so the pad
length is always passed explicitly. Signals containing NaN (tracking gaps) are filtered per run
of finite samples; runs too short to filter are returned unchanged and reported.

The design and the filter are the engine's (``lfd._hmmseg.butter_lowpass`` and ``filtfilt``),
bit for bit scipy's ``butter(order, fc, fs=fs)`` and ``filtfilt(b, a, x, axis=0,
padlen=...)``: no scipy import.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from .. import _hmmseg
from ..errors import DemonstrationError

__all__ = [
    "MIN_CUTOFF_HZ",
    "butter_ba",
    "filtfilt_runs",
    "finite_runs",
    "lowpass",
    "matlab_padlen",
    "unwrap_runs",
]


MIN_CUTOFF_HZ = 0.01
"""Smallest low-pass cut-off: a period of 100 s, longer than any skill (the filter's design is
singular long before 1e-300 Hz: about 1e-14 of the sampling rate)."""


def butter_ba(cutoff_hz: float, fs: float, order: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """Coefficients ``(b, a)`` of a Butterworth low-pass, as MATLAB's ``butter(order, fc/(fs/2))``."""
    if not (fs > 0 and np.isfinite(fs)):
        raise DemonstrationError(f"sampling rate must be positive, got {fs}")
    if not (MIN_CUTOFF_HZ <= cutoff_hz < fs / 2):
        raise DemonstrationError(
            f"cut-off {cutoff_hz} Hz must be between {MIN_CUTOFF_HZ} Hz and the Nyquist "
            f"frequency {fs / 2} Hz"
        )
    return _hmmseg.butter_lowpass(order, float(cutoff_hz), float(fs))


def matlab_padlen(b: np.ndarray, a: np.ndarray) -> int:
    """MATLAB's ``filtfilt`` pad length, ``3 * (max(len(a), len(b)) - 1)``."""
    return 3 * (max(len(a), len(b)) - 1)


def finite_runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """Half-open ``(start, stop)`` index ranges of the runs of True in a 1-D boolean mask."""
    m = np.concatenate([[False], np.asarray(mask, dtype=bool), [False]])
    edges = np.flatnonzero(np.diff(m.astype(np.int8)))
    return [(int(s), int(e)) for s, e in zip(edges[::2], edges[1::2], strict=True)]


def lowpass(
    x: npt.ArrayLike,
    cutoff_hz: float,
    fs: float,
    *,
    order: int = 4,
    report: list[tuple[int, int]] | None = None,
) -> np.ndarray:
    """Zero-phase low-pass along axis 0, MATLAB ``filtfilt(butter(order, fc/(fs/2)), x)``.

    Parameters
    ----------
    x : array, shape (n, ...)
        Signal sampled at ``fs``; each trailing column is filtered independently.
    cutoff_hz : float
        Cut-off frequency (the gain there is 0.5 after the two passes).
    fs : float
        Sampling rate, Hz.
    order : int
        Butterworth order (4 in the paper).
    report : list, optional
        If given, ``(start, stop)`` of every finite run too short to filter (left unfiltered)
        is appended.

    Returns
    -------
    array, shape (n, ...)
        The filtered signal; NaN stays NaN. Runs of finite samples between NaN gaps are filtered
        separately.

    Raises
    ------
    DemonstrationError
        If the signal has no more samples than the pad length (12 for order 4).
    """
    b, a = butter_ba(cutoff_hz, fs, order)
    pad = matlab_padlen(b, a)
    arr = np.asarray(x, dtype=np.float64)
    if arr.ndim == 0:
        raise DemonstrationError("cannot filter a scalar")
    n = arr.shape[0]
    if n <= pad:
        raise DemonstrationError(
            f"signal of {n} samples is too short to filter (needs more than {pad} samples, "
            f"{pad / fs:.2f} s at {fs} Hz)"
        )
    flat = np.ascontiguousarray(arr.reshape(n, -1))
    finite = np.isfinite(flat)
    if finite.all():
        return _hmmseg.filtfilt(b, a, flat, pad).reshape(arr.shape)
    return filtfilt_runs(flat, finite, b, a, report=report).reshape(arr.shape)


def filtfilt_runs(
    x: np.ndarray,
    ok: np.ndarray,
    b: np.ndarray,
    a: np.ndarray,
    *,
    report: list[tuple[int, int]] | None = None,
) -> np.ndarray:
    """MATLAB ``filtfilt`` of ``x`` (n, columns) along axis 0, each column's runs of ``ok``
    filtered on their own (columns with the same runs together); a run of at most the pad
    length is left unfiltered (and its ``(start, stop)`` appended to ``report``); NaN where not
    ``ok``. What :func:`lowpass` does to a signal with gaps."""
    pad = matlab_padlen(b, a)
    out, short = _hmmseg.filtfilt_runs(
        np.asarray(b, dtype=np.float64),
        np.asarray(a, dtype=np.float64),
        np.ascontiguousarray(x, dtype=np.float64),
        np.ascontiguousarray(ok, dtype=bool),
        pad,
    )
    if report is not None:
        report.extend(run for run in short if run not in report)
    return out


def unwrap_runs(angles: npt.ArrayLike) -> np.ndarray:
    """``np.unwrap`` along axis 0, separately in each run of finite samples, per column.

    Parameters
    ----------
    angles : array, shape (n, ...)
        Angles in radians, NaN in gaps.
    """
    arr = np.asarray(angles, dtype=np.float64)
    flat = arr.reshape(arr.shape[0], -1).copy()
    for j in range(flat.shape[1]):
        for start, stop in finite_runs(np.isfinite(flat[:, j])):
            flat[start:stop, j] = np.unwrap(flat[start:stop, j])
    return flat.reshape(arr.shape)
