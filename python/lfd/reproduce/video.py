"""Videos of a reproduction: the frames :func:`lfd.reproduce.reproduce` renders, to a file."""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..errors import LfdError
from ..outputs import atomic_output

VIDEO_SUFFIXES = (".mp4", ".avi")
"""Video containers the OpenCV writer produces (mp4v in .mp4, MJPG in .avi)."""


def write_video(
    path: str | os.PathLike[str], frames: Sequence[np.ndarray], fps: float, *, what: str = "video"
) -> None:
    """Write RGB frames to a video atomically (OpenCV: mp4v in .mp4, MJPG in .avi).

    ``what`` names the destination in error messages (the ``lfd`` command passes ``--video``).

    Raises
    ------
    LfdError
        No frames, or OpenCV could not write the file; nothing is left under ``path``.
    """
    import cv2

    if not frames:
        raise LfdError(f"{what} {path}: no frames were rendered")
    suffix = Path(path).suffix.lower()
    fourcc = cv2.VideoWriter_fourcc(*("MJPG" if suffix == ".avi" else "mp4v"))  # type: ignore[attr-defined]
    h, w = frames[0].shape[:2]
    with atomic_output(path) as tmp:
        # OpenCV picks the container from the extension: write beside the temporary file
        video = tmp.with_name(tmp.name + suffix)
        try:
            writer = cv2.VideoWriter(str(video), fourcc, fps, (w, h))
            if not writer.isOpened():
                raise LfdError(f"{what} {path}: OpenCV cannot write {suffix} video here")
            for f in frames:
                writer.write(cv2.cvtColor(f, cv2.COLOR_RGB2BGR))
            writer.release()
            if not video.exists() or video.stat().st_size == 0:
                raise LfdError(f"{what} {path}: OpenCV wrote no data")
            os.replace(video, tmp)
        finally:
            video.unlink(missing_ok=True)
