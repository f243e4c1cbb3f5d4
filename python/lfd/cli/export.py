"""``lfd export lerobot DIR_OR_FILES -o DATASET_DIR``: recordings out as a LeRobot dataset."""

from __future__ import annotations

import argparse
import sys

NAME = "export"
HELP = "Export recordings to other tools' formats (a LeRobot dataset, one episode per recording)."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="format", metavar="FORMAT", required=True)
    lr = sub.add_parser(
        "lerobot",
        help="a LeRobot dataset: one episode per recording, skill labels frame by frame "
        "(docs/export.md)",
        description="Write a LeRobot dataset (lerobot 0.4.4 format) with one episode per "
        "recording: hand keypoints, gripper and object poses at 30 Hz, the skill and object of "
        "every frame, the task program in meta/lfd_program.json, colour frames as video.",
    )
    lr.add_argument("inputs", nargs="+", help="directories (every *.mcap in them) or .mcap files")
    lr.add_argument(
        "-o", "--output", required=True, metavar="DATASET_DIR", help="dataset directory to write"
    )
    lr.add_argument(
        "--overwrite",
        action="store_true",
        help="replace DATASET_DIR when it is not empty (only a LeRobot dataset: a directory "
        "holding anything else is never deleted)",
    )
    lr.add_argument(
        "--labels",
        choices=("auto", "ground-truth", "segment"),
        default="auto",
        help="skill labels from the recording's ground truth or from lfd's segmentation "
        "(default auto: the ground truth when there is one)",
    )
    lr.add_argument(
        "--templates", metavar="FILE", help="templates for --labels segment (default: shipped)"
    )
    lr.add_argument(
        "--repo-id", metavar="OWNER/NAME", help="the dataset's repo_id (default lfd/DATASET_DIR)"
    )
    lr.add_argument(
        "--no-video", action="store_true", help="leave the recordings' colour images out"
    )
    from ._options import add_batch_options

    add_batch_options(lr)  # reading and labelling the recordings; the dataset is written in order
    lr.add_argument(
        "--vcodec",
        choices=("libsvtav1", "h264"),
        default="libsvtav1",
        help="video codec of the colour frames (default libsvtav1, lerobot's)",
    )


def run(args: argparse.Namespace) -> int:
    from ._options import batch_options, check_inputs, sigterm_interrupts

    check_inputs(templates=args.templates)
    from ..export.lerobot import RecordingResult, export_lerobot

    def show(r: RecordingResult) -> None:
        if r.error is not None:
            print(f"lfd export: error: {r.error} (skipped)", file=sys.stderr)
        else:
            print(
                f"{r.recording}: episode {r.episode_index}, {r.frames} frames, "
                f"{r.labels} labels, {r.seconds:.1f} s"
            )

    with sigterm_interrupts():  # SIGTERM, as Ctrl+C: no temporary dataset left behind
        report = export_lerobot(
            args.inputs,
            args.output,
            labels=args.labels,
            overwrite=args.overwrite,
            repo_id=args.repo_id,
            video=not args.no_video,
            vcodec=args.vcodec,
            method=args.templates,  # read there: an input the dataset may not replace
            on_result=show,
            **batch_options(args),
        )
    failed = len(report.failed)
    print(
        f"{report.root}: {len(report.exported)} episode(s), "
        f"{sum(r.frames for r in report.exported)} frames"
        + (f", {failed} recording(s) skipped" if failed else "")
        + f" ({report.seconds:.1f} s)"
    )
    return 1 if failed else 0
