"""Tracking gaps: interpolate what the hand and object trackers missed, before the features.

The first step of :func:`lfd.segment` after preprocessing, and of template training; it sits
below both (:mod:`lfd.segmentation.pipeline`, :mod:`lfd.segmentation.templates`).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..errors import DemonstrationError
from ..trajectory import Trajectory


def _interp_columns(t: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, int]:
    """Linear interpolation of NaN rows of ``x`` (n, ...) over ``t``; returns (filled, n_missing).
    Without a gap (or without a finite row) ``filled`` is a read-only view of ``x``, not a copy."""
    ok = np.all(np.isfinite(x.reshape(x.shape[0], -1)), axis=1)
    missing = int((~ok).sum())
    if missing == 0 or not ok.any():
        view = x.view()
        view.flags.writeable = False
        return view, missing
    flat = x.reshape(x.shape[0], -1).copy()
    for c in range(flat.shape[1]):
        flat[~ok, c] = np.interp(t[~ok], t[ok], flat[ok, c])
    return flat.reshape(x.shape), missing


def _stacked(whole: np.ndarray, parts: list[np.ndarray]) -> np.ndarray:
    """``np.stack(parts)``, or a read-only view of ``whole`` when the parts are all of it,
    unchanged (each a view of its row)."""
    if len(parts) == len(whole) and all(
        np.may_share_memory(p, w) for p, w in zip(parts, whole, strict=True)
    ):
        view = whole.view()
        view.flags.writeable = False
        return view
    return np.stack(parts)


def fill_gaps(traj: Trajectory) -> tuple[Trajectory, list[str]]:
    """Interpolate hand and object tracking gaps (NaN) so the features can be computed.

    Raises :class:`DemonstrationError` if there is no hand data or no object with data.
    Returns the filled trajectory and warnings describing what was filled or dropped.
    """
    n = len(traj)
    if n == 0:
        raise DemonstrationError("the demonstration has no samples")
    t = traj.t_s
    warnings: list[str] = []
    if not np.any(np.all(np.isfinite(traj.tcp), axis=1)):
        raise DemonstrationError("the demonstration has no hand data (the hand was never tracked)")
    tcp, m1 = _interp_columns(t, traj.tcp)
    opening, m2 = _interp_columns(t, traj.opening[:, None])
    rotation, _ = _interp_columns(t, traj.rotation)
    if max(m1, m2):
        warnings.append(
            f"hand not tracked for {max(m1, m2) * traj.dt:.2f} s in total; gaps interpolated"
        )
    keep = []
    pos = []
    quat = []
    for k, name in enumerate(traj.object_names):
        if not np.any(np.all(np.isfinite(traj.object_position[k]), axis=1)):
            warnings.append(f"object {name!r} never tracked; ignored")
            continue
        p, miss = _interp_columns(t, traj.object_position[k])
        q, _ = _interp_columns(t, traj.object_quaternion[k])
        if miss:
            warnings.append(f"object {name!r} not tracked for {miss * traj.dt:.2f} s; interpolated")
        keep.append(k)
        pos.append(p)
        quat.append(q)
    if not keep:
        raise DemonstrationError("the demonstration has no tracked objects")
    filled = dataclasses.replace(
        traj,
        tcp=tcp,
        opening=opening[:, 0],
        rotation=rotation,
        object_names=[traj.object_names[k] for k in keep],
        object_position=_stacked(traj.object_position, pos),
        object_quaternion=_stacked(traj.object_quaternion, quat),
        object_size=traj.object_size[keep],
        hand_valid=np.ones(n, dtype=bool),
        object_valid=np.ones((len(keep), n), dtype=bool),
    )
    return filled, warnings
