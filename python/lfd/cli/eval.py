"""``lfd eval DIR_OR_FILES``: compare the segmentation methods on labelled recordings."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any, get_args

from ._options import add_json_argument, check_json, console, json_to_stdout, write_json

if TYPE_CHECKING:
    from ..segmentation.pipeline import GrammarUse

NAME = "eval"
HELP = "Evaluate lfd's default (dp), the paper's method and three baselines against ground truth."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("inputs", nargs="+", help="directories or .mcap files with skill labels")
    parser.add_argument("--templates", metavar="FILE", help="template file (default: shipped)")
    add_json_argument(parser, "the full report")
    from ..segmentation.evaluate import DEFAULT_METHODS, METHODS
    from ..segmentation.pipeline import DEFAULT_GRAMMAR, GrammarUse

    parser.add_argument(
        "--methods",
        default=",".join(DEFAULT_METHODS),
        metavar="M,M,...",
        help=f"comma-separated methods from {', '.join(METHODS)} "
        f"(default {','.join(DEFAULT_METHODS)}; dp is lfd's default, paper = greedy + warn)",
    )
    parser.add_argument(
        "--grammar",
        choices=get_args(GrammarUse),
        default=DEFAULT_GRAMMAR,
        help=f"grammar use of the dp and greedy methods (default {DEFAULT_GRAMMAR})",
    )
    from ..viz.cli import add_rerun_arguments

    add_rerun_arguments(parser)  # shows one recording: every method's lane beside the truth


def _fmt(k: str, v: float) -> str:
    if not math.isfinite(v):
        return "-"
    if k == "sequence_match":
        return f"{v:.0f}"
    if k in ("boundary_error_s",):
        return f"{v:.3f}"
    return f"{100 * v:.1f}" if k != "edit_distance" else f"{v:.3f}"


def run(args: argparse.Namespace) -> int:
    from rich.progress import Progress
    from rich.table import Table

    from ..errors import UsageError
    from ..segmentation import Templates
    from ..segmentation.evaluate import check_methods, evaluate, expand_paths
    from ..segmentation.metrics import METRIC_NAMES
    from ..viz.cli import check_rerun_args, close_from_args, open_from_args

    methods = check_methods([m.strip() for m in args.methods.split(",") if m.strip()])
    paths = expand_paths(args.inputs)
    if not paths:
        raise UsageError(f"no .mcap recordings in {' '.join(args.inputs)}")
    inputs = [*paths, *([args.templates] if args.templates else [])]
    check_json(args, inputs)
    check_rerun_args(args, inputs)
    con = console(args)
    templates = Templates.load(args.templates) if args.templates else None
    if open_from_args(args, "lfd_eval"):
        _show(paths, methods, templates, args.grammar, con)
    with Progress(console=con, transient=True) as progress:
        task = progress.add_task("evaluating", total=len(paths))
        report = evaluate(
            paths,
            templates=templates,
            methods=methods,
            grammar=args.grammar,
            progress=lambda name: progress.update(task, advance=1, description=name),
        )
    if not report.recordings:
        raise UsageError(
            f"none of the {len(paths)} recordings has ground-truth skill labels to evaluate against"
        )
    for title, task_name in [*((t, t) for t in report.tasks()), ("overall", None)]:
        summary = report.summary(task_name)
        n = int(next(iter(summary.values()))["n"])
        table = Table(title=f"{title} ({n} recordings)")
        table.add_column("method")
        for k in METRIC_NAMES:
            table.add_column(k.replace("_", " "), justify="right")
        for m, vals in summary.items():
            table.add_row(m, *(_fmt(k, vals[k]) for k in METRIC_NAMES))
        con.print(table)
    for r in report.recordings:
        for m, err in r.errors.items():
            print(f"lfd eval: warning: {r.name} {m}: {' '.join(str(err).split())}", file=sys.stderr)
    close_from_args(args)
    if args.json:
        write_json(args.json, report.to_dict())
        if not json_to_stdout(args):
            con.print(f"wrote {args.json}")
    return 0


def _show(
    paths: list[Path],
    methods: tuple[str, ...],
    templates: Any,
    grammar: GrammarUse,
    console: Any,
) -> None:
    """Log one recording and every method's result to the open Rerun session."""
    if len(paths) != 1:
        print(
            f"lfd eval: warning: --rerun* shows a single recording; got {len(paths)}",
            file=sys.stderr,
        )
        return
    from ..io import load
    from ..viz.pipeline import log_methods, log_recorded_demo

    demo = load(paths[0])
    traj = log_recorded_demo(demo, features=False)  # log_methods logs them
    log_methods(demo, methods, templates=templates, trajectory=traj, grammar=grammar)
