"""Log the Table I features as time series, each beside its stage-1 threshold."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from ..errors import DemonstrationError
from .paths import FEATURE_TARGET, feature_path
from .recording import get_recording, import_rerun
from .timeline import time_columns, time_origin

VALUE_COLOR = (60, 160, 255)
THRESHOLD_COLOR = (235, 90, 70)


class FeaturesLike(Protocol):
    """What :func:`log_features` reads from a features result (``lfd.features.Features``)."""

    @property
    def names(self) -> Sequence[str]: ...
    @property
    def values(self) -> Any: ...
    @property
    def thresholds(self) -> Any: ...
    @property
    def t_ns(self) -> Any: ...


def _changes(labels: np.ndarray) -> np.ndarray:
    """Indices where a label sequence (n,) changes, including 0."""
    if labels.size == 0:
        return np.zeros(0, dtype=np.int64)
    return np.flatnonzero(np.r_[True, labels[1:] != labels[:-1]])


def log_feature_arrays(
    names: Sequence[str],
    values: npt.ArrayLike,
    thresholds: npt.ArrayLike | None,
    t_ns: npt.ArrayLike,
    *,
    target: npt.ArrayLike | None = None,
    object_names: Sequence[str] | None = None,
    frame: npt.ArrayLike | None = None,
    symmetric: Sequence[str] | None = None,
    recording: Any = None,
    origin_ns: int | None = None,
) -> None:
    """Log feature columns and thresholds as series under ``/features/<name>``.

    Parameters
    ----------
    names : sequence of str, length f
        Feature (column) names.
    values : array, shape (n, f)
        Feature values per sample.
    thresholds : array, shape (n, f) or (f,), optional
        Stage-1 thresholds (per sample or constant), drawn as ``/features/<name>/threshold``.
    t_ns : array, shape (n,)
        Absolute sample times, int64 nanoseconds.
    target : array, shape (n,), optional
        Target object index per sample, shown as a state lane ``/features/target``.
    object_names : sequence of str, optional
        Names for the target indices (default ``object <k>``).
    frame : array, shape (n,), optional
        Sample indices for the ``frame`` timeline (default ``0..n-1``).
    symmetric : sequence of str, optional
        Features whose threshold is the half-width of a ``±`` band (also drawn negated);
        default: names starting with ``tcp_in_object``.
    recording : rerun.RecordingStream, optional
    origin_ns : int, optional
        See :func:`lfd.viz.log_demonstration`.
    """
    rr = import_rerun()
    names = list(names)
    vals = np.asarray(values, dtype=np.float64)
    n = vals.shape[0] if vals.ndim == 2 else -1
    if vals.ndim != 2 or vals.shape[1] != len(names):
        raise DemonstrationError(
            f"feature values must have shape (n, {len(names)}), got {vals.shape}"
        )
    t = np.asarray(t_ns)
    if t.shape != (n,) or (t.size and not np.issubdtype(t.dtype, np.integer)):
        raise DemonstrationError(
            f"feature t_ns must be integer nanoseconds of shape ({n},), got {t.dtype} {t.shape}"
        )
    thr = None
    if thresholds is not None:
        thr = np.asarray(thresholds, dtype=np.float64)
        if thr.shape == (len(names),):
            thr = np.broadcast_to(thr, vals.shape)
        if thr.shape != vals.shape:
            raise DemonstrationError(
                f"thresholds must have shape {vals.shape} or ({len(names)},), got {thr.shape}"
            )
    frames = np.arange(n) if frame is None else np.asarray(frame, dtype=np.int64)
    if frames.shape != (n,):
        raise DemonstrationError(f"frame must have shape ({n},), got {frames.shape}")
    rec = get_recording(recording)
    if n == 0:
        return
    origin = time_origin(rec, first_ns=int(t[0]), origin_ns=origin_ns)
    sym = (
        {m for m in names if m.startswith("tcp_in_object")} if symmetric is None else set(symmetric)
    )

    for j, name in enumerate(names):
        base = feature_path(name)
        series: list[tuple[str, np.ndarray, str, tuple[int, int, int], float]] = [
            ("value", vals[:, j], name, VALUE_COLOR, 2.0)
        ]
        if thr is not None:
            series.append(("threshold", thr[:, j], "threshold", THRESHOLD_COLOR, 1.0))
            if name in sym:
                series.append(("threshold_neg", -thr[:, j], "-threshold", THRESHOLD_COLOR, 1.0))
        for leaf, y, label, color, width in series:
            ok = np.flatnonzero(np.isfinite(y))
            rec.log(
                f"{base}/{leaf}",
                rr.SeriesLines(names=label, colors=[color], widths=width),
                static=True,
            )
            if ok.size:
                rec.send_columns(
                    f"{base}/{leaf}",
                    indexes=time_columns(t[ok], origin, frame=frames[ok]),
                    columns=rr.Scalars.columns(scalars=y[ok]),
                )

    if target is not None:
        tgt = np.asarray(target)
        if tgt.shape != (n,):
            raise DemonstrationError(f"target must have shape ({n},), got {tgt.shape}")
        labels = [
            object_names[int(k)]
            if object_names is not None and 0 <= int(k) < len(object_names)
            else f"object {int(k)}"
            for k in tgt
        ]
        arr = np.asarray(labels, dtype=object)
        ch = _changes(arr)
        rec.send_columns(
            FEATURE_TARGET,
            indexes=time_columns(t[ch], origin, frame=frames[ch]),
            columns=rr.StateChange.columns(state=[f"target: {s}" for s in arr[ch]]),
        )


def log_features(
    features: FeaturesLike,
    *,
    object_names: Sequence[str] | None = None,
    recording: Any = None,
    origin_ns: int | None = None,
) -> None:
    """Log a features result (``names``, ``values``, ``thresholds``, ``t_ns``, ``target``).

    See :func:`log_feature_arrays` for the layout; ``object_names`` defaults to the result's
    own ``object_names`` attribute when it has one.
    """
    log_feature_arrays(
        features.names,
        features.values,
        getattr(features, "thresholds", None),
        features.t_ns,
        target=getattr(features, "target", None),
        object_names=object_names or getattr(features, "object_names", None),
        recording=recording,
        origin_ns=origin_ns,
    )
