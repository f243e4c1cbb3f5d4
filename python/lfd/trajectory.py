"""The preprocessed demonstration: every stream on one clock, the hand mapped to a gripper.

Produced by :func:`lfd.preprocess` (resample + filter + hand -> gripper mapping) and
consumed by the features, segmentation, reproduction and visualisation stages.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np


@dataclass
class Trajectory:
    """A demonstration resampled onto common timestamps.

    Attributes
    ----------
    t_ns : array, shape (n,)
        Common timestamps, int64 nanoseconds (absolute, as in the recording).
    tcp : array, shape (n, 3)
        Tool centre point ``(I + T) / 2`` in metres, world frame.
    rotation : array, shape (n, 3, 3)
        Gripper orientation (columns = x, y, z axes of the hand frame in world coordinates).
    euler : array, shape (n, 3)
        The same orientation as (unwrapped) XYZ Euler angles in radians, low-pass filtered.
    opening : array, shape (n,)
        Gripper opening = fingertip distance ``|I - T|`` in metres.
    keypoints : array, shape (n, 21, 3)
        The resampled hand keypoints.
    object_names : list[str]
        Object names; index ``k`` below refers to ``object_names[k]``.
    object_position : array, shape (k, n, 3)
        Object centres, metres.
    object_quaternion : array, shape (k, n, 4)
        Object orientations (x, y, z, w).
    object_size : array, shape (k, 3)
        Box dimensions ``d_i``, metres.
    hand_valid : array, shape (n,)
        False inside long hand-tracking gaps (values there are NaN).
    object_valid : array, shape (k, n)
        False inside long marker gaps.
    meta : dict
        Preprocessing parameters and reports (gaps, cut-offs, rate).
    """

    t_ns: np.ndarray
    tcp: np.ndarray
    rotation: np.ndarray
    euler: np.ndarray
    opening: np.ndarray
    keypoints: np.ndarray
    object_names: list[str]
    object_position: np.ndarray
    object_quaternion: np.ndarray
    object_size: np.ndarray
    hand_valid: np.ndarray
    object_valid: np.ndarray
    meta: dict[str, Any] = field(default_factory=dict)

    def __len__(self) -> int:
        return int(self.t_ns.shape[0])

    @property
    def t_s(self) -> np.ndarray:
        """Seconds since the first sample, shape (n,)."""
        return (self.t_ns - self.t_ns[0]).astype(np.float64) * 1e-9

    @property
    def dt(self) -> float:
        """Sample period in seconds."""
        if len(self) < 2:
            return 0.0
        return float((self.t_ns[1] - self.t_ns[0]) * 1e-9)
