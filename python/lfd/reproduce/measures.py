"""Measures of a reproduction: TCP path length, execution time, per-object task success."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .goals import quat_to_matrix

POS_TOL = 0.01
"""Success: an object ends within this distance of its expected pose (m)."""
ROT_TOL_DEG = 10.0
"""Success: and within this rotation (deg), modulo the box's symmetries."""


def path_length(points: np.ndarray) -> float:
    """Sum of the distances between consecutive points, ``points`` shape (n, 3)."""
    p = np.asarray(points, dtype=np.float64)
    if p.shape[0] < 2:
        return 0.0
    return float(np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1)))


def _symmetries(size: np.ndarray) -> list[np.ndarray]:
    """Rotations about the box's vertical axis that map it onto itself."""
    square = abs(size[0] - size[1]) < 0.003
    angles = np.arange(4) * np.pi / 2 if square else np.array([0.0, np.pi])
    out = []
    for a in angles:
        c, s = np.cos(a), np.sin(a)
        out.append(np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]))
    return out


@dataclass
class ObjectResult:
    """Final pose error of one object."""

    name: str
    position_error: float
    rotation_error_deg: float

    @property
    def success(self) -> bool:
        return self.position_error <= POS_TOL and self.rotation_error_deg <= ROT_TOL_DEG


def object_errors(
    names: list[str],
    final_position: np.ndarray,
    final_quaternion: np.ndarray,
    expected: dict[str, np.ndarray],
    sizes: np.ndarray,
) -> list[ObjectResult]:
    """Compare final object poses to the expected 4x4 poses.

    Parameters
    ----------
    names : list of str
    final_position : array, shape (k, 3)
    final_quaternion : array, shape (k, 4)
        (x, y, z, w).
    expected : dict name -> array (4, 4)
    sizes : array, shape (k, 3)
    """
    out = []
    for j, name in enumerate(names):
        T = expected[name]
        perr = float(np.linalg.norm(final_position[j] - T[:3, 3]))
        R = quat_to_matrix(final_quaternion[j])
        best = np.inf
        for S in _symmetries(np.asarray(sizes[j])):
            c = (np.trace((T[:3, :3] @ S).T @ R) - 1.0) / 2.0
            best = min(best, float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0)))))
        out.append(ObjectResult(name, perr, best))
    return out
