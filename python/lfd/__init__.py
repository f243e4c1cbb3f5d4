"""lfd — learn a robot manipulation task from a human hand demonstration.

Record hand keypoints and AR-tagged object poses to MCAP, preprocess them, segment the
demonstration into skills with HMM template matching (Rust engine ``lfd._hmmseg``), and
reproduce the task on a simulated arm in MuJoCo.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

# The functions are named by verbs (``lfd.preprocess``, ``lfd.segment``), the packages that hold
# them by nouns (``lfd.preprocessing``, ``lfd.segmentation``), so importing a package never
# replaces a function. The heavy stages (sim, reproduce, perception, viz) are imported on use.
from . import errors, io, preprocessing, segmentation
from .demo import CameraInfo, Demonstration, HandTrack, ImageStream, ObjectTrack, SkillLabel
from .engine import GaussianHMM
from .errors import EngineError, LfdError
from .features import FEATURE_NAMES, FeatureParams, Features, compute_features, label_targets
from .io import load
from .preprocessing import preprocess
from .segmentation import Method, Segment, Segmentation, Templates, segment
from .skills import SKILLS
from .trajectory import Trajectory

if TYPE_CHECKING:
    from ._version import __version__
    from .io import McapRecorder, save


def __getattr__(name: str) -> Any:
    """The MCAP writer (``lfd.save``, ``lfd.McapRecorder``) and ``__version__`` (from the
    installed package's metadata), imported when first used."""
    if name == "__version__":
        from ._version import __version__

        return __version__
    if name in ("McapRecorder", "save"):
        from . import io

        return getattr(io, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


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
    "Method",
    "ObjectTrack",
    "Segment",
    "Segmentation",
    "SkillLabel",
    "Templates",
    "Trajectory",
    "__version__",
    "compute_features",
    "errors",
    "io",
    "label_targets",
    "load",
    "preprocess",
    "preprocessing",
    "save",
    "segment",
    "segmentation",
]
