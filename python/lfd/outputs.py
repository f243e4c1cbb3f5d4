"""Output files that never lose data: checked before the work starts, written atomically.

Every command that writes a file checks its destination first with :func:`check_output` (an
input is never overwritten, the directory exists and is writable, the path is not a
directory), then writes through :func:`atomic_output` (or :func:`atomic_write_text`): the data
goes to a temporary file beside the destination, which replaces the destination by an atomic
rename only once it is complete. A failed or interrupted command therefore leaves either the old
file or none, never a half-written one, and two runs writing the same file cannot interleave.

An input is every file the command reads (:func:`lfd.io.reads.read_paths` lists them: the
files it is given, each one's object-size sidecar ``REC.sizes.toml`` and, for a file of a ROS 2
bag or the bag directory, the whole directory): no output may land on one, nor inside a bag
directory being read (a :class:`ReadPath` with ``tree``).
"""

from __future__ import annotations

import contextlib
import errno
import os
import tempfile
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

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


@dataclass(frozen=True)
class ReadPath:
    """A path a command reads (:func:`lfd.io.reads.read_paths` lists them); a plain path given
    as an input is ``ReadPath(path)``."""

    path: str
    """As given (or derived: the sidecar, the bag directory)."""
    why: str = ""
    """Why it is an input when it was not given itself (``the object sizes of e1.mcap``)."""
    tree: bool = False
    """A directory read as a whole (a ROS 2 bag, a ``frames:`` folder): nothing may be written
    inside it."""
    kind: str = "a ROS bag directory"
    """What the ``tree`` is, for the message (``a frames: source folder``)."""


def same_file(p: str | os.PathLike[str], q: str | os.PathLike[str]) -> bool:
    """Whether ``p`` and ``q`` name the same file (however spelled, through links)."""
    if os.path.realpath(p) == os.path.realpath(q):
        return True
    try:
        return os.path.samefile(p, q)  # hard links
    except OSError:
        return False


def _inside(p: str | os.PathLike[str], tree: str | os.PathLike[str]) -> bool:
    return os.path.realpath(p).startswith(os.path.realpath(tree).rstrip(os.sep) + os.sep)


Inputs = Iterable[str | os.PathLike[str] | ReadPath | None]
"""What a command reads: paths (None skipped), or :class:`ReadPath` s that say more."""


def _read(inputs: Inputs) -> list[ReadPath]:
    return [
        i if isinstance(i, ReadPath) else ReadPath(os.fspath(i))
        for i in inputs
        if i is not None
        and not (isinstance(i, (str, os.PathLike)) and os.fspath(i) in ("", STDOUT))
    ]


def input_clash(path: str | os.PathLike[str], inputs: Inputs) -> str | None:
    """Why writing ``path`` would damage an input, or None: it is one, or it lies inside a
    directory being read (a ``tree``: a ROS 2 bag, a ``frames:`` folder). The message starts after the path."""
    p = Path(path)
    for r in _read(inputs):
        why = f" ({r.why})" if r.why else ""
        if same_file(p, r.path):
            return f"is also an input{why}; refusing to overwrite it"
        if r.tree and _inside(p, r.path):
            return f"is inside {r.path}, {r.kind} being read{why}; refusing to write into it"
    return None


def check_output(
    path: str | os.PathLike[str],
    *,
    inputs: Inputs = (),
    what: str = "output",
    allow_stdout: bool = False,
    suffixes: Iterable[str] = (),
    overwrite: bool = True,
) -> Path:
    """Refuse an output destination that cannot be written, before any work is done.

    Parameters
    ----------
    path : path-like
        The requested output file.
    inputs : iterable of path-like or ReadPath
        What the command reads (:func:`lfd.io.reads.read_paths` adds the sidecars and bag
        directories of its files); the output may be none of them, nor lie in a bag directory
        being read (:func:`input_clash`).
    what : str
        How the error message names the output (e.g. ``"--json"``).
    allow_stdout : bool
        Whether ``-`` (standard output) is allowed.
    suffixes : iterable of str
        Allowed file extensions (e.g. ``(".json",)``); empty: any.
    overwrite : bool
        Whether an existing file may be replaced (False: ``--overwrite`` was not given).

    Returns
    -------
    Path
        The destination (``Path("-")`` for standard output).

    Raises
    ------
    UsageError
        The destination is an input, a directory, a device, pipe or socket, in a missing or
        read-only directory, has an extension not in ``suffixes``, or exists without
        ``overwrite``.
    """
    p = Path(path)
    if str(path) == STDOUT:
        if allow_stdout:
            stdout(what)
            return p
        raise UsageError(f"{what}: '-' (standard output) is not supported here; give a file name")
    if str(path) == "":
        raise UsageError(f"{what}: empty file name")
    clash = input_clash(p, inputs)
    if clash:
        raise UsageError(f"{what} {p} {clash}")
    if p.is_dir():
        raise UsageError(f"{what} {p} is a directory; give a file name")
    if p.exists() and not p.is_file():
        raise UsageError(f"{what} {p} {_NOT_REGULAR}")
    allowed = tuple(s.lower() for s in suffixes)
    if allowed and p.suffix.lower() not in allowed:
        raise UsageError(f"{what} {p}: unsupported extension; use {', '.join(allowed)}")
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.exists():
        raise UsageError(f"{what} {p}: directory {parent} does not exist")
    if not parent.is_dir():
        raise UsageError(f"{what} {p}: {parent} is not a directory")
    if not writable_dir(parent):
        raise UsageError(f"{what} {p}: directory {parent} is not writable")
    if p.exists() and not os.access(p, os.W_OK):
        raise UsageError(f"{what} {p} exists and is read-only")
    if p.exists() and not overwrite:
        raise UsageError(f"{what} {p} exists; pass --overwrite to replace it")
    return p


# a rename onto a device (/dev/null), a pipe or a socket would replace it with a regular file
_NOT_REGULAR = "is not a regular file (a device, pipe or socket); refusing to replace it"


def writable_dir(path: str | os.PathLike[str]) -> bool:
    """Whether files can be created in the directory ``path``: the permissions allow it and a
    probe file can really be created there (and is removed again). The probe catches what
    permissions do not show: a read-only or pseudo file system (``/proc``, ``/sys``) where
    ``root`` passes every permission check, yet nothing can be created."""
    if not os.path.isdir(path) or not os.access(path, os.W_OK | os.X_OK):
        return False
    try:
        fd, probe = tempfile.mkstemp(prefix=".lfd-probe.", suffix=".partial", dir=path)
    except OSError:
        return False
    os.close(fd)
    with contextlib.suppress(OSError):
        os.unlink(probe)
    return True


class _Held:
    """One :func:`signals_held` block; the class keeps how deep they nest in the main thread."""

    depth = 0

    def __init__(self) -> None:
        self.role = "none"  # "outer", "nested", or "none" (another thread)
        self.noted: list[int] = []
        self.swapped: dict[int, Any] = {}
        self.masked: set[int] | None = None

    def __enter__(self) -> None:
        import signal
        import threading

        if threading.current_thread() is not threading.main_thread():
            return  # no handler raises in another thread
        if _Held.depth:
            _Held.depth += 1  # nested: the outermost block holds (cheap, ~4 us)
            self.role = "nested"
            return
        held = (signal.SIGINT, signal.SIGTERM)
        for s in held:
            if callable(signal.getsignal(s)):
                self.swapped[s] = signal.signal(s, self._note)
        with contextlib.suppress(AttributeError, OSError, ValueError):
            self.masked = signal.pthread_sigmask(signal.SIG_BLOCK, held)
        self.role = "outer"
        _Held.depth = 1

    def _note(self, signum: int, _frame: object) -> None:
        self.noted.append(signum)

    def __exit__(self, *exc: object) -> None:
        if self.role != "outer":
            _Held.depth -= self.role == "nested"
            return
        import signal

        _Held.depth = 0
        for s, handler in self.swapped.items():
            signal.signal(s, handler)
        if self.masked is not None:
            signal.pthread_sigmask(signal.SIG_SETMASK, self.masked)  # a masked one comes now
        if self.noted:
            signal.raise_signal(self.noted[0])  # its handler runs now (Ctrl+C raises here)


def signals_held() -> contextlib.AbstractContextManager[None]:
    """Hold SIGINT and SIGTERM (Ctrl+C, a kill) while the block runs: a signal that arrives
    meanwhile is delivered after it (and interrupts then), so a cleanup or a write is never left
    half done. Blocks nest; only the outermost one holds and delivers.

    Python runs its signal handlers in the main thread, wherever the operating system delivers
    the signal (another thread of torch or OpenCV, say): masking the signal in the main thread
    alone would not stop the handler from raising ``KeyboardInterrupt`` in the middle of the
    block. So the Python handlers are swapped for one that only notes the signal, and the signal
    is masked in this thread as well (for a handler that is not Python's: ``SIG_DFL`` would end
    the process in the middle). In another thread nothing is swapped, since no handler raises
    there. An outermost block costs about 30 us: a caller with many short blocks nests them in
    one."""
    return _Held()


@contextlib.contextmanager
def _naming(dest: Path) -> Iterator[None]:
    """An OSError of the block names ``dest``, the user's path, not the hidden temporary one
    beside it (``error: /proc/x.json: No such file or directory``)."""
    try:
        yield
    except OSError as err:
        if err.errno is None:
            raise
        raise OSError(err.errno, err.strerror, os.fspath(dest)) from None


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success it is renamed onto ``path``.

    On an exception (including KeyboardInterrupt) the temporary file is removed and ``path`` is
    left as it was. The temporary name starts with ``.`` and ends with ``.partial``.
    """
    dest = Path(path)
    if dest.exists() and not dest.is_file() and not dest.is_dir():
        raise UsageError(f"{dest} {_NOT_REGULAR}")
    with _naming(dest):
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
        with _naming(dest):
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
    inputs: Inputs = (),
    what: str = "output",
    overwrite: bool = False,
    replaceable: Callable[[Path], str | None] | None = None,
    parents: bool = False,
) -> Path:
    """Refuse an output directory that cannot be written, before any work is done.

    The directory may be missing (it is created) or empty; a non-empty one only with
    ``overwrite``, and only when ``replaceable(path)`` has nothing against it (returns None,
    else why not: e.g. it holds files the command did not write). It may never be an input,
    lie inside a bag directory being read, or hold an input (replacing it would delete the
    input; see :func:`check_output`'s ``inputs``).
    With ``parents``, its missing parent directories are allowed too (:func:`created_parents`
    makes them): the nearest existing one must be a writable directory.

    Raises
    ------
    UsageError
        The path is a file, an input, inside a bag being read, non-empty without ``overwrite``
        or not ``replaceable``, holds an input, or its parent is missing or read-only.
    """
    p = Path(path)
    if str(path) in ("", STDOUT):
        raise UsageError(f"{what}: give a directory name")
    clash = input_clash(p, inputs)
    if clash:
        raise UsageError(f"{what} {p} {clash}")
    if p.exists() and not p.is_dir():
        raise UsageError(f"{what} {p} is a file; give a directory")
    if p.is_dir() and any(p.iterdir()):
        if not overwrite:
            raise UsageError(f"{what} {p} is not empty; pass --overwrite to replace it")
        for r in _read(inputs):
            if _inside(r.path, p):
                raise UsageError(f"{what} {p} holds the input {r.path}; refusing to replace it")
        reason = replaceable(p) if replaceable is not None else None
        if reason:
            raise UsageError(f"{what} {p}: {reason}; refusing to replace it with --overwrite")
    parent = p.resolve().parent
    while parents and not parent.exists() and parent != parent.parent:
        parent = parent.parent  # the one the missing parents will be created in
    if parent.exists() and not parent.is_dir():
        raise UsageError(f"{what} {p}: {parent} is not a directory")
    if not parent.is_dir():
        raise UsageError(f"{what} {p}: directory {parent} does not exist")
    if not writable_dir(parent):
        raise UsageError(f"{what} {p}: directory {parent} is not writable")
    return p


@contextlib.contextmanager
def atomic_directory(
    path: str | os.PathLike[str],
    *,
    overwrite: bool = True,
    replaceable: Callable[[Path], str | None] | None = None,
    what: str = "output",
) -> Iterator[Path]:
    """:func:`atomic_output` for a directory: yield a path beside ``path`` to create and fill.

    The yielded path does not exist yet (the caller creates it, e.g. a library that insists on
    a new directory); it lies in a temporary directory ``.<name>.*.partial`` beside ``path``. On
    success it replaces ``path``; on an exception the temporary directory is removed and
    ``path`` is left as it was.

    A non-empty ``path`` found at the end (it may have appeared while the directory was being
    written: another run writing the same one) is replaced only with ``overwrite`` and when
    ``replaceable(path)`` returns None (see :func:`check_output_dir`); it is moved aside first
    and removed only after the rename. Without ``overwrite`` the rename itself refuses it
    (a directory is never renamed onto a non-empty one), with a :class:`UsageError`: the
    other run's directory is kept, this one is discarded.
    """
    import shutil

    dest = Path(path)
    parent = dest.parent if str(dest.parent) else Path(".")
    with _naming(dest):
        holder = Path(tempfile.mkdtemp(prefix=f".{dest.name}.", suffix=".partial", dir=parent))
    new = holder / dest.name
    old: Path | None = None
    appeared = UsageError(
        f"{what} {dest} appeared while this one was written (another run writing it?); kept "
        "it and discarded this one; pass --overwrite to replace it"
    )
    try:
        yield new
        if not new.is_dir():
            raise FileNotFoundError(f"{new} was not created")
        if not overwrite:
            try:
                os.rename(new, dest)  # onto a missing or empty directory only
            except OSError as err:
                if err.errno in (errno.ENOTEMPTY, errno.EEXIST, errno.ENOTDIR, errno.EISDIR):
                    raise appeared from None
                raise
            return
        if dest.is_dir() and any(dest.iterdir()):
            reason = replaceable(dest) if replaceable is not None else None
            if reason:
                raise UsageError(f"{what} {dest}: {reason}; refusing to replace it")
            old = holder / ".old"
            os.replace(dest, old)
        try:
            os.replace(new, dest)  # onto a missing or empty directory
        except BaseException:
            if old is not None:
                os.replace(old, dest)
            raise
    finally:
        with signals_held():  # a second Ctrl+C does not leave half of it behind
            shutil.rmtree(holder, ignore_errors=True)


@contextlib.contextmanager
def created_parents(path: str | os.PathLike[str]) -> Iterator[None]:
    """Create the missing parent directories of ``path`` (``lfd export -o a/b/ds`` makes
    ``a/b``); if the block fails, remove again those it created that are still empty."""
    made: list[Path] = []
    parent = Path(os.path.abspath(path)).parent
    while not parent.exists():
        made.append(parent)
        parent = parent.parent
    try:
        for d in reversed(made):
            d.mkdir(exist_ok=True)
        yield
    except BaseException:
        for d in made:  # innermost first
            with contextlib.suppress(OSError):
                d.rmdir()
        raise
