"""The distance from a point to an object's box: the one implementation of the rule that the
contact rules (:mod:`lfd.contact`), the grasp aperture (:mod:`lfd.preprocessing.grasp`), the
recording checks (:mod:`lfd.io.checks`) and the grasp goals (:mod:`lfd.reproduce.goals`) use.

A box is its centre, its orientation (a quaternion x, y, z, w) and its size (the full edge
lengths); a point's distance from it is the length of the part of its offset, in the box's
frame, that sticks out of the half sizes: 0 inside.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["box_distance", "in_box_frame", "outside_distance"]

_IDENTITY = np.array([0.0, 0.0, 0.0, 1.0])


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``np.cross`` of 3-vectors on the last axis (the same products, without its axis moves)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def in_box_frame(offset: npt.ArrayLike, quaternion: npt.ArrayLike) -> np.ndarray:
    """``R(q)^T offset``: offsets ``(..., 3)`` from a box's centre in the frame of a box of
    orientation ``quaternion`` ``(..., 4)`` (x, y, z, w; normalised here, a unit one is used
    as it is up to rounding), broadcast."""
    q = np.asarray(quaternion, dtype=np.float64)
    v = np.asarray(offset, dtype=np.float64)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    u, w = -q[..., :3], q[..., 3:]  # the inverse rotation
    t = 2.0 * _cross(u, v)
    return np.asarray(v + w * t + _cross(u, t))


def outside_distance(local: npt.ArrayLike, size: npt.ArrayLike) -> np.ndarray:
    """Distance of points ``local`` ``(..., k)`` given in a box's frame from that box, of full
    edge lengths ``size`` ``(..., k)`` (``k`` = 3, or 2 for the footprint of an upright box):
    0 inside, NaN for a NaN point."""
    out = np.maximum(np.abs(np.asarray(local)) - np.asarray(size, dtype=np.float64) / 2.0, 0.0)
    return np.asarray(np.linalg.norm(out, axis=-1))


def box_distance(
    points: npt.ArrayLike,
    position: npt.ArrayLike,
    quaternion: npt.ArrayLike,
    size: npt.ArrayLike,
) -> np.ndarray:
    """Distance (m) of ``points`` ``(..., 3)`` from boxes of ``size`` ``(3,)`` (or
    ``(..., 3)``) centred at ``position`` ``(..., 3)`` with orientation ``quaternion``
    ``(..., 4)`` (x, y, z, w), all broadcast: 0 inside. A NaN point, a non-finite pose or a
    zero quaternion gives NaN (without a floating-point warning from the quaternion)."""
    p = np.asarray(points, dtype=np.float64)
    c = np.asarray(position, dtype=np.float64)
    q = np.asarray(quaternion, dtype=np.float64)
    ok = np.isfinite(q).all(axis=-1) & (np.linalg.norm(np.nan_to_num(q), axis=-1) > 0)
    local = in_box_frame(p - c, np.where(ok[..., None], q, _IDENTITY))
    d = outside_distance(local, size)
    return np.where(ok & np.isfinite(d), d, np.nan)
