"""Demonstration files: MCAP with foxglove protobuf schemas (see :mod:`lfd.io.topics`).

- :class:`McapRecorder` writes a recording sample by sample (safe to interrupt);
- :func:`save` writes a whole :class:`~lfd.demo.Demonstration`;
- :func:`load` reads one back, recovering truncated files with a warning;
- :func:`follow` reads a recording while another process still writes it;
- :func:`scan` lists a file's channels, metadata and damage without decoding;
- :func:`summarise` tells what a recording holds (``lfd info``);
- :mod:`lfd.io.checks` whether it can be segmented: the hand reaches an object
  (:func:`check_hand_reaches`), an object moves;
- :func:`merge_hands` joins two one-hand recordings of one take into a two-hand demonstration
  (:mod:`lfd.io.hands`: the clock rule of two hands);
- :mod:`lfd.io.sizes` sizes the objects a file does not (``--object-size``, ``REC.sizes.toml``);
- :mod:`lfd.io.ros` reads ROS 1/2 bags through a topic mapping (the ``ros`` extra).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from ..errors import (
    DefaultSizeWarning,
    RecordingFormatError,
    RecoveredFileWarning,
    TimestampWarning,
)
from .follow import Follower, LiveMessage, follow
from .hands import merge_hands
from .mcapfile import ChannelSummary, RawRecording, scan
from .reader import load
from .summary import summarise

if TYPE_CHECKING:
    from .checks import check_hand_reaches, closest_approach, object_travel
    from .writer import McapRecorder, save


def __getattr__(name: str) -> Any:
    """The writer and the checks, imported when first used (a command that
    only reads a recording does not pay for the MCAP writer)."""
    if name in ("McapRecorder", "save"):
        from . import writer

        return getattr(writer, name)
    if name in ("check_hand_reaches", "closest_approach", "object_travel"):
        from . import checks

        return getattr(checks, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [
    "ChannelSummary",
    "DefaultSizeWarning",
    "Follower",
    "LiveMessage",
    "McapRecorder",
    "RawRecording",
    "RecordingFormatError",
    "RecoveredFileWarning",
    "TimestampWarning",
    "check_hand_reaches",
    "closest_approach",
    "follow",
    "load",
    "merge_hands",
    "object_travel",
    "save",
    "scan",
    "summarise",
]
