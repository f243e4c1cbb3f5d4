"""The method file's schema: what every field of a template file's ``lfd`` block holds.

A method file is a template file (``lfd templates train``, :meth:`lfd.Method.save`): the
engine's templates (its own ``format_version``, checked by the engine) and an ``lfd`` block:

- ``format_version`` (:data:`FORMAT_VERSION`; a file without one is read as this version, a
  newer one is refused);
- the preprocessing the templates were trained with (:data:`PREPROCESSING_RULES`);
- how they were made (:data:`ABOUT_RULES`: recordings, augmentation, adaptation; informative);
- ``method``: the method saved with them (``name``, ``search``, ``grammar`` and ``params``, the
  fields of :class:`~lfd.segmentation.settings.SegmentParams`, :data:`SEGMENT_RULES`, with
  ``stage1`` and ``contacts``).

Every field has one rule (:mod:`lfd.rules`): the same table checks a file when it is read and a
dataclass when it is made, so ``SegmentParams(penalty=-1)`` and a file with ``"penalty": -1``
are refused with the same words. Unknown keys are refused by name. docs/method-files.md is the
human-readable copy.
"""

from __future__ import annotations

from typing import Any, get_args

from .._hmmseg import EndState
from ..contact import CONTACT_RULES, ContactParams
from ..errors import LfdError, ModelFormatError
from ..preprocessing.filters import MIN_CUTOFF_HZ
from ..preprocessing.grasp import Aperture
from ..rules import Choice, Counts, Flag, Items, Nested, Number, Rule, Text, Whole, check_keys
from .stage1 import STAGE1_RULES, Stage1Params

FORMAT_VERSION = 1
"""The version of the ``lfd`` block this lfd writes and reads (``lfd.format_version``)."""

SEGMENT_RULES: dict[str, Rule] = {
    "stage1": Nested(Stage1Params, STAGE1_RULES),
    "end": Choice(get_args(EndState)),
    "min_rise": Number(0.0, 10.0, "m"),
    "dominance": Number(0.0, 1000.0),
    "max_segment_s": Number(0.0, 3600.0, "s", open_low=True),
    "lookahead": Flag(),
    "penalty": Number(0.0, 1e6, "nats"),
    "min_duration_s": Number(0.0, 3600.0, "s"),
    "co_motion": Number(0.0, 1e6, "nats"),
    "co_motion_grace_s": Number(0.0, 3600.0, "s"),
    "co_motion_slide_s": Number(-3600.0, 3600.0, "s (negative: off)"),
    "co_motion_left_s": Number(-3600.0, 3600.0, "s (negative: off)"),
    "co_motion_window_s": Number(0.0, 60.0, "s", open_low=True),
    "implicit_moves": Flag(),
    "implicit_move_s": Number(0.0, 60.0, "s"),
    "co_motion_displacement": Number(0.0, 10.0, "m"),
    "contacts": Nested(ContactParams, CONTACT_RULES, nullable=True),
}
"""What each :class:`~lfd.segmentation.settings.SegmentParams` field holds."""

MAX_CUTOFF_HZ = 1000.0
"""Largest low-pass cut-off a method file may name (a recording's own Nyquist frequency is
checked when it is preprocessed)."""

PREPROCESSING_RULES: dict[str, Rule] = {
    "feature_cutoff_hz": Number(MIN_CUTOFF_HZ, MAX_CUTOFF_HZ, "Hz", also=("auto",)),
    "object_cutoff_hz": Number(MIN_CUTOFF_HZ, MAX_CUTOFF_HZ, "Hz", also=(None,)),
    "aperture": Choice(get_args(Aperture)),
    "min_keypoint_confidence": Number(0.0, 1.0),
}
"""The preprocessing stored with templates (keyword arguments of :func:`lfd.preprocess`)."""

_NAMES = Items(Text(1000))
ABOUT_RULES: dict[str, Rule] = {
    "trained_from": _NAMES,
    "frame_symmetry": Whole(1, 360),
    "layout_scales": Items(Number(0.0, 1000.0, open_low=True), 100),
    "note": Text(),
    "adapted_from": Text(),
    "base_trained_from": _NAMES,
    "adapted_on": _NAMES,
    "adapt_examples": Counts(),
    "adapt_prior": Whole(0, 10**6),
    "adapt_kept_base": _NAMES,
}
"""How templates were made (informative: nothing reads them to segment)."""

BLOCK_KEYS: frozenset[str] = frozenset(
    {"format_version", "method", *PREPROCESSING_RULES, *ABOUT_RULES}
)
"""Every key of the ``lfd`` block."""


def check_block(
    meta: Any, where: str = "lfd.", error: type[LfdError] = ModelFormatError
) -> dict[str, Any]:
    """The ``lfd`` block of a template file checked (without its ``method`` entry, which
    :meth:`lfd.Method.of_templates` reads): known keys, each value by its rule (normalised:
    numbers as floats), and the format version, which is dropped."""
    check_keys(meta, BLOCK_KEYS, where, error)
    out: dict[str, Any] = {}
    for key, value in meta.items():
        if key == "format_version":
            check_version(value, f"{where}{key}", error)
        elif key == "method":
            if not isinstance(value, dict):
                raise error(f"{where}method must be a JSON object, got {type(value).__name__}")
            out[key] = value
        else:
            rule = PREPROCESSING_RULES.get(key) or ABOUT_RULES[key]
            out[key] = rule.check(value, f"{where}{key}", error)
    return out


def check_version(value: Any, name: str, error: type[LfdError] = ModelFormatError) -> None:
    """Refuse a format version this lfd does not read (newer, or not a version at all)."""
    version = Whole(1, 10**6).check(value, name, error)
    if version > FORMAT_VERSION:
        raise error(
            f"{name} {version} is newer than this lfd reads ({FORMAT_VERSION}): upgrade lfd"
        )
