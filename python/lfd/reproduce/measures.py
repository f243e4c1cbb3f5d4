"""Measures of a reproduction: TCP path length, execution time, per-object task success."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .goals import quat_to_matrix, square_footprint

POS_TOL = 0.01
"""Success: an object ends within this distance of its expected pose (m)."""
ROT_TOL_DEG = 10.0
"""Success: and within this rotation (deg), modulo the box's symmetries (a cuboid turned by
180 deg about any of its axes occupies the same space)."""


def path_length(points: np.ndarray) -> float:
    """Sum of the distances between consecutive points, ``points`` shape (n, 3)."""
    p = np.asarray(points, dtype=np.float64)
    if p.shape[0] < 2:
        return 0.0
    return float(np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1)))


def _symmetries(size: np.ndarray) -> list[np.ndarray]:
    """Rotations that map the box onto itself (180 deg about each axis; 90 deg about z if the
    footprint is square)."""
    flips = [np.diag(d) for d in ((1, 1, 1), (1, -1, -1), (-1, 1, -1), (-1, -1, 1))]
    if not square_footprint(size):
        return flips
    quarter = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    return flips + [quarter @ f for f in flips]


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
