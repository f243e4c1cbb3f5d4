"""Output files that never lose data: checked before the work starts, written atomically.

Every command that writes a file checks its destination first with :func:`check_output` (an
input is never overwritten, the directory exists and is writable, the path is not a
directory), then writes through :func:`atomic_output` (or :func:`atomic_write_text`): the data
goes to a temporary file beside the destination, which replaces the destination by an atomic
rename only once it is complete. A failed or interrupted command therefore leaves either the old
file or none, never a half-written one, and two runs writing the same file cannot interleave.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import TextIO

from .errors import UsageError

STDOUT = "-"
"""The path that means standard output, where a command allows it."""


def stdout(what: str = "output") -> TextIO:
    """``sys.stdout``, refused with :class:`UsageError` when standard output is closed
    (``lfd ... --json - >&-``: Python then has no ``sys.stdout`` at all)."""
    import sys

    out = sys.stdout
    closed = UsageError(f"{what} -: standard output is closed; give a file name")
    if out is None or getattr(out, "closed", False):
        raise closed
    try:
        fd = out.fileno()
    except (OSError, ValueError, AttributeError):
        return out  # not a file descriptor (a caller's stream, a test's capture): writable
    try:
        os.fstat(fd)
    except OSError:
        raise closed from None
    return out


def check_output(
    path: str | os.PathLike[str],
    *,
    inputs: Iterable[str | os.PathLike[str]] = (),
    what: str = "output",
    allow_stdout: bool = False,
    suffixes: Iterable[str] = (),
) -> Path:
    """Refuse an output destination that cannot be written, before any work is done.

    Parameters
    ----------
    path : path-like
        The requested output file.
    inputs : iterable of path-like
        Files the command reads; the output may be none of them.
    what : str
        How the error message names the output (e.g. ``"--json"``).
    allow_stdout : bool
        Whether ``-`` (standard output) is allowed.
    suffixes : iterable of str
        Allowed file extensions (e.g. ``(".json",)``); empty: any.

    Returns
    -------
    Path
        The destination (``Path("-")`` for standard output).

    Raises
    ------
    UsageError
        The destination is an input, a directory, in a missing or read-only directory, or has an
        extension not in ``suffixes``.
    """
    p = Path(path)
    if str(path) == STDOUT:
        if allow_stdout:
            stdout(what)
            return p
        raise UsageError(f"{what}: '-' (standard output) is not supported here; give a file name")
    if str(path) == "":
        raise UsageError(f"{what}: empty file name")
    for inp in inputs:
        q = Path(inp)
        same = q.exists() and p.exists() and os.path.samefile(p, q)
        if same or p.resolve() == q.resolve():
            raise UsageError(f"{what} {p} is also an input; refusing to overwrite it")
    if p.is_dir():
        raise UsageError(f"{what} {p} is a directory; give a file name")
    allowed = tuple(s.lower() for s in suffixes)
    if allowed and p.suffix.lower() not in allowed:
        raise UsageError(f"{what} {p}: unsupported extension; use {', '.join(allowed)}")
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.exists():
        raise UsageError(f"{what} {p}: directory {parent} does not exist")
    if not parent.is_dir():
        raise UsageError(f"{what} {p}: {parent} is not a directory")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise UsageError(f"{what} {p}: directory {parent} is not writable")
    if p.exists() and not os.access(p, os.W_OK):
        raise UsageError(f"{what} {p} exists and is read-only")
    return p


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success it is renamed onto ``path``.

    On an exception (including KeyboardInterrupt) the temporary file is removed and ``path`` is
    left as it was. The temporary name starts with ``.`` and ends with ``.partial``.
    """
    dest = Path(path)
    fd, tmp_name = tempfile.mkstemp(
        prefix=f".{dest.name}.", suffix=".partial", dir=dest.parent if str(dest.parent) else "."
    )
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        yield tmp
        if dest.exists():
            with contextlib.suppress(OSError):
                os.chmod(tmp, dest.stat().st_mode & 0o777)
        else:
            with contextlib.suppress(OSError):
                umask = os.umask(0)
                os.umask(umask)
                os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, dest)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes) -> None:
    """Write ``data`` to ``path`` atomically (see :func:`atomic_output`)."""
    with atomic_output(path) as tmp:
        with open(tmp, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())


def atomic_write_text(path: str | os.PathLike[str], text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically; ``-`` writes to standard output."""
    if str(path) == STDOUT:
        out = stdout()
        out.write(text if text.endswith("\n") else text + "\n")
        out.flush()
        return
    atomic_write_bytes(path, text.encode("utf-8"))


class _Discarded(Exception):
    """Thrown into :func:`atomic_output` to discard the temporary file."""


class PendingOutput:
    """:func:`atomic_output` for a file written over an object's lifetime (a recorder, a sink).

    ``path`` is the temporary file to write; :meth:`commit` renames it onto ``destination``,
    :meth:`discard` removes it. Both are idempotent, and only the first of them has an effect.
    """

    def __init__(self, destination: str | os.PathLike[str]) -> None:
        self.destination = Path(destination)
        self._cm = atomic_output(destination)
        self.path: Path = self._cm.__enter__()
        self._done = False

    def commit(self) -> None:
        """Move the finished temporary file onto the destination."""
        if not self._done:
            self._done = True
            self._cm.__exit__(None, None, None)

    def discard(self) -> None:
        """Remove the temporary file; the destination is left as it was."""
        if not self._done:
            self._done = True
            err = _Discarded()
            self._cm.__exit__(_Discarded, err, None)


def check_output_dir(
    path: str | os.PathLike[str],
    *,
    inputs: Iterable[str | os.PathLike[str]] = (),
    what: str = "output",
    overwrite: bool = False,
) -> Path:
    """Refuse an output directory that cannot be written, before any work is done.

    The directory may be missing (it is created) or empty; a non-empty one only with
    ``overwrite``, and never one that holds an input (replacing it would delete the input).

    Raises
    ------
    UsageError
        The path is a file, non-empty without ``overwrite``, holds an input, or its parent is
        missing or read-only.
    """
    p = Path(path)
    if str(path) in ("", STDOUT):
        raise UsageError(f"{what}: give a directory name")
    if p.exists() and not p.is_dir():
        raise UsageError(f"{what} {p} is a file; give a directory")
    if p.is_dir() and any(p.iterdir()):
        if not overwrite:
            raise UsageError(f"{what} {p} is not empty; pass --overwrite to replace it")
        root = p.resolve()
        for inp in inputs:
            q = Path(inp).resolve()
            if q == root or root in q.parents:
                raise UsageError(f"{what} {p} holds the input {inp}; refusing to replace it")
    parent = p.resolve().parent
    if not parent.is_dir():
        raise UsageError(f"{what} {p}: directory {parent} does not exist")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise UsageError(f"{what} {p}: directory {parent} is not writable")
    return p


@contextlib.contextmanager
def atomic_directory(path: str | os.PathLike[str]) -> Iterator[Path]:
    """:func:`atomic_output` for a directory: yield a path beside ``path`` to create and fill.

    The yielded path does not exist yet (the caller creates it, e.g. a library that insists on
    a new directory); it lies in a temporary directory ``.<name>.*.partial`` beside ``path``. On
    success it replaces ``path`` (an existing directory is moved aside first and removed only
    after the rename); on an exception the temporary directory is removed and ``path`` is left
    as it was.
    """
    import shutil

    dest = Path(path)
    parent = dest.parent if str(dest.parent) else Path(".")
    holder = Path(tempfile.mkdtemp(prefix=f".{dest.name}.", suffix=".partial", dir=parent))
    new = holder / dest.name
    old: Path | None = None
    try:
        yield new
        if not new.is_dir():
            raise FileNotFoundError(f"{new} was not created")
        if dest.is_dir() and any(dest.iterdir()):
            old = holder / ".old"
            os.replace(dest, old)
        try:
            os.replace(new, dest)  # onto a missing or empty directory
        except BaseException:
            if old is not None:
                os.replace(old, dest)
            raise
    finally:
        shutil.rmtree(holder, ignore_errors=True)
