"""``lfd eval DIR_OR_FILES``: compare the segmentation methods on labelled recordings."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any, get_args

from ._options import (
    add_batch_options,
    add_json_argument,
    add_recording_arguments,
    check_inputs,
    check_json,
    console,
    emit_json,
    load_options,
)

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
    loo = parser.add_argument_group("leave-one-out (your own labelled recordings)")
    loo.add_argument(
        "--leave-one-out",
        action="store_true",
        help="segment each recording with templates trained on all the others (adapted from "
        "--base, else made the way --templates FILE was made, else trained from scratch)",
    )
    loo.add_argument(
        "--base",
        metavar="default|FILE",
        help="with --leave-one-out: adapt this template set (the shipped one: default) to the "
        "other recordings, instead of training from scratch",
    )
    add_recording_arguments(parser, ros=False)  # ROS bags carry no ground truth
    from ._rerun import add_rerun_arguments

    add_rerun_arguments(parser)  # shows one recording: every method's lane beside the truth
    add_batch_options(parser)  # the recordings in parallel (not --leave-one-out's folds)


def _fmt(k: str, v: float) -> str:
    if not math.isfinite(v):
        return "-"
    if k == "sequence_match":
        return f"{v:.0f}"
    if k in ("boundary_error_s", "segment_ratio"):
        return f"{v:.3f}"
    return f"{100 * v:.1f}" if k != "edit_distance" else f"{v:.3f}"


def run(args: argparse.Namespace) -> int:
    from rich.progress import Progress

    from ..errors import UsageError
    from ..segmentation import Method
    from ..segmentation.evaluate import (
        TEMPLATE_METHODS,
        check_methods,
        evaluate,
        expand_paths,
        leave_one_out,
    )
    from ._options import batch_options
    from ._rerun import check_rerun_args, close_from_args, open_from_args

    methods = check_methods([m.strip() for m in args.methods.split(",") if m.strip()])
    if args.leave_one_out and not set(methods) & TEMPLATE_METHODS:
        raise UsageError(
            f"--leave-one-out trains templates: --methods needs one of {', '.join(TEMPLATE_METHODS)}"
        )
    paths = expand_paths(args.inputs)
    if not paths:
        raise UsageError(f"no .mcap recordings in {' '.join(args.inputs)}")
    inputs = [*paths, *([args.templates] if args.templates else [])]
    check_json(args, inputs)
    check_rerun_args(args, inputs)
    con = console(args)
    if args.base is not None and not args.leave_one_out:
        raise UsageError("--base adapts templates for --leave-one-out; add --leave-one-out")
    rerun = ("rerun", "rerun_save", "rerun_connect", "rerun_serve")
    if args.leave_one_out and any(getattr(args, a, None) for a in rerun):
        raise UsageError("--rerun* shows one recording's methods; drop it with --leave-one-out")
    if args.base is not None and args.base != "default":
        check_inputs(base=args.base)
    sizes = load_options(args)["object_sizes"]
    given = Method.load(args.templates) if args.templates else None
    method = (given or Method.default()).with_options(grammar=args.grammar)
    base, base_name = _base(args, given) if args.leave_one_out else (None, "")
    batch = batch_options(args)
    if args.leave_one_out and batch["ray_address"] is not None:
        raise UsageError("--ray runs the recordings of a plain eval; drop it with --leave-one-out")
    failed: dict[str, str] = {}
    if open_from_args(args, "lfd_eval"):
        _show(paths, methods, method, con, sizes)
    from rich.console import Console

    stderr = Console(stderr=True)
    with Progress(console=stderr, transient=True, disable=not stderr.is_terminal) as progress:
        total = 2 * len(paths) if args.leave_one_out else len(paths)
        task = progress.add_task("evaluating", total=total)

        def step(name: str) -> None:
            progress.update(task, advance=1, description=name)

        if args.leave_one_out:
            report = leave_one_out(
                paths,
                base=base,
                base_name=base_name,
                methods=[m for m in methods if m in TEMPLATE_METHODS],
                method=method,
                progress=step,
                object_sizes=sizes,
            )
        else:
            report = evaluate(
                paths,
                method=method,
                methods=methods,
                progress=step,
                object_sizes=sizes,
                failed=failed,
                **batch,
            )
    for path, message in failed.items():
        print(f"lfd eval: error: {path}: {message}", file=sys.stderr)
    if not report.recordings and failed:
        return 2
    if not report.recordings:
        raise UsageError(
            f"none of the {len(paths)} recordings has ground-truth skill labels to evaluate against"
        )
    if args.leave_one_out:
        how = f"adapted from {base_name}" if base is not None else "trained from scratch"
        con.print(f"leave-one-out: each recording segmented by templates {how} on the others")
        _per_recording(report, con)
    _print_report(report, con)
    close_from_args(args)
    doc = report.to_dict()
    if failed:  # only a batch with failures has the key: a complete run's document is as before
        doc["failed"] = [{"recording": p, "error": m} for p, m in failed.items()]
    emit_json(args, doc, con)
    if failed:
        print(
            f"lfd eval: {len(paths) - len(failed)} of {len(paths)} recordings evaluated; "
            f"{len(failed)} failed",
            file=sys.stderr,
        )
    return 2 if failed else 0


def _print_report(report: Any, con: Any) -> None:
    """The recordings left out, a table of the metrics per task and overall, and each
    method's errors (warnings on stderr)."""
    from rich.table import Table

    from ..segmentation.metrics import METRIC_NAMES

    for r in report.recordings:
        note = r.excluded_note()
        if note is not None:
            con.print(note, highlight=False, soft_wrap=True)
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
    _print_hands(report, con)
    for r in report.recordings:
        for m, err in r.errors.items():
            print(f"lfd eval: warning: {r.name} {m}: {' '.join(str(err).split())}", file=sys.stderr)


def _print_hands(report: Any, con: Any) -> None:
    """With two-hand recordings: a table per hand (segment count ratio too) and the
    handovers found, missed and false per method."""
    from rich.table import Table

    from ..segmentation.metrics import METRIC_NAMES

    keys = [*METRIC_NAMES, "segment_ratio"]
    for side, summary in report.hands_summary().items():
        n = int(next(iter(summary.values()))["n"])
        table = Table(title=f"{side} hand ({n} two-hand recordings)")
        table.add_column("method")
        for k in keys:
            table.add_column(k.replace("_", " "), justify="right")
        for m, vals in summary.items():
            table.add_row(m, *(_fmt(k, vals[k]) for k in keys))
        con.print(table)
    for m, h in report.handover_summary().items():
        con.print(
            f"handovers, {m}: {int(h['found'])}/{int(h['true'])} found within 0.3 s, "
            f"{int(h['false'])} false",
            highlight=False,
        )


def _show(
    paths: list[Path],
    methods: tuple[str, ...],
    method: Any,
    console: Any,
    object_sizes: Any = None,
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

    demo = load(paths[0], object_sizes=object_sizes)
    log_recorded_demo(demo, trajectory=False)  # log_methods logs the segmented one
    log_methods(demo, methods, method=method)


def _base(args: argparse.Namespace, given: Any) -> tuple[Any, str]:
    """The template set --leave-one-out adapts (None: train from scratch) and its name
    (``given``: the method of --templates FILE, or None)."""
    from ..errors import UsageError
    from ..segmentation import Method, Templates

    name = args.base
    if name is None and given is not None:  # made the way --templates FILE was made
        name = given.templates.meta.get("adapted_from")
        if name is not None and name != "default" and not Path(name).is_file():
            raise UsageError(
                f"--templates {args.templates} was adapted from {name}, which does not exist "
                "here; give --base default|FILE"
            )
    if name is None:
        return None, ""
    return (Templates.default() if name == "default" else Method.load(name).templates), str(name)


def _per_recording(report: Any, con: Any) -> None:
    from rich.table import Table

    table = Table(title="leave-one-out: each recording with templates from the others")
    for col in ("recording", "method", "frame accuracy", "exact sequence", "boundary error s"):
        table.add_column(col, justify="left" if col in ("recording", "method") else "right")
    for r in report.recordings:
        for m, v in r.metrics.items():
            table.add_row(
                r.name,
                m,
                _fmt("frame_accuracy", v["frame_accuracy"]),
                "yes" if v["sequence_match"] else "no",
                _fmt("boundary_error_s", v["boundary_error_s"]),
            )
    con.print(table)
