"""Native libraries that write to file descriptor 2 (OpenCV's ``[ WARN ]`` lines, FFmpeg's
complaints about a damaged file, TFLite's delegate banner) around calls whose outcome lfd
reports itself, in one line.

:func:`quiet_opencv` is the one place OpenCV's and FFmpeg's own logging is set: importing
:mod:`lfd.perception` calls it, before OpenCV opens anything. A variable the user set in the
environment is left as it is (``OPENCV_LOG_LEVEL=INFO lfd record ...`` shows OpenCV's lines).
"""

from __future__ import annotations

import contextlib
import os
import sys
from collections.abc import Iterator
from types import ModuleType

from .image_header import MAX_IMAGE_PIXELS

OPENCV_ENVIRONMENT = {
    "OPENCV_LOG_LEVEL": "SILENT",  # OpenCV's own [ WARN ] / [ERROR] lines
    "OPENCV_FFMPEG_LOGLEVEL": "-8",  # AV_LOG_QUIET: FFmpeg's lines about a damaged video
    "CV_IO_MAX_IMAGE_PIXELS": str(MAX_IMAGE_PIXELS),  # what OpenCV's imread allocates
}
"""What :func:`quiet_opencv` sets, unless the environment already has it."""

_ours: set[str] = set()


def quiet_opencv() -> None:
    """Set :data:`OPENCV_ENVIRONMENT` (read by OpenCV when it starts and by its FFmpeg backend
    when it opens its first video), and OpenCV's log level if it is already imported."""
    for key, value in OPENCV_ENVIRONMENT.items():
        if key not in os.environ:
            os.environ[key] = value
            _ours.add(key)
    if "cv2" in sys.modules:
        _silence(sys.modules["cv2"])


def _silence(cv2: ModuleType) -> None:
    if "OPENCV_LOG_LEVEL" in _ours:
        with contextlib.suppress(AttributeError):  # a stand-in cv2 of a test
            cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_SILENT)


def opencv() -> ModuleType:
    """``cv2``, quiet (:func:`quiet_opencv`)."""
    quiet_opencv()
    import cv2

    _silence(cv2)
    return cv2


@contextlib.contextmanager
def quiet_stderr() -> Iterator[None]:
    """Silence native writes to file descriptor 2 (Python's own stderr is flushed first)."""
    sys.stderr.flush()
    try:
        saved = os.dup(2)
    except OSError:  # no usable fd 2: nothing to silence
        yield
        return
    try:
        with open(os.devnull, "wb") as null:
            os.dup2(null.fileno(), 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)
