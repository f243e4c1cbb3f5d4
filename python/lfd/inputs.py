"""Input files that cannot hang, exhaust memory or crash a parser: checked before they are read.

Every file lfd reads for the user (a recording, a ROS bag, a topic mapping, a sidecar size file,
templates, labels, intrinsics, a task program) is checked with :func:`check_input_file` before it
is opened: it must be a regular file. A FIFO blocks the open until some writer comes (forever),
and a device such as ``/dev/zero`` never ends (a reader fills memory). Text inputs are read with
:func:`read_text` (at most :data:`MAX_TEXT_BYTES`, UTF-8) and parsed with :func:`parse_json` or
:func:`parse_toml`, which turn every way those parsers fail on hostile text (too deeply nested,
a number with thousands of digits, invalid bytes) into the caller's error, one line. Numbers
typed as text (an option value, a CSV field) are read with :func:`parse_number` and
:func:`parse_integer`.

The ``output`` twin of this module is :mod:`lfd.outputs`.
"""

from __future__ import annotations

import math
import os
import stat
from typing import Any

from .errors import LfdError, UsageError

__all__ = [
    "END_TOLERANCE_NS",
    "MAX_DURATION_S",
    "MAX_SECONDS",
    "MAX_TEXT_BYTES",
    "check_duration",
    "check_input_file",
    "duration_problem",
    "parse_integer",
    "parse_json",
    "parse_number",
    "parse_toml",
    "read_text",
    "seconds",
    "shown",
]

MAX_TEXT_BYTES = 64 * 2**20
"""Largest text input (labels, mappings, sidecars, templates) read: 64 MiB, far more than any
such file lfd writes (the shipped templates are 52 KB)."""

_KINDS = (
    (stat.S_ISFIFO, "a FIFO (named pipe)"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
)


def check_input_file(
    path: str | os.PathLike[str],
    what: str = "",
    error: type[LfdError] = UsageError,
    *,
    directory: bool = False,
) -> str:
    """``path`` (as a string) once it is known not to be a FIFO, device or socket.

    A path that does not exist (or cannot be looked at) is returned as it is: the open that
    follows reports it as it always has. A directory is refused unless ``directory``.
    ``what`` names the input in the message (``"--map"``); ``error`` is the class raised.
    """
    p = os.fspath(path)
    try:
        st = os.stat(p)  # follows symlinks: a link to /dev/zero is /dev/zero
    except (OSError, ValueError):
        return p
    label = f"{what} {p}" if what else p
    if stat.S_ISDIR(st.st_mode):
        if directory:
            return p
        raise error(f"{label} is a directory, not a regular file; give a file")
    if stat.S_ISREG(st.st_mode):
        return p
    kind = next((name for test, name in _KINDS if test(st.st_mode)), "not a file")
    raise error(f"{label} is not a regular file ({kind}); give a file")


def read_text(
    path: str | os.PathLike[str],
    what: str = "",
    error: type[LfdError] = UsageError,
    *,
    limit: int = MAX_TEXT_BYTES,
    not_text: str = "is not UTF-8 text",
) -> str:
    """The UTF-8 text of a regular file of at most ``limit`` bytes, else ``error`` (for bytes
    that are not UTF-8: ``"<path> <not_text>"``). A leading byte order mark (as Excel and some
    Windows editors write UTF-8) is not part of the text and is dropped.

    :class:`OSError` (missing file, permission denied) propagates for the caller to word."""
    p = check_input_file(path, what, error)
    label = f"{what} {p}" if what else p
    with open(p, "rb") as f:
        data = f.read(limit + 1)
    if len(data) > limit:
        raise error(f"{label} is larger than {limit // 2**20} MiB; not a text input lfd reads")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise error(f"{label} {not_text}") from None


def _detail(err: BaseException) -> str:
    if isinstance(err, RecursionError):
        return "nested too deeply"
    text = " ".join(str(err).split())
    if "integer string conversion" in text:  # Python's limit on the digits of an int
        return "a number has more than 4300 digits"
    return text[:200]


def parse_json(text: str | bytes, prefix: str, error: type[LfdError] = UsageError) -> Any:
    """``json.loads(text)``; any failure raises ``error(f"{prefix}: {reason}")``."""
    import json

    try:
        return json.loads(text)
    except (RecursionError, ValueError) as err:  # JSONDecodeError and UnicodeDecodeError too
        raise error(f"{prefix}: {_detail(err)}") from None


def parse_toml(text: str, prefix: str, error: type[LfdError] = UsageError) -> dict[str, Any]:
    """``tomllib.loads(text)``; any failure raises ``error(f"{prefix}: {reason}")``."""
    import tomllib

    try:
        return tomllib.loads(text)
    except (RecursionError, ValueError) as err:  # TOMLDecodeError is a ValueError
        raise error(f"{prefix}: {_detail(err)}") from None


def shown(value: Any) -> str:
    """``repr(value)`` for a message, cut to 40 characters (a file may hold a 5000-digit
    number or a huge list)."""
    text = repr(value)
    return text if len(text) <= 40 else f"{text[:37]}..."


def parse_number(text: str) -> float:
    """``float(text)`` for a number typed as text, without Python's own spellings: digit-group
    underscores (``1_0`` would be 10) and non-ASCII digits are refused, as a user means no such
    thing. NaN and infinity are returned (the caller says whether it takes them).

    Raises
    ------
    ValueError
        ``text`` is not a number (no message: the caller words it).
    """
    return float(_plain(text))


def parse_integer(text: str) -> int:
    """``int(text)`` for an integer typed as text, refusing what :func:`parse_number` refuses.

    Raises
    ------
    ValueError
        ``text`` is not an integer (no message: the caller words it).
    """
    return int(_plain(text))


END_TOLERANCE_NS = 100_000_000
"""How far (ns) a label may end after the recording's last sample: 0.1 s, three samples at
30 Hz, since a segment ends where the next sample would start."""

MAX_SECONDS = 9e9
"""Largest time (s) a label may give, either sign: nanoseconds beyond it do not fit in the
signed 64-bit integers recordings count time in (2**63 ns is 9.2e9 s, 292 years)."""


MAX_DURATION_S = 24 * 3600.0
"""Longest ``--duration`` (s) of any command (``lfd record``, ``lfd simulate``) and of
:func:`lfd.sim.demonstrator.crop`: 24 hours, longer than any one recording session; a
simulated demonstration lasts far less and is cropped to at most its length. Beyond it
a duration in nanoseconds or frames overflows (1e10 s does not fit in an int64 of ns)."""


def duration_problem(value: Any) -> str | None:
    """What is wrong with ``value`` as a duration to keep (None: a finite number of seconds in
    (0, :data:`MAX_DURATION_S`]); the rule of every duration (``--duration``,
    :func:`lfd.sim.demonstrator.crop`)."""
    try:
        x = math.nan if isinstance(value, bool) else float(value)
    except (TypeError, ValueError, OverflowError):
        x = math.nan
    if not (math.isfinite(x) and x > 0):
        return "must be a finite number of seconds > 0"
    if x > MAX_DURATION_S:
        return f"must be at most {MAX_DURATION_S:g} s (24 h)"
    return None


def check_duration(value: float, what: str = "duration") -> float:
    """``value`` as seconds once :func:`duration_problem` finds nothing wrong with it.

    Raises
    ------
    UsageError
        ``f"{what} must be ..., got {value}"``, one line.
    """
    problem = duration_problem(value)
    if problem is not None:
        raise UsageError(f"{what} {problem}, got {shown(value)}")
    return float(value)


def seconds(value: Any, where: str, key: str) -> float:
    """``value`` (a JSON number, or text such as a CSV field) as a time in seconds: a finite
    number, not a boolean, within :data:`MAX_SECONDS` either way. The rule of every time a user
    gives in a file (labels, handovers, a task program).

    Raises
    ------
    UsageError
        ``f"{where}: {key} must be ..."``, one line (a huge value is cut short).
    """
    if isinstance(value, bool) or value is None:
        raise UsageError(f"{where}: {key} must be a number of seconds, got {shown(value)}")
    try:  # an integer beyond any float (10**400) is out of range below, not "not a number"
        x = parse_number(value) if isinstance(value, str) else float(value)
    except OverflowError:
        x = 2 * MAX_SECONDS  # the sign does not matter: |x| is checked
    except (TypeError, ValueError):
        raise UsageError(
            f"{where}: {key} must be a number of seconds, got {shown(value)}"
        ) from None
    if not math.isfinite(x):
        raise UsageError(f"{where}: {key} must be a finite number of seconds, got {shown(value)}")
    if abs(x) > MAX_SECONDS:
        raise UsageError(
            f"{where}: {key} must be within +-{MAX_SECONDS:g} s of the recording, "
            f"got {shown(value)}"
        )
    return x


def _plain(text: str) -> str:
    if "_" in text or not text.isascii():
        raise ValueError(text)
    return text


def is_ros_path(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` is a ROS bag by its name alone: a ``.bag`` or ``.db3`` file or a
    directory (a ROS 2 bag holds ``metadata.yaml``). An ``.mcap`` needs a look inside
    (:func:`is_ros_recording`)."""
    p = os.fspath(path)
    if os.path.isdir(p):
        return os.path.isfile(os.path.join(p, "metadata.yaml"))
    return p.endswith((".bag", ".db3"))
