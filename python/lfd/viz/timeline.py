"""Timelines shared by every view: names, the time origin of a recording, time columns.

``demo_time`` is a duration timeline: integer nanoseconds since the *origin* of the recording,
which is the start of the first thing logged to it (the demonstration, or the first feature
sample) unless set explicitly with :func:`set_time_origin`. Every ``log_*`` function converts
the absolute capture times of lfd (``t_ns``) with the same origin, so the hand, the features and
the segments line up. ``frame`` is the sample index of the stream an entity belongs to (the
trajectory/feature sample for pipeline results, so stage-1 boundaries read directly on it).
``robot_time`` holds reproductions, ``greedy_iteration`` the stage-2 greedy search.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from ..errors import DemonstrationError
from .recording import get_recording, import_rerun

DEMO_TIME = "demo_time"
"""Duration timeline of the demonstration, nanoseconds since the recording's origin."""
FRAME = "frame"
"""Sequence timeline: sample index within the logged stream."""
ROBOT_TIME = "robot_time"
"""Duration timeline of a reproduction, nanoseconds since its start."""
GREEDY_ITERATION = "greedy_iteration"
"""Sequence timeline of the stage-2 greedy segmentation iterations."""

_ORIGINS: dict[str, int] = {}


def set_time_origin(origin_ns: int, *, recording: Any = None) -> None:
    """Make ``origin_ns`` (absolute capture time) the zero of ``demo_time`` for a recording."""
    rec = get_recording(recording)
    _ORIGINS[rec.get_recording_id()] = int(origin_ns)


def time_origin(rec: Any, *, first_ns: int, origin_ns: int | None = None) -> int:
    """The ``demo_time`` origin of ``rec``: explicit, already set, or ``first_ns`` (then kept)."""
    key = rec.get_recording_id()
    if origin_ns is not None:
        _ORIGINS[key] = int(origin_ns)
    return _ORIGINS.setdefault(key, int(first_ns))


def current_origin(rec: Any) -> int | None:
    """The ``demo_time`` origin of ``rec`` if one is set."""
    return _ORIGINS.get(rec.get_recording_id())


def as_ns(t_ns: npt.ArrayLike, what: str, n: int | None = None) -> np.ndarray:
    """Check integer nanosecond timestamps, shape (n,), and return them as int64."""
    t = np.asarray(t_ns)
    if t.ndim != 1:
        raise DemonstrationError(f"{what}: timestamps must be 1-D, got shape {t.shape}")
    if t.size and not np.issubdtype(t.dtype, np.integer):
        raise DemonstrationError(f"{what}: timestamps must be integer nanoseconds, got {t.dtype}")
    if n is not None and t.shape[0] != n:
        raise DemonstrationError(f"{what}: {t.shape[0]} timestamps for {n} samples")
    return t.astype(np.int64, copy=False)


def time_columns(
    t_ns: np.ndarray,
    origin_ns: int,
    *,
    frame: npt.ArrayLike | None = None,
    timeline: str = DEMO_TIME,
) -> list[Any]:
    """``rr.TimeColumn`` s for absolute times ``t_ns`` (n,) and optional frame indices (n,)."""
    rr = import_rerun()
    rel = (np.asarray(t_ns, dtype=np.int64) - np.int64(origin_ns)).astype("timedelta64[ns]")
    cols = [rr.TimeColumn(timeline, duration=rel)]
    if frame is not None:
        cols.append(rr.TimeColumn(FRAME, sequence=np.asarray(frame, dtype=np.int64)))
    return cols


def set_time(
    rec: Any,
    t_ns: int,
    origin_ns: int,
    *,
    frame: int | None = None,
    timeline: str = DEMO_TIME,
) -> None:
    """Set the current time of ``rec`` (for ``rec.log``) to absolute ``t_ns``."""
    rec.set_time(timeline, duration=np.timedelta64(int(t_ns) - int(origin_ns), "ns"))
    if frame is not None:
        rec.set_time(FRAME, sequence=int(frame))
