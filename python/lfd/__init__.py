"""lfd — learn a robot manipulation task from a human hand demonstration.

Record hand keypoints and AR-tagged object poses to MCAP, preprocess them, segment the
demonstration into skills with HMM template matching (Rust engine ``lfd._hmmseg``), and
reproduce the task on a simulated arm in MuJoCo.
"""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version
from typing import TYPE_CHECKING, Any

from .demo import CameraInfo, Demonstration, HandTrack, ImageStream, ObjectTrack, SkillLabel
from .engine import GaussianHMM
from .errors import EngineError, LfdError
from .features import FEATURE_NAMES, FeatureParams, Features, compute_features, label_targets
from .skills import SKILLS
from .trajectory import Trajectory

if TYPE_CHECKING:
    from .io import McapRecorder, load, save
    from .preprocess import preprocess

# Imported on first use so that ``import lfd`` (and ``lfd --help``) stays fast.
_LAZY = {"McapRecorder": "io", "load": "io", "save": "io", "preprocess": "preprocess"}


def __getattr__(name: str) -> Any:
    import importlib

    if name == "segment":  # the subpackage is callable: lfd.segment(demo) -> Segmentation
        return importlib.import_module(".segment", __name__)
    if name in _LAZY:
        return getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


try:
    __version__ = version("lfd")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.0.0"

__all__ = [
    "FEATURE_NAMES",
    "SKILLS",
    "CameraInfo",
    "Demonstration",
    "EngineError",
    "FeatureParams",
    "Features",
    "GaussianHMM",
    "HandTrack",
    "ImageStream",
    "LfdError",
    "McapRecorder",
    "ObjectTrack",
    "SkillLabel",
    "Trajectory",
    "__version__",
    "compute_features",
    "label_targets",
    "load",
    "preprocess",
    "save",
    "segment",
]
