"""The ``lfd`` command line. Each subcommand lives in its own module under ``lfd.cli``.

A command module defines ``NAME``, ``HELP``, ``add_arguments(parser)`` and ``run(args) -> int``;
register it in :data:`COMMANDS`. Heavy imports belong inside ``run`` so ``lfd --help`` is fast.

The error contract (see docs/cli.md): results go to stdout, everything else to stderr; a
user-caused error is one line, ``lfd <command>: error: <message>``, with exit status 2; a
warning is one line, ``lfd <command>: warning: <message>``; Ctrl+C exits with 130.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
import warnings
from collections.abc import Sequence
from typing import NoReturn

from .._extras import message_for
from ..errors import LfdError, LfdWarning

COMMANDS: tuple[str, ...] = (
    # one module name per subcommand, in help order
    "info",
    "simulate",
    "segment",
    "label",
    "import_",
    "templates",
    "eval",
    "reproduce",
    "record",
    "perception",
    "export",
)

PREFERRED_EXTRAS: dict[str, tuple[str, ...]] = {
    # a missing module several extras install is reported as the one this command is about
    "simulate": ("sim",),
    "reproduce": ("sim",),
    "record": ("sim", "perception"),
    "perception": ("perception", "sim"),
    "export": ("lerobot",),
}


class _Parser(argparse.ArgumentParser):
    """An argument parser whose usage errors are one line: ``lfd <cmd>: error: ... (see ...)``.

    The prefix is the command's, as every other error of it (``lfd export: error: ...``, also
    for ``lfd export robot-data``); the help named is the subcommand's own."""

    def error(self, message: str) -> NoReturn:
        command = " ".join(self.prog.split()[:2])  # lfd export robot-data -> lfd export
        self.exit(2, f"{command}: error: {message} (see {self.prog} --help)\n")


class _Version(argparse.Action):
    """``--version``: the installed package's version, looked up only when asked for."""

    def __call__(self, parser, namespace, values, option_string=None):  # type: ignore[no-untyped-def]
        from .._version import __version__

        print(f"lfd {__version__}")
        parser.exit(0)


def build_parser(only: str | None = None) -> argparse.ArgumentParser:
    """The ``lfd`` parser; with ``only`` (a subcommand's name) the other subcommands are listed
    without their options (what ``main`` builds for one command: their options import what
    those commands need, e.g. the simulator's task names)."""
    parser = _Parser(
        prog="lfd",
        description="Learn a robot manipulation task from a human hand demonstration.",
        allow_abbrev=False,
    )
    parser.add_argument("--version", action=_Version, nargs=0, help="print the version and exit")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    for name in COMMANDS:
        mod = importlib.import_module(f"{__name__}.{name}")
        # options are never abbreviated: `--out` is not silently `--output`
        p = sub.add_parser(mod.NAME, help=mod.HELP, description=mod.HELP, allow_abbrev=False)
        if only is None or only == mod.NAME:
            mod.add_arguments(p)
        p.set_defaults(_run=mod.run)
        _mark_leaves(p)
    return parser


def _mark_leaves(parser: argparse.ArgumentParser) -> None:
    """Record in each (sub)command's defaults the parser that reports its usage errors."""
    parser.set_defaults(_parser=parser)
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for child in action.choices.values():
                child.allow_abbrev = False
                _mark_leaves(child)


def _warning_printer(command: str):  # type: ignore[no-untyped-def]
    """A ``warnings.showwarning`` that prints ``lfd <command>: warning: <message>``, one line."""

    def show(message, category, filename, lineno, file=None, line=None):  # type: ignore[no-untyped-def]
        text = " ".join(str(message).split())
        print(f"lfd {command}: warning: {text}", file=sys.stderr if file is None else file)

    return show


def _one_line(err: BaseException) -> str:
    return " ".join(str(err).split()) or type(err).__name__


def _one_malloc_arena() -> None:
    """One glibc malloc arena for the process (``mallopt(M_ARENA_MAX, 1)``, what
    ``MALLOC_ARENA_MAX=1`` does): otherwise each of the engine's worker threads keeps an arena of
    its own whose freed blocks stay resident, about 50 MB more peak memory on an hour's
    recording, for no speed (``benches/load_speed.py``). Takes effect only before a second
    thread allocates, so first thing in :func:`main`, for ``lfd segment``; nothing where the C
    library is not glibc."""
    if not sys.platform.startswith("linux"):
        return
    import ctypes

    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):  # pragma: no cover - not glibc
        return
    m_arena_max = -8
    mallopt(ctypes.c_int(m_arena_max), ctypes.c_int(1))


def main(argv: Sequence[str] | None = None) -> int:
    args_in = list(sys.argv[1:] if argv is None else argv)
    first = next((a for a in args_in if not a.startswith("-")), None)
    if first == "segment":  # measured there; the perception commands allocate from many threads
        _one_malloc_arena()
    parser = build_parser(first if first is not None and args_in[0] == first else None)
    args, extra = parser.parse_known_args(args_in)
    if extra:  # reported by the subcommand's parser: `lfd segment: error: unrecognized ...`
        getattr(args, "_parser", parser).error(f"unrecognized arguments: {' '.join(extra)}")
    if not hasattr(args, "_run"):
        parser.print_help()
        return 0
    command = args.command
    with warnings.catch_warnings():
        # lfd's own warnings are the command's output, one line each, whatever filters the
        # caller (a test run with warnings as errors, python -W error) has set
        warnings.simplefilter("default", LfdWarning)
        warnings.showwarning = _warning_printer(command)
        return _run(args, command)


def _run(args: argparse.Namespace, command: str) -> int:
    """Run a parsed command: its exit status, every error one line (see the module docs)."""
    try:
        status = int(args._run(args) or 0)
        if sys.stdout is not None:  # None: started with stdout closed (``>&-``)
            sys.stdout.flush()  # a closed pipe shows here, not in the interpreter's exit
        return status
    except LfdError as err:
        print(f"lfd {command}: error: {_one_line(err)}", file=sys.stderr)
        return 2
    except ModuleNotFoundError as err:
        # a module of an optional extra (lfd._extras.EXTRAS): one line saying what to install
        line = message_for(err.name or "", PREFERRED_EXTRAS.get(command, ()))
        if line is None:
            raise
        print(f"lfd {command}: error: {line}", file=sys.stderr)
        return 2
    except BrokenPipeError:
        # the reader of stdout went away (``lfd info x.mcap --json - | head -1``): stop quietly;
        # point stdout at devnull so the interpreter's final flush does not fail again
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 141
    except OSError as err:
        # a user path that cannot be read or written (missing, permission denied, disk full)
        where = f"{err.filename}: " if err.filename else ""
        what = err.strerror or _one_line(err)
        print(f"lfd {command}: error: {where}{what}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"lfd {command}: interrupted", file=sys.stderr)
        return 130
    finally:
        if "lfd.cli._rerun" in sys.modules:  # imported by every command with --rerun* options
            # a session still open here belongs to a command that failed: no --rerun-save file
            sys.modules["lfd.cli._rerun"].abort_from_args(args)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
