"""The eight features of Table I and target-object labelling (Rust engine ``lfd._hmmseg``).

:func:`compute_features` turns a preprocessed :class:`~lfd.trajectory.Trajectory` into an
``(n, 10)`` matrix with the columns :data:`FEATURE_NAMES` (Table I's *TCP position in object
frame* takes three columns) and the per-sample thresholds of Table I. Each sample's features
refer to its *target object*, chosen by :func:`label_targets` unless given.

With ``i`` the target, ``d_i`` its size (:attr:`FeatureParams.size_measure`), ``p_i`` its
centre and ``R_i`` its rotation:

=====================  =========================================  =================================
column                 value                                      threshold
=====================  =========================================  =================================
fingertip_distance     ``|I - T|`` (gripper opening)              ``d_i + gamma``
tcp_rise_fall          ``d TCP_z / dt`` (central differences)     ``0``
object_proximity       ``|TCP - p_i|``                            ``d_i / 2 + gamma``
object_distance        ``min_{j != i} |p_i - p_j|``               ``d_i``
object_height          ``p_i . e_z``                              resting height of ``i`` + gamma
tcp_in_object_{x,y,z}  ``R_i^T (TCP - p_i)``                      ``+-(size_i[axis] / 2 + gamma)``
object_velocity        ``|d p_i / dt|``                           ``v_th``
hand_velocity          ``|d TCP / dt|``                           ``v_th``
=====================  =========================================  =================================

The resting height is the median height of the object before it first moves. ``z`` is measured
from the table (the world frame's ``z = 0``); all values are invariant to moving the scene
horizontally and turning it about the vertical axis. With a single object ``object_distance``
is :attr:`FeatureParams.lone_object_distance`.

Features need NaN-free input: the preprocessing marks tracking gaps (``hand_valid``,
``object_valid``), and features are computed only on valid samples — crop the trajectory to a
valid span (see :func:`valid_mask`) before calling.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import asdict, dataclass, fields
from typing import Any

import numpy as np
import numpy.typing as npt

from . import _hmmseg
from ._hmmseg import SizeMeasure
from .errors import DemonstrationError, InvalidParameterError, ShapeMismatchError
from .trajectory import Trajectory

__all__ = [
    "FEATURE_GROUPS",
    "FEATURE_NAMES",
    "FeatureParams",
    "Features",
    "checked_params",
    "compute_features",
    "feature_rows",
    "label_targets",
    "valid_mask",
]

FEATURE_NAMES: tuple[str, ...] = _hmmseg.FEATURE_NAMES
"""Column names of :attr:`Features.values` and :attr:`Features.thresholds`, in order (defined
in the engine)."""

FEATURE_GROUPS: dict[str, tuple[str, ...]] = {
    name: FEATURE_NAMES[start:end] for name, start, end in _hmmseg.FEATURE_GROUPS
}
"""The eight features of Table I and their columns (one HMM per feature; defined in the
engine, ``lfd._hmmseg.FEATURE_GROUPS``)."""


@dataclass(frozen=True)
class FeatureParams:
    """Parameters of the features and of target labelling (mirrors the Rust ``FeatureParams``).

    Attributes
    ----------
    gamma : float
        The small offset ``gamma`` of Table I, metres.
    v_th : float
        Velocity threshold of Table I, m/s; also the speed above which an object counts as
        moving when labelling targets. 0.05 m/s is above filtered tracking noise and well
        below a human reach (0.3-1 m/s).
    size_measure : {"max_horizontal", "min_horizontal", "max"}
        Which box dimension is ``d_i``: the largest horizontal extent (default, a hand opened
        wider can enclose the object from any side), the narrowest grasp width, or the
        largest extent.
    min_motion_s : float
        Object motions shorter than this (seconds) are ignored as noise.
    approach_margin : float
        Hysteresis (metres) of the approaches (minima of the hand's clearance from the nearest
        object) used in target labelling.
    approach_radius : float
        The hand *dwells* near an object (e.g. locate) where its clearance ``|TCP - p| - d / 2``
        from the nearest object is at most this (metres) ...
    dwell_speed : float
        ... and it is slower than this (m/s). Fast passes near other objects on the way to the
        target are not dwells.
    lone_object_distance : float
        ``object_distance`` of a scene with a single object, metres.
    """

    gamma: float = 0.02
    v_th: float = 0.05
    size_measure: SizeMeasure = "max_horizontal"
    min_motion_s: float = 0.1
    approach_margin: float = 0.05
    approach_radius: float = 0.15
    dwell_speed: float = 0.1
    lone_object_distance: float = 1.0

    def to_dict(self) -> dict[str, Any]:
        """The parameters as a plain dict (JSON-ready)."""
        return asdict(self)

    def to_json(self) -> str:
        """The parameters as JSON, the form the engine reads."""
        return json.dumps(self.to_dict())

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> FeatureParams:
        """Build from a mapping; missing keys take defaults, unknown keys are an error."""
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise InvalidParameterError(
                f"unknown feature parameters {unknown}; known: {sorted(known)}"
            )
        return cls(**dict(data))


def _params_json(params: FeatureParams | Mapping[str, Any] | str | None) -> str | None:
    """Parameters as validated JSON for the engine (``None`` = defaults)."""
    if params is None:
        return None
    if isinstance(params, str):
        text = params
    elif isinstance(params, FeatureParams):
        text = params.to_json()
    else:
        text = FeatureParams.from_dict(params).to_json()
    return _hmmseg.check_feature_params(text)


@dataclass
class Features:
    """Feature time series of a demonstration.

    Attributes
    ----------
    names : tuple of str
        Column names, :data:`FEATURE_NAMES`.
    values : ndarray, shape (n, 10)
        Feature values.
    thresholds : ndarray, shape (n, 10)
        Table I thresholds per sample (for ``tcp_in_object_*`` the half-width of the band).
    target : ndarray of int64, shape (n,)
        Target object index of each sample (index into ``Trajectory.object_names``).
    t_ns : ndarray of int64, shape (n,)
        Timestamps of the samples.
    """

    names: tuple[str, ...]
    values: np.ndarray
    thresholds: np.ndarray
    target: np.ndarray
    t_ns: np.ndarray

    def __len__(self) -> int:
        return int(self.values.shape[0])

    def column(self, name: str) -> np.ndarray:
        """Values of one column, shape (n,)."""
        return self.values[:, self._index(name)]

    def threshold(self, name: str) -> np.ndarray:
        """Thresholds of one column, shape (n,)."""
        return self.thresholds[:, self._index(name)]

    def group(self, feature: str) -> np.ndarray:
        """Columns of one Table I feature (see :data:`FEATURE_GROUPS`), shape (n, c)."""
        if feature not in FEATURE_GROUPS:
            raise KeyError(f"unknown feature {feature!r}; known: {list(FEATURE_GROUPS)}")
        return self.values[:, [self._index(c) for c in FEATURE_GROUPS[feature]]]

    def _index(self, name: str) -> int:
        try:
            return self.names.index(name)
        except ValueError:
            raise KeyError(f"unknown feature column {name!r}; known: {list(self.names)}") from None


def valid_mask(traj: Trajectory) -> np.ndarray:
    """Samples where the hand and every object are tracked, bool array of shape (n,)."""
    mask = np.asarray(traj.hand_valid, dtype=bool).copy()
    obj = np.asarray(traj.object_valid, dtype=bool)
    if obj.size:
        mask &= obj.all(axis=0)
    return mask


def _dt(t_ns: np.ndarray) -> float:
    """Uniform sample period in seconds, checked."""
    t = np.asarray(t_ns, dtype=np.int64)
    if t.ndim != 1 or t.shape[0] < 2:
        raise DemonstrationError(f"features need at least 2 timestamps, got shape {t.shape}")
    steps = np.diff(t)
    if np.any(steps <= 0):
        raise DemonstrationError("timestamps t_ns must be strictly increasing")
    dt = float(t[-1] - t[0]) / (t.shape[0] - 1)
    if np.max(np.abs(steps - dt)) > 0.01 * dt:
        raise DemonstrationError("features need a uniform clock: resample the trajectory first")
    return dt * 1e-9


def _arrays(traj: Trajectory) -> dict[str, np.ndarray]:
    """The trajectory's arrays the engine reads, float64 and shape-checked."""
    n = len(traj)
    out = {
        "tcp": np.asarray(traj.tcp, dtype=np.float64),
        "opening": np.asarray(traj.opening, dtype=np.float64),
        "object_position": np.asarray(traj.object_position, dtype=np.float64),
        "object_quaternion": np.asarray(traj.object_quaternion, dtype=np.float64),
        "object_size": np.asarray(traj.object_size, dtype=np.float64),
    }
    k = out["object_size"].shape[0] if out["object_size"].ndim == 2 else -1
    expected = {
        "tcp": (n, 3),
        "opening": (n,),
        "object_position": (k, n, 3),
        "object_quaternion": (k, n, 4),
        "object_size": (k, 3),
    }
    for name, shape in expected.items():
        if out[name].shape != shape:
            raise ShapeMismatchError(
                f"trajectory.{name} has shape {out[name].shape}, expected {shape} "
                f"(n = {n} samples, k = {max(k, 0)} objects)"
            )
    mask = valid_mask(traj)
    if not mask.all():
        bad = int(np.argmin(mask))
        raise DemonstrationError(
            f"sample {bad} is inside a tracking gap (hand_valid/object_valid is False): features "
            "are computed only on valid samples; crop the trajectory with valid_mask() first"
        )
    return out


def compute_features(
    traj: Trajectory,
    *,
    target: int | npt.ArrayLike | None = None,
    params: FeatureParams | Mapping[str, Any] | str | None = None,
) -> Features:
    """Compute the Table I features of a trajectory.

    Parameters
    ----------
    traj : Trajectory
        Preprocessed demonstration on a uniform clock, NaN-free (cropped to valid samples).
    target : int or array_like of int, shape (n,), optional
        Target object of every sample (an int for all samples); ``None`` labels them with
        :func:`label_targets`.
    params : FeatureParams, mapping, JSON string, optional
        Feature parameters; ``None`` for the defaults.

    Returns
    -------
    Features
        ``values`` and ``thresholds`` of shape (n, 10), ``target`` of shape (n,).

    Raises
    ------
    DemonstrationError
        Non-uniform or too few timestamps, samples inside tracking gaps.
    ShapeMismatchError, NonFiniteError, EmptySequenceError, InvalidParameterError
        From the engine (bad shapes, NaN with the array and index, no objects, bad target
        index or parameters).
    """
    dt = _dt(traj.t_ns)
    arrays = _arrays(traj)
    n = len(traj)
    tgt: np.ndarray | None = None
    if target is not None:
        tgt = np.asarray(target)
        if tgt.ndim == 0:
            tgt = np.full(n, int(tgt), dtype=np.int64)
        if not np.issubdtype(tgt.dtype, np.integer):
            raise InvalidParameterError(f"target must be integer object indices, got {tgt.dtype}")
        if tgt.shape != (n,):
            raise ShapeMismatchError(f"target has shape {tgt.shape}, expected ({n},)")
        tgt = np.ascontiguousarray(tgt, dtype=np.int64)
    values, thresholds, labels = feature_rows(
        arrays["tcp"],
        arrays["opening"],
        arrays["object_position"],
        arrays["object_quaternion"],
        arrays["object_size"],
        dt,
        tgt,
        checked_params(params),
    )
    return Features(
        names=FEATURE_NAMES,
        values=values,
        thresholds=thresholds,
        target=labels,
        t_ns=np.asarray(traj.t_ns, dtype=np.int64).copy(),
    )


def checked_params(params: FeatureParams | Mapping[str, Any] | str | None) -> str | None:
    """Feature parameters as the engine's validated JSON (``None``: the defaults), to pass to
    :func:`feature_rows` many times."""
    return _params_json(params)


def feature_rows(
    tcp: np.ndarray,
    opening: np.ndarray,
    object_position: np.ndarray,
    object_quaternion: np.ndarray,
    object_size: np.ndarray,
    dt: float,
    target: np.ndarray | None,
    params_json: str | None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The engine's Table I computation on raw, checked float64 arrays — the core of
    :func:`compute_features`, for callers that compute features many times.

    ``tcp`` (n, 3), ``opening`` (n,), ``object_position`` (k, n, 3), ``object_quaternion``
    (k, n, 4), ``object_size`` (k, 3), ``target`` int64 (n,) or None, ``params_json`` from
    :func:`checked_params`. Returns ``(values, thresholds, target)``.
    """
    return _hmmseg.compute_features(
        tcp, opening, object_position, object_quaternion, object_size, dt, target, params_json
    )


def label_targets(
    traj: Trajectory, params: FeatureParams | Mapping[str, Any] | str | None = None
) -> np.ndarray:
    """Label every sample with its target object (paper Sec. III-B.3).

    The target of a sample is, by the first rule that applies:

    1. the object moving at that time (speed above ``v_th`` for at least ``min_motion_s``; if
       several move, the one nearest the hand);
    2. the object whose motion just ended, while the hand stays within its proximity zone
       (``|TCP - p| <= d / 2 + gamma``: the release after a place);
    3. the object of the next event: an object starting to move, or a *dwell* — the hand
       slower than ``dwell_speed`` with a clearance ``|TCP - p| - d / 2`` of at most
       ``approach_radius`` from the nearest object (e.g. locate);
    4. after the last event, the object nearest the hand at the next approach (minimum of the
       clearance, with hysteresis ``approach_margin``), and after the last approach that
       approach's object.

    Parameters
    ----------
    traj : Trajectory
        Preprocessed, NaN-free demonstration on a uniform clock.
    params : FeatureParams, mapping, JSON string, optional

    Returns
    -------
    ndarray of int64, shape (n,)
        Object indices into ``traj.object_names``.
    """
    dt = _dt(traj.t_ns)
    arrays = _arrays(traj)
    return _hmmseg.label_targets(
        arrays["tcp"],
        arrays["object_position"],
        arrays["object_size"],
        dt,
        _params_json(params),
    )
