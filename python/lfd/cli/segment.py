"""``lfd segment rec.mcap``: cut a recording into skills and print them (with ground truth)."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ._options import (
    add_json_argument,
    add_segmentation_arguments,
    check_json,
    console,
    emit_json,
    segmentation_options,
)

NAME = "segment"
HELP = "Segment a recording into skills (two-stage HMM template matching)."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("recording", help="an lfd MCAP recording")
    parser.add_argument("--templates", metavar="FILE", help="template file (default: shipped)")
    add_segmentation_arguments(parser)
    add_json_argument(parser, "the segments (and metrics against the ground truth)")
    from ._rerun import add_rerun_arguments

    add_rerun_arguments(parser)


def segment_recording(
    args: argparse.Namespace, on_loaded: Callable[[Any], Any] | None = None
) -> tuple[Any, Any, dict[str, Any]]:
    """Load, segment and score: returns (demonstration, segmentation, JSON document).

    ``on_loaded(demo)`` is called as soon as the recording is loaded (e.g. to show it).
    """
    from ..io import load
    from ..segmentation import segment

    demo = load(args.recording, images=bool(getattr(args, "rerun_session", None)))
    if on_loaded is not None:
        on_loaded(demo)
    result = segment(demo, **segmentation_options(args))
    return demo, result, result.report(demo.labels, recording=str(args.recording))


def _show_demo(shown: list[Any]) -> Callable[[Any], None]:
    def show(demo: Any) -> None:
        from ..viz.pipeline import log_recorded_demo

        shown.append(log_recorded_demo(demo, features=False))

    return show


def run(args: argparse.Namespace) -> int:
    from rich.table import Table

    from ._rerun import check_rerun_args, close_from_args, open_from_args

    inputs = [p for p in (args.recording, args.templates) if p]
    check_json(args, inputs)
    check_rerun_args(args, inputs)
    show = open_from_args(args, "lfd_segment")
    shown: list[Any] = []  # the trajectory made while showing the demonstration
    demo, result, doc = segment_recording(args, on_loaded=_show_demo(shown) if show else None)
    if show:
        from ..segmentation.templates import resolve_templates
        from ..viz.pipeline import log_segment_run

        opts = segmentation_options(args)
        log_segment_run(
            demo,
            result,
            trajectory=shown[0] if shown else None,
            templates=resolve_templates(opts["templates"]),
            params=opts.get("params"),
            ground_truth=False,  # logged with the demonstration
        )
    con = console(args)
    table = Table(title=f"{Path(args.recording).name}: {result.method} segmentation")
    for col in ("#", "skill", "start s", "end s", "object", "score", "confidence"):
        table.add_column(col, justify="right" if col not in ("skill", "object") else "left")
    for n, s in enumerate(result.segments):
        table.add_row(
            str(n),
            s.skill,
            f"{s.start_s:.2f}",
            f"{s.end_s:.2f}",
            s.object or "-",
            f"{s.score:.2f}",
            f"{s.confidence:.2f}",
        )
    con.print(table)
    if doc["ground_truth"]:
        gt = Table(title="ground truth")
        for col in ("#", "skill", "start s", "end s", "object"):
            gt.add_column(col)
        for n, g in enumerate(doc["ground_truth"]):
            gt.add_row(
                str(n), g["skill"], f"{g['start_s']:.2f}",
                f"{g['end_s']:.2f}", g["object"] or "-",
            )  # fmt: skip
        con.print(gt)
        mt = Table(title="metrics")
        mt.add_column("metric")
        mt.add_column("value", justify="right")
        for k, v in doc["metrics"].items():
            mt.add_row(k, "-" if v is None else f"{v:.3f}")
        con.print(mt)
    for w in result.warnings:
        print(f"lfd segment: warning: {' '.join(str(w).split())}", file=sys.stderr)
    close_from_args(args)
    emit_json(args, doc, con)
    return 0
