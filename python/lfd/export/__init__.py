"""Export: recordings out to other tools' formats.

:mod:`.lerobot` writes a LeRobot dataset, one episode per recording, with the skill labels
frame by frame (``lfd export lerobot``, docs/export.md). The ``lerobot`` package is imported only
when a dataset is written (the ``lerobot`` extra).
"""

from __future__ import annotations

from .lerobot import (
    LABEL_SOURCES,
    Episode,
    ExportReport,
    LeRobotWriter,
    RecordingResult,
    export_lerobot,
    export_recording,
    prepare_episode,
)

__all__ = [
    "LABEL_SOURCES",
    "Episode",
    "ExportReport",
    "LeRobotWriter",
    "RecordingResult",
    "export_lerobot",
    "export_recording",
    "prepare_episode",
]
