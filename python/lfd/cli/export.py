"""``lfd export lerobot DIR_OR_FILES -o DATASET_DIR``: recordings out as a LeRobot dataset;
``lfd export robot-data REC -o DATASET_DIR --layouts N``: robot episodes from one demonstration."""

from __future__ import annotations

import argparse
import sys

NAME = "export"
HELP = (
    "Export recordings to other tools' formats (a LeRobot dataset, one episode per recording; "
    "robot episodes from one demonstration)."
)


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
    add_robot_data(sub)


def run(args: argparse.Namespace) -> int:
    if args.format == "robot-data":
        return run_robot_data(args)
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


def add_robot_data(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """``lfd export robot-data REC -o DIR --layouts N``."""
    from ._types import float_range, layout_count, positive_int, seed

    rd = sub.add_parser(
        "robot-data",
        help="robot episodes from one demonstration: randomised layouts run on the robot, the "
        "successful runs as a LeRobot dataset (docs/export.md)",
        description="Run one demonstration's task program on the simulated robot in N "
        "randomised layouts and write the successful runs as a LeRobot dataset of robot "
        "episodes: joint positions, commanded joints, object poses, a rendered camera, the "
        "skill of every frame as the subtask. Every tried layout and why it failed are in "
        "meta/lfd_layouts.json. Interrupted, the same command continues where it stopped. "
        "With a two-arm --robot (aloha, two_pandas), a two-hand recording on two arms: both "
        "arms' joints, each arm's skill.",
    )
    rd.add_argument(
        "recording",
        help="a one-hand recording (.mcap); a two-hand one with a two-arm --robot",
    )
    rd.add_argument(
        "-o", "--output", required=True, metavar="DATASET_DIR", help="dataset directory to write"
    )
    rd.add_argument(
        "--layouts", type=layout_count, required=True, metavar="N", help="layouts to try"
    )
    rd.add_argument("--seed", type=seed, default=0, help="the layouts' random seed (default 0)")
    rd.add_argument(
        "--robot",
        default="kuka_lwr4",
        metavar="NAME",
        help="the arm (default kuka_lwr4; panda needs robosuite, as lfd reproduce --robot), or "
        "two arms for a two-hand recording: aloha (needs gym-aloha) or two_pandas",
    )
    rd.add_argument("--mode", choices=("skills", "dmp"), default="skills", help="(default skills)")
    rd.add_argument(
        "--labels",
        choices=("ground-truth", "segment"),
        default="ground-truth",
        help="the task program: the recording's labels (default) or lfd's segmentation",
    )
    rd.add_argument(
        "--fps", type=positive_int, default=10, help="frames per second, a divisor of 100 (10)"
    )
    rd.add_argument(
        "--image-size", type=_image_size, default=(160, 120), metavar="WxH", help="(160x120)"
    )
    rd.add_argument(
        "--max-shift", type=float_range(0.0, 0.5), help="largest shift of an object, m (0.10)"
    )
    rd.add_argument(
        "--max-turn", type=float_range(0.0, 180.0), help="largest turn of an object, deg (45)"
    )
    rd.add_argument(
        "--repo-id", metavar="OWNER/NAME", help="the dataset's repo_id (default lfd/DATASET_DIR)"
    )
    rd.add_argument(
        "--overwrite", action="store_true", help="replace DATASET_DIR (a LeRobot dataset only)"
    )
    rd.add_argument(
        "--vcodec", choices=("libsvtav1", "h264"), default="libsvtav1", help="(libsvtav1)"
    )


def _image_size(text: str) -> tuple[int, int]:
    w, sep, h = text.lower().partition("x")
    if not (sep and w.isdigit() and h.isdigit()):
        raise argparse.ArgumentTypeError(f"must be WIDTHxHEIGHT in pixels, got {text!r}")
    return int(w), int(h)


def run_robot_data(args: argparse.Namespace) -> int:
    from ..export.robot_data import LayoutResult, export_robot_data
    from ._options import sigterm_interrupts

    def show(r: LayoutResult, n: int) -> None:
        how = "ok" if r.success else "failed: " + "; ".join(r.failures)
        done = " (done before)" if r.resumed else f", {r.seconds:.1f} s"
        frames = f", {r.frames} frames" if r.success else ""
        print(f"layout {r.index + 1}/{n}: {how}{frames}{done}", flush=True)

    with sigterm_interrupts():  # SIGTERM, as Ctrl+C: the finished layouts are kept
        report = export_robot_data(
            args.recording,
            args.output,
            layouts=args.layouts,
            seed=args.seed,
            mode=args.mode,
            labels=args.labels,
            fps=args.fps,
            image_size=args.image_size,
            vcodec=args.vcodec,
            repo_id=args.repo_id,
            overwrite=args.overwrite,
            max_shift=args.max_shift,
            max_turn_deg=args.max_turn,
            robot=args.robot,
            progress=show,
        )
    ok = len(report.succeeded)
    print(
        f"{report.root}: {ok} episode(s) of {len(report.layouts)} layouts (yield "
        f"{100 * report.yield_:.0f} %), {sum(r.frames for r in report.succeeded)} frames, "
        f"{report.size_bytes / 1e6:.1f} MB ({report.seconds:.1f} s, writing "
        f"{report.write_seconds:.1f} s)"
    )
    return 0
