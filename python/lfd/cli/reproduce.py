"""``lfd reproduce rec.mcap --mode replay|skills|dmp``: execute a demonstration on the robot."""

from __future__ import annotations

import argparse

from ._options import (
    add_json_argument,
    add_segmentation_arguments,
    check_json,
    json_to_stdout,
    segmentation_options,
    write_json,
)

NAME = "reproduce"
HELP = "Reproduce a demonstration on a simulated 7-DoF arm (replay, skills or DMP) and measure it."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("recording", help="an lfd MCAP recording")
    parser.add_argument(
        "--mode",
        choices=("replay", "skills", "dmp", "all"),
        default="skills",
        help="reproduction method ('all' runs the three and prints a path-length table)",
    )
    parser.add_argument(
        "--displace",
        action="append",
        metavar="NAME:DX,DY",
        help="shift an object's initial position in the robot scene (m); repeatable",
    )
    parser.add_argument(
        "--task",
        metavar="PROGRAM.json",
        help="task program (segments) to execute; default: the recording's ground-truth labels",
    )
    parser.add_argument(
        "--segment",
        action="store_true",
        help="segment the recording with lfd.segment instead of using its ground-truth labels",
    )
    add_segmentation_arguments(parser, used_with="with --segment")
    add_json_argument(parser, "the task program and the measurements")
    parser.add_argument(
        "--video", metavar="OUT.mp4", help="render a video of the (last) mode (imageio or OpenCV)"
    )
    from ..viz.cli import add_rerun_arguments

    add_rerun_arguments(parser)


def run(args: argparse.Namespace) -> int:
    from rich.console import Console
    from rich.progress import Progress
    from rich.table import Table

    from ..errors import LfdError
    from ..io import load
    from ..preprocessing import preprocess
    from ..reproduce import (
        TaskProgram,
        from_labels,
        from_segmentation,
        parse_displacement,
        reproduce,
    )
    from ..viz.cli import check_rerun_args, close_from_args, open_from_args

    inputs = [p for p in (args.recording, args.task) if p]
    check_json(args, inputs)
    check_rerun_args(args, inputs)
    console = Console(stderr=True)
    show = open_from_args(args, "lfd_reproduce")
    demo = load(args.recording, images=False)
    traj = preprocess(demo)
    t0 = int(traj.t_ns[0])
    if args.task:
        program = TaskProgram.load(args.task)
    elif args.segment:
        try:
            from ..segmentation import segment  # type: ignore[import-not-found, unused-ignore]
        except ImportError as err:
            raise LfdError("lfd.segment is not available in this installation") from err
        search, grammar = segmentation_options(args)
        program = from_segmentation(segment(demo, search=search, grammar=grammar), t0)  # type: ignore[arg-type]
    else:
        program = from_labels(demo.labels, t0)
    displace = parse_displacement(args.displace)
    modes = ("replay", "skills", "dmp") if args.mode == "all" else (args.mode,)
    results = {}
    with Progress(console=console, transient=True) as bar:
        for mode in modes:
            task = bar.add_task(f"{mode}", total=1.0)

            def tick(i: int, n: int, task: object = task) -> None:
                bar.update(task, completed=i / max(n, 1))  # type: ignore[arg-type]

            fps = 30.0 if args.video and mode == modes[-1] else 0.0
            results[mode] = reproduce(
                traj, program, mode, displace=displace, video_fps=fps, progress=tick
            )
    if show:
        from ..viz import log_demonstration, log_reproduction

        log_demonstration(demo, trajectory=traj)
        sizes = {n: o.size for n, o in demo.objects.items()}
        for r in results.values():
            log_reproduction(r, skills=program.skills, object_sizes=sizes)
    close_from_args(args)
    table = Table(title=f"{args.recording}: {' '.join(program.skills)}")
    for col in ("mode", "path length (m)", "ratio", "time (s)", "success", "objects"):
        table.add_column(col)
    ref = results["replay"].path_length if "replay" in results else None
    for mode, r in results.items():
        objs = ", ".join(
            f"{o.name} {o.position_error * 1000:.1f} mm/{o.rotation_error_deg:.1f}°"
            + ("" if o.success else " ✗")
            for o in r.objects
        )
        ratio = f"{100 * r.path_length / ref:.1f}%" if ref else "-"
        table.add_row(
            mode,
            f"{r.path_length:.4f}",
            ratio,
            f"{r.execution_time_s:.1f}",
            "yes" if r.success else "no",
            objs,
        )
    out = console if json_to_stdout(args) else Console()  # stdout is JSON only under --json -
    out.print(table)
    if args.json:
        doc = {
            "recording": args.recording,
            "program": program.to_json(),
            "results": {m: r.to_json() for m, r in results.items()},
        }
        write_json(args.json, doc)
    if args.video:
        ex = results[modes[-1]].execution
        if ex is not None and ex.frames:
            write_video(args.video, ex.frames, fps=30.0)
            console.print(f"video: {args.video} ({len(ex.frames)} frames, mode {modes[-1]})")
    return 0 if all(r.success for r in results.values()) or args.mode == "all" else 1


def write_video(path: str, frames: list, fps: float) -> None:
    """Write RGB frames to an MP4 (imageio when installed, else OpenCV's mp4v writer)."""
    try:
        import imageio.v2 as imageio
    except ImportError:
        import cv2

        h, w = frames[0].shape[:2]
        fourcc = cv2.VideoWriter_fourcc(*"mp4v")  # type: ignore[attr-defined]
        writer = cv2.VideoWriter(path, fourcc, fps, (w, h))
        for f in frames:
            writer.write(cv2.cvtColor(f, cv2.COLOR_RGB2BGR))
        writer.release()
    else:
        imageio.mimwrite(path, frames, fps=fps)
