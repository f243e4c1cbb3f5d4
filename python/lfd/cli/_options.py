"""Options shared by several subcommands (not a subcommand itself)."""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import os
from collections.abc import Iterable, Iterator, Sequence
from typing import Any, get_args


def add_segmentation_arguments(parser: argparse.ArgumentParser, *, used_with: str = "") -> None:
    """``--search``, ``--grammar`` and ``--paper``: the stage-2 options of :func:`lfd.segment`.

    The defaults are the most accurate method (segmental DP under the grammar); ``--paper``
    selects the paper's algorithm (greedy cut loop, grammar warnings). Read the chosen values with
    :func:`segmentation_method`.
    """
    from ..segmentation.pipeline import DEFAULT_GRAMMAR, DEFAULT_SEARCH, GrammarUse, Search

    when = f" {used_with}" if used_with else ""
    group = parser.add_argument_group("segmentation method")
    group.add_argument(
        "--search",
        choices=get_args(Search),
        default=None,
        help=f"stage-2 search{when}: dp = optimal segmental DP (default), greedy = the paper's loop",
    )
    group.add_argument(
        "--grammar",
        choices=get_args(GrammarUse),
        default=None,
        help=f"skill grammar{when}: enforce it (default), warn about impossible transitions, or off",
    )
    group.add_argument(
        "--paper",
        action="store_true",
        help=f"the paper's algorithm{when}: --search greedy --grammar warn "
        f"(default: --search {DEFAULT_SEARCH} --grammar {DEFAULT_GRAMMAR})",
    )


def segmentation_method(args: argparse.Namespace) -> Any:
    """The :class:`lfd.Method` chosen by :func:`add_segmentation_arguments`'s options and
    ``--templates`` (a file, with the method saved in it, wins over the set ``--paper``
    selects; ``--search`` / ``--grammar`` override the method's)."""
    from ..errors import UsageError
    from ..segmentation import Method
    from ..segmentation.pipeline import PAPER_GRAMMAR, PAPER_SEARCH

    given = getattr(args, "templates", None)
    if args.paper:
        if args.search not in (None, PAPER_SEARCH) or args.grammar not in (None, PAPER_GRAMMAR):
            raise UsageError(
                f"--paper means --search {PAPER_SEARCH} --grammar {PAPER_GRAMMAR}; "
                "drop --paper to choose other values"
            )
        paper = Method.paper()
        if given:  # the file's templates (and its whole method checked), the paper's method
            return dataclasses.replace(
                paper, name=str(given), templates=Method.load(given).templates
            )
        return paper
    method = Method.load(given)
    return method.with_options(search=args.search, grammar=args.grammar)


# --- outputs: one vocabulary (-o/--output FILE, --json OUT|-) -------------------------------
def add_json_argument(parser: argparse.ArgumentParser, what: str = "the result") -> None:
    """``--json OUT``: write ``what`` as JSON to OUT, ``-`` for standard output."""
    parser.add_argument(
        "--json",
        metavar="OUT",
        help=f"write {what} as JSON to OUT ('-': standard output, the tables then go to stderr)",
    )


def json_to_stdout(args: argparse.Namespace) -> bool:
    """Whether ``--json -`` asked for JSON on standard output (human output then goes to stderr)."""
    from ..outputs import STDOUT

    return getattr(args, "json", None) == STDOUT


UNBOUNDED_WIDTH = 100_000
"""Width of a console writing to a file or a pipe: as wide as the output (rich lays tables out
at their natural width), so a long topic name or path is never cut to ``…`` or folded."""


def make_console(*, stderr: bool = False) -> Any:
    """A rich console for the human-readable output. In a terminal it fits the terminal; into
    a file or a pipe (``lfd info REC > info.txt``) it cuts and wraps nothing (unless the
    ``COLUMNS`` environment variable sets a width)."""
    from rich.console import Console

    con = Console(stderr=stderr)
    if not con.is_terminal and "COLUMNS" not in os.environ:
        con = Console(stderr=stderr, width=UNBOUNDED_WIDTH)
    return con


def console(args: argparse.Namespace) -> Any:
    """The console of a command's human-readable output (:func:`make_console`): stdout, or
    stderr under ``--json -``."""
    return make_console(stderr=json_to_stdout(args))


MAX_TABLE_ROWS = 40
"""Rows of a long table (skills of an hour-long recording) printed in the terminal; ``--json``
has every one."""


def capped(rows: Sequence[Any], skills: Iterable[str]) -> tuple[Sequence[Any], str | None]:
    """The first :data:`MAX_TABLE_ROWS` of ``rows`` and, when some are left out, a line that
    says how many and counts every row's skill (``skills``, one per row)."""
    if len(rows) <= MAX_TABLE_ROWS:
        return rows, None
    from collections import Counter

    counts = Counter(skills).most_common()
    return rows[:MAX_TABLE_ROWS], (
        f"... and {len(rows) - MAX_TABLE_ROWS} more ({len(rows)} in all: "
        + ", ".join(f"{n} {skill}" for skill, n in counts)
        + "; --json lists every one)"
    )


INPUT_OPTIONS = ("templates", "map", "labels", "base", "task", "intrinsics", "depth", "init",
                 "hand_model")  # fmt: skip
"""Options (``args`` attributes) that name files a command reads, where it has them."""


def read_files(args: argparse.Namespace, *given: Any) -> list[Any]:
    """Every path a command reads, for :func:`lfd.outputs.check_output`'s ``inputs``: ``given``
    (its recordings, bags, images...; None skipped) and the existing paths its
    :data:`INPUT_OPTIONS` name (``--templates``, ``--map``, ``--from`` ...), with their
    sidecars and bag directories (:func:`lfd.io.reads.read_paths`)."""
    from ..io.reads import read_paths

    out = list(given)
    for option in INPUT_OPTIONS:
        value = getattr(args, option, None)
        for v in value if isinstance(value, (list, tuple)) else [value]:
            if isinstance(v, (str, os.PathLike)) and os.path.exists(v):
                out.append(os.fspath(v))
    return read_paths(out)


def check_json(args: argparse.Namespace, inputs: Iterable[str | os.PathLike[str]]) -> None:
    """Refuse an unusable ``--json`` destination before any work (see :func:`check_output`):
    ``inputs`` and every file of :func:`read_files` count as inputs."""
    from ..outputs import check_output

    if getattr(args, "json", None) is not None:
        reads = read_files(args, *inputs)
        check_output(args.json, inputs=reads, what="--json", allow_stdout=True)


@contextlib.contextmanager
def sigterm_interrupts() -> Iterator[None]:
    """While in the block, SIGTERM raises KeyboardInterrupt as Ctrl+C does (in the main
    thread; elsewhere nothing changes): the command cleans up and exits 130."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def on_term(signum: int, frame: Any) -> None:
        raise KeyboardInterrupt

    old = signal.signal(signal.SIGTERM, on_term)
    old_int = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, old)
        signal.signal(signal.SIGINT, old_int)


def json_text(doc: Any) -> str:
    """``doc`` as JSON laid out for reading: a dict a key per line, a list an item per line,
    one level deep, each value on its line compact. (``json.dumps(indent=2)`` takes the pure-
    Python encoder: seconds for the skills of an hour-long recording; this, the C one.)"""
    import json

    def dumps(v: Any) -> str:
        return json.dumps(v, default=str)

    def lines(v: Any, pad: str) -> str:
        if isinstance(v, list) and v:
            return "[\n" + ",\n".join(pad + "  " + dumps(x) for x in v) + "\n" + pad + "]"
        if isinstance(v, dict) and v:
            items = (f"{pad}  {dumps(str(k))}: {lines(x, pad + '  ')}" for k, x in v.items())
            return "{\n" + ",\n".join(items) + "\n" + pad + "}"
        return dumps(v)

    return lines(doc, "")


def write_json(path: str, doc: Any) -> None:
    """Write ``doc`` as JSON (:func:`json_text`) to ``path`` (``-``: stdout), atomically."""
    from ..outputs import atomic_write_text

    atomic_write_text(path, json_text(doc))


def emit_json(args: argparse.Namespace, doc: Any, con: Any) -> None:
    """Write ``doc`` to ``--json`` when given, and say where on ``con`` (not under ``--json -``)."""
    if getattr(args, "json", None):
        write_json(args.json, doc)
        if not json_to_stdout(args):
            con.print(f"wrote {args.json}")


def check_inputs(**named: str | os.PathLike[str] | None) -> None:
    """Refuse input files that do not exist, before heavy imports (``--hand-model=path``...)."""
    from ..errors import UsageError
    from ..inputs import check_input_file

    for option, path in named.items():
        if path is None:
            continue
        flag = "--" + option.replace("_", "-")
        check_input_file(path, flag)  # not a FIFO, a device, a directory
        if not os.path.isfile(path):
            raise UsageError(f"{flag} {path} does not exist; give an existing file")


# --- recordings from other tools: --object-size, --map ---------------------------------------
def add_recording_arguments(parser: argparse.ArgumentParser, *, ros: bool = True) -> None:
    """``--object-size NAME=X,Y,Z`` (repeatable) and, with ``ros``, ``--map MAP.toml``: how
    :func:`lfd.load` reads a file without object sizes or a ROS bag (read them with
    :func:`load_options`)."""
    from ._types import object_size

    group = parser.add_argument_group("recordings from other tools")
    group.add_argument(
        "--object-size",
        action="append",
        type=object_size,
        metavar="NAME=X,Y,Z",
        help="an object's box size in metres, e.g. box_1=0.05,0.05,0.05; wins over the sidecar "
        "REC.sizes.toml and the file's own sizes (an object with none: 0.05 m cube and a "
        "warning); repeatable",
    )
    if ros:
        group.add_argument(
            "--map",
            metavar="MAP.toml",
            help="topic mapping of a ROS bag (.bag, ROS 2 bag directory or .db3, ROS 2 .mcap): "
            "which topics or tf frames are the hand and the objects (docs/ros.md)",
        )


def load_options(args: argparse.Namespace) -> dict[str, Any]:
    """Keyword arguments of :func:`lfd.load` chosen by :func:`add_recording_arguments`'s
    options: ``object_sizes`` and (when the command has ``--map``) ``mapping``. The mapping
    file is read and checked here, before any recording."""
    from ..errors import UsageError

    sizes: dict[str, Any] = {}
    for name, size in getattr(args, "object_size", None) or []:
        if name in sizes:
            raise UsageError(f"--object-size {name}=... is given twice; give each object once")
        sizes[name] = size
    out: dict[str, Any] = {"object_sizes": sizes or None}
    if getattr(args, "map", None) is not None:
        from ..io.ros import read_mapping

        out["mapping"] = read_mapping(args.map)
    return out


# --- many recordings: --jobs N, --ray [ADDRESS] (lfd.batch) ------------------------------------
def add_batch_options(parser: argparse.ArgumentParser) -> None:
    """``--jobs N`` and ``--ray [ADDRESS]``: how a command runs over many recordings
    (:func:`lfd.batch.run_batch`; docs/batch.md). Read them with :func:`batch_options`."""
    from ._types import positive_int

    group = parser.add_argument_group("many recordings (docs/batch.md)")
    group.add_argument(
        "--jobs",
        type=positive_int,
        default=None,
        metavar="N",
        help="recordings processed in parallel, one process each (default: the cores, "
        f"{os.cpu_count()} here; 1: one after the other in this process)",
    )
    group.add_argument(
        "--ray",
        nargs="?",
        const="local",
        default=None,
        metavar="ADDRESS",
        help="run the recordings as Ray tasks: without ADDRESS on a new local Ray instance with "
        "--jobs CPUs, 'auto' or HOST:PORT on a running cluster (recordings are read at the "
        "same path on every node; gives up when nothing answers at HOST:PORT within 15 s); "
        "write --ray=ADDRESS or put --ray after the recordings",
    )


def batch_options(args: argparse.Namespace) -> dict[str, Any]:
    """``jobs`` and ``ray_address`` keyword arguments of :func:`lfd.batch.run_batch` chosen by
    :func:`add_batch_options`'s options."""
    from ..errors import UsageError

    ray = getattr(args, "ray", None)
    if ray is not None and (ray.endswith(".mcap") or os.path.exists(ray)):
        raise UsageError(
            f"--ray took {ray} as the cluster address; put --ray after the recordings "
            "or write --ray=ADDRESS"
        )
    return {"jobs": getattr(args, "jobs", None), "ray_address": ray}


def batch_progress(total: int, description: str) -> Any:
    """One rich progress bar on stderr for a batch of ``total`` recordings (shown only when
    stderr is a terminal). Use as a context manager; call the result with each finished
    :class:`lfd.batch.ItemResult`."""
    import contextlib

    from rich.console import Console
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    con = Console(stderr=True)

    @contextlib.contextmanager
    def bar() -> Any:
        with Progress(
            TextColumn("{task.description}"),
            BarColumn(),
            MofNCompleteColumn(),
            TimeElapsedColumn(),
            TimeRemainingColumn(),
            console=con,
            transient=False,
            disable=not con.is_terminal,
        ) as progress:
            task = progress.add_task(description, total=total)
            failed = [0]

            def step(res: Any) -> None:
                failed[0] += 0 if res.ok else 1
                what = f"{description} ({failed[0]} failed)" if failed[0] else description
                progress.update(task, advance=1, description=what)

            yield step

    return bar()


def report_batch_errors(command: str, results: Iterable[Any], name: Any = str) -> int:
    """Print each failed recording's error as one line, ``lfd <command>: error: NAME: message``,
    and each warning as ``lfd <command>: warning: NAME: message``, in input order; return the
    exit status of the batch: 0 if every recording succeeded, 2 if some failed."""
    import sys

    status = 0
    for res in results:
        for w in res.warnings:
            print(f"lfd {command}: warning: {name(res.item)}: {w}", file=sys.stderr)
        if not res.ok:
            print(f"lfd {command}: error: {name(res.item)}: {res.error}", file=sys.stderr)
            status = 2
    return status
