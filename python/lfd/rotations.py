"""Rotations without scipy: unit quaternions ``(x, y, z, w)``, rotation matrices and extrinsic
x-y-z Euler angles, computed by the engine (``crates/hmmseg/src/rotation.rs``) with the formulas
of ``scipy.spatial.transform.Rotation`` and ``Slerp`` (the same numbers to a few units in the
last place).

Every function takes one rotation (``(4,)``, ``(3, 3)``, ``(3,)``) or many (``(n, 4)``,
``(n, 3, 3)``, ``(n, 3)``) and returns the same number; a rotation with a NaN entry gives NaN
(a tracking gap stays a gap). Quaternions are normalised where they are read, as
``Rotation.from_quat`` does; a zero quaternion is an :class:`~lfd.errors.InvalidParameterError`.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from . import _hmmseg

__all__ = [
    "apply",
    "as_matrix",
    "euler_from_matrix",
    "euler_from_quat",
    "from_matrix",
    "inverse",
    "make_continuous",
    "matrix_from_euler",
    "multiply",
    "normalize",
    "quat_from_euler",
    "slerp",
]

IDENTITY = np.array([0.0, 0.0, 0.0, 1.0])
"""The identity quaternion."""


def _many(
    fn: Callable[[np.ndarray], np.ndarray], x: npt.ArrayLike, inner: tuple[int, ...]
) -> np.ndarray:
    """``fn`` of rows of shape ``inner``; a single row in, a single row out."""
    arr = np.ascontiguousarray(x, dtype=np.float64)
    single = arr.shape == inner
    out = fn(arr.reshape((1, *inner)) if single else arr)
    return out[0] if single else out


def normalize(q: npt.ArrayLike) -> np.ndarray:
    """Unit quaternions ``q / |q|``."""
    return _many(_hmmseg.quat_normalize, q, (4,))


def as_matrix(q: npt.ArrayLike) -> np.ndarray:
    """Rotation matrices ``(..., 3, 3)`` of quaternions (``Rotation.from_quat(q).as_matrix()``)."""
    return _many(_hmmseg.quat_to_matrix, q, (4,))


def from_matrix(m: npt.ArrayLike) -> np.ndarray:
    """Unit quaternions of rotation matrices (``Rotation.from_matrix(m).as_quat()``; a matrix
    that is not orthogonal is replaced by the nearest rotation, one of non-positive
    determinant is an error)."""
    return _many(_hmmseg.quat_from_matrix, m, (3, 3))


def euler_from_matrix(m: npt.ArrayLike) -> np.ndarray:
    """Extrinsic x-y-z Euler angles of rotation matrices (``.as_euler("xyz")``)."""
    return _many(_hmmseg.euler_xyz_from_matrix, m, (3, 3))


def matrix_from_euler(e: npt.ArrayLike) -> np.ndarray:
    """Rotation matrices of extrinsic x-y-z Euler angles (``Rotation.from_euler("xyz", e)``)."""
    return _many(_hmmseg.matrix_from_euler_xyz, e, (3,))


def euler_from_quat(q: npt.ArrayLike) -> np.ndarray:
    """Extrinsic x-y-z Euler angles of quaternions."""
    return _many(_hmmseg.euler_xyz_from_quat, q, (4,))


def quat_from_euler(e: npt.ArrayLike) -> np.ndarray:
    """Quaternions of extrinsic x-y-z Euler angles."""
    return _many(_hmmseg.quat_from_euler_xyz, e, (3,))


def inverse(q: npt.ArrayLike) -> np.ndarray:
    """The inverse rotations ``(-x, -y, -z, w)`` (of unit quaternions)."""
    out = np.array(q, dtype=np.float64)
    out[..., :3] *= -1.0
    return out


def multiply(p: npt.ArrayLike, q: npt.ArrayLike) -> np.ndarray:
    """``p * q`` (``q`` applied first), normalised; one of them may be a single rotation."""
    a = np.ascontiguousarray(p, dtype=np.float64)
    b = np.ascontiguousarray(q, dtype=np.float64)
    out = _hmmseg.quat_multiply(a.reshape(-1, 4), b.reshape(-1, 4))
    return out[0] if a.ndim == 1 and b.ndim == 1 else out


def apply(q: npt.ArrayLike, v: npt.ArrayLike, *, inverse: bool = False) -> np.ndarray:
    """``R(q) v`` (``R(q)^T v`` with ``inverse``); one of them may be a single row."""
    a = np.ascontiguousarray(q, dtype=np.float64)
    b = np.ascontiguousarray(v, dtype=np.float64)
    out = _hmmseg.quat_apply(a.reshape(-1, 4), b.reshape(-1, 3), inverse)
    return out[0] if a.ndim == 1 and b.ndim == 1 else out


def slerp(times: npt.ArrayLike, q: npt.ArrayLike, at: npt.ArrayLike) -> np.ndarray:
    """Spherical linear interpolation ``(len(at), 4)`` of key rotations ``q`` ``(m, 4)`` at
    strictly increasing ``times`` (``m >= 2``): ``Slerp(times, Rotation.from_quat(q))(at)``.
    Every time of ``at`` must lie in ``[times[0], times[-1]]``."""
    return _hmmseg.quat_slerp(
        np.ascontiguousarray(times, dtype=np.float64),
        np.ascontiguousarray(q, dtype=np.float64).reshape(-1, 4),
        np.ascontiguousarray(at, dtype=np.float64).reshape(-1),
    )


def make_continuous(q: npt.ArrayLike) -> np.ndarray:
    """Signs flipped so consecutive finite quaternions ``(n, 4)`` have a non-negative dot
    product (each run of finite rows on its own; the first row of a run keeps its sign)."""
    return _hmmseg.quat_make_continuous(np.ascontiguousarray(q, dtype=np.float64))
