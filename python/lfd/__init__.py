"""lfd — learn a robot manipulation task from a human hand demonstration.

Record hand keypoints and AR-tagged object poses to MCAP, preprocess them, segment the
demonstration into skills with HMM template matching (Rust engine ``lfd._hmmseg``), and
reproduce the task on a simulated arm in MuJoCo.
"""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

from .demo import CameraInfo, Demonstration, HandTrack, ImageStream, ObjectTrack, SkillLabel
from .engine import GaussianHMM
from .errors import EngineError, LfdError
from .skills import SKILLS
from .trajectory import Trajectory

try:
    __version__ = version("lfd")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.0.0"

__all__ = [
    "SKILLS",
    "CameraInfo",
    "Demonstration",
    "EngineError",
    "GaussianHMM",
    "HandTrack",
    "ImageStream",
    "LfdError",
    "ObjectTrack",
    "SkillLabel",
    "Trajectory",
    "__version__",
]
