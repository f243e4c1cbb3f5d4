"""``lfd label REC.mcap --from seg.json``: write ground-truth skill labels into a recording."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ..demo import SkillLabel

NAME = "label"
HELP = (
    "Write ground-truth skill labels (an edited `lfd segment --json` file, or a CSV/JSON of "
    "skill,start_s,end_s,object,hand) into a recording, replacing its old ones; a two-hand "
    "recording takes labels per hand and its handovers."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("recording", help="an lfd MCAP recording (rewritten in place unless -o)")
    parser.add_argument(
        "--from",
        dest="labels",
        required=True,
        metavar="FILE",
        help="labels: the JSON `lfd segment REC --json FILE` writes (edit it to correct it; "
        "a two-hand one too, with its handovers), a JSON list of {skill, start_s, end_s, "
        "object, hand}, or a .csv with those columns; seconds count from the JSON's origin_ns, "
        "else from the recording's first sample; in a two-hand recording each label names its "
        "hand (docs/own-recordings.md)",
    )
    parser.add_argument(
        "-o",
        "--output",
        metavar="OUT.mcap",
        help="write the labelled copy here instead of replacing the recording",
    )
    from ._options import add_recording_arguments

    add_recording_arguments(parser, ros=False)  # labels are written into an lfd recording


def run(args: argparse.Namespace) -> int:

    from ..io import load
    from ..io.labels import read_annotations, write_labels
    from ..outputs import check_output, same_file
    from ._options import check_inputs, load_options, make_console, read_files

    check_inputs(**{"from": args.labels})
    if args.output is not None and same_file(args.output, args.recording):
        args.output = None  # -o the recording itself: rewritten in place
    if args.output is not None:
        reads = read_files(args, args.recording)
        check_output(args.output, inputs=reads, what="-o/--output", suffixes=(".mcap",))
    else:  # the recording is the output: the label file (and its sidecar) may not be it
        check_output(args.recording, inputs=read_files(args), what="the recording")
    demo = load(args.recording, images=False, **load_options(args))
    labels, handovers = read_annotations(args.labels, demo)
    dest = write_labels(args.recording, labels, args.output, handovers)
    origin = demo.start_ns

    def listed(lane: list[SkillLabel]) -> str:
        return ", ".join(
            f"{lab.skill}{'(' + lab.object + ')' if lab.object else ''} "
            f"{(lab.start_ns - origin) * 1e-9:.2f}-{(lab.end_ns - origin) * 1e-9:.2f}"
            for lab in lane
        )

    con = make_console()
    if len(demo.sides) == 1:
        con.print(
            f"wrote {len(labels)} labels into {dest}: {listed(labels)} (s from the "
            "recording's first sample)"
        )
        return 0
    con.print(f"wrote {len(labels)} labels into {dest} (s from the recording's first sample):")
    for side in demo.sides:
        con.print(f"  {side} hand: {listed([lab for lab in labels if lab.hand == side])}")
    if handovers is not None:
        con.print(
            f"  {len(handovers)} handovers: "
            + ", ".join(
                f"{h.giver} to {h.taker}{'(' + h.object + ')' if h.object else ''} "
                f"{(h.start_ns - origin) * 1e-9:.2f}-{(h.end_ns - origin) * 1e-9:.2f}"
                for h in handovers
            )
        )
    return 0
