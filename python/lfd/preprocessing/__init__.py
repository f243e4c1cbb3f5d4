"""Preprocessing: resample to one clock, low-pass filter, map the hand to a gripper.

:func:`preprocess` turns a :class:`~lfd.demo.Demonstration` into a
:class:`~lfd.trajectory.Trajectory`; :func:`lowpass` is the MATLAB-equivalent zero-phase filter
for reuse on feature arrays; :func:`gripper_frame` is the hand -> gripper mapping.
"""

from __future__ import annotations

from .filters import lowpass
from .mapping import euler_from_rotation, gripper_frame, rotation_from_euler
from .pipeline import preprocess
from .resample import resample_positions, resample_quaternions

__all__ = [
    "euler_from_rotation",
    "gripper_frame",
    "lowpass",
    "preprocess",
    "resample_positions",
    "resample_quaternions",
    "rotation_from_euler",
]
