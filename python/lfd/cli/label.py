"""``lfd label REC.mcap --from seg.json``: write ground-truth skill labels into a recording."""

from __future__ import annotations

import argparse

NAME = "label"
HELP = (
    "Write ground-truth skill labels (an edited `lfd segment --json` file, or a CSV/JSON of "
    "skill,start_s,end_s,object) into a recording, replacing its old ones."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("recording", help="an lfd MCAP recording (rewritten in place unless -o)")
    parser.add_argument(
        "--from",
        dest="labels",
        required=True,
        metavar="FILE",
        help="labels: the JSON `lfd segment REC --json FILE` writes (edit it to correct it), a "
        "JSON list of {skill, start_s, end_s, object}, or a .csv with those columns; seconds "
        "count from the JSON's origin_ns, else from the recording's first sample",
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
    from rich.console import Console

    from ..io import load
    from ..io.labels import read_labels, write_labels
    from ..outputs import check_output, same_file
    from ._options import check_inputs, load_options, read_files

    check_inputs(**{"from": args.labels})
    if args.output is not None and same_file(args.output, args.recording):
        args.output = None  # -o the recording itself: rewritten in place
    if args.output is not None:
        reads = read_files(args, args.recording)
        check_output(args.output, inputs=reads, what="-o/--output", suffixes=(".mcap",))
    else:  # the recording is the output: the label file (and its sidecar) may not be it
        check_output(args.recording, inputs=read_files(args), what="the recording")
    demo = load(args.recording, images=False, **load_options(args))
    labels = read_labels(args.labels, demo)
    dest = write_labels(args.recording, labels, args.output)
    origin = demo.start_ns
    Console().print(
        f"wrote {len(labels)} labels into {dest}: "
        + ", ".join(
            f"{lab.skill}{'(' + lab.object + ')' if lab.object else ''} "
            f"{(lab.start_ns - origin) * 1e-9:.2f}-{(lab.end_ns - origin) * 1e-9:.2f}"
            for lab in labels
        )
        + " (s from the recording's first sample)"
    )
    return 0
