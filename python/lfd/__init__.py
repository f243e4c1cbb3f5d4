"""lfd — learn a robot manipulation task from a human hand demonstration.

Record hand keypoints and AR-tagged object poses to MCAP, preprocess them, segment the
demonstration into skills with HMM template matching (Rust engine ``lfd._hmmseg``), and
reproduce the task on a simulated arm in MuJoCo.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

# The functions are named by verbs (``lfd.preprocess``, ``lfd.segment``), the packages that hold
# them by nouns (``lfd.preprocessing``, ``lfd.segmentation``), so importing a package never
# replaces a function. Every name is imported on first use (PEP 562): ``lfd info`` does not
# load the segmentation, ``lfd segment`` not the writer; the heavy stages (sim, reproduce,
# perception, viz) are never imported here.
from . import errors
from .errors import EngineError, LfdError

if TYPE_CHECKING:
    from . import io, preprocessing, segmentation
    from ._version import __version__
    from .demo import (
        CameraInfo,
        Demonstration,
        Handover,
        HandTrack,
        ImageStream,
        ObjectTrack,
        SkillLabel,
    )
    from .engine import GaussianHMM
    from .features import (
        FEATURE_NAMES,
        FeatureParams,
        Features,
        compute_features,
        label_targets,
    )
    from .io import McapRecorder, load, save
    from .preprocessing import preprocess
    from .segmentation import (
        HandsSegmentation,
        Method,
        Segment,
        Segmentation,
        Templates,
        segment,
        segment_hands,
    )
    from .skills import SKILLS
    from .trajectory import Trajectory

_HOME = {
    **dict.fromkeys(("io", "preprocessing", "segmentation"), ""),
    "__version__": "._version",
    **dict.fromkeys(
        (
            "CameraInfo",
            "Demonstration",
            "Handover",
            "HandsSegmentation",
            "HandTrack",
            "ImageStream",
            "ObjectTrack",
            "SkillLabel",
        ),
        ".demo",
    ),
    "GaussianHMM": ".engine",
    **dict.fromkeys(
        ("FEATURE_NAMES", "FeatureParams", "Features", "compute_features", "label_targets"),
        ".features",
    ),
    **dict.fromkeys(("McapRecorder", "load", "save"), ".io"),
    "preprocess": ".preprocessing",
    **dict.fromkeys(
        (
            "HandsSegmentation",
            "Method",
            "Segment",
            "Segmentation",
            "Templates",
            "segment",
            "segment_hands",
            "segment_hands",
        ),
        ".segmentation",
    ),
    "SKILLS": ".skills",
    "Trajectory": ".trajectory",
}
"""The module each public name comes from ("": the name is a subpackage)."""


def __getattr__(name: str) -> Any:
    """A public name, imported from its module when first used (then kept)."""
    import importlib

    home = _HOME.get(name)
    if home is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    if home == "":
        value: Any = importlib.import_module(f".{name}", __name__)
    else:
        value = getattr(importlib.import_module(home, __name__), name)
    globals()[name] = value
    return value


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
    "Handover",
    "HandsSegmentation",
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
    "segment_hands",
    "segmentation",
]
