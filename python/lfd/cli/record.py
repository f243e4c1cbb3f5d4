"""``lfd record``: perceive a camera (tags + hand model) into a demonstration MCAP.

    lfd record --source sim:exp1 -o demo.mcap --duration 10     # simulator, real perception
    lfd record --source sim:exp3:natural --seed 4 -o demo.mcap  # the natural demonstrator
    lfd record --source frames:DIR -o demo.mcap                  # image folder (see docs)
    lfd record --source camera:0 --intrinsics camera.json -o demo.mcap \
        --depth-reader docs/examples/realsense_reader.py:make_reader --hand right
    lfd record --source camera:0 --intrinsics camera.json --hand-size 0.19 -o demo.mcap
    lfd record --source video:demo.mp4 --intrinsics camera.json -o demo.mcap   # colour only

The hand model: ``mediapipe`` (MediaPipe Hands on the colour image, lifted with depth, or
placed from colour alone when there is none; the default for real cameras, image folders and
videos) or ``depth-net`` (lfd's depth network, trained on
the simulator's hand; the default for ``sim:`` sources), or a ``.pt`` file of the depth network.

Ctrl+C (SIGINT) or SIGTERM stops the recording; the file is closed and complete.
"""

from __future__ import annotations

import argparse
from typing import Any

from ._types import duration, float_range, positive_float, seed

NAME = "record"
HELP = "Record a demonstration from a camera or video: object tags + hand keypoints -> MCAP."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from ..perception.camera_file import HAND_RATE_RANGE_HZ
    from ..perception.hand.colour import HAND_SIZE_RANGE

    parser.add_argument(
        "--source",
        required=True,
        help="sim:TASK[:STYLE] (STYLE careful, the default, or natural), frames:DIR, "
        "camera:N (device index) or video:FILE (a video file, colour only)",
    )
    parser.add_argument(
        "-o",
        "--output",
        required=True,
        help="output .mcap (written beside it as .NAME.*.partial until the recording stops)",
    )
    parser.add_argument(
        "--overwrite",
        action="store_true",
        help="replace the -o recording when it exists (without it an existing file is refused)",
    )
    parser.add_argument(
        "--duration",
        type=duration,
        help="stop after this many seconds of frames (> 0, at most 24 h)",
    )
    parser.add_argument(
        "--hand-rate",
        type=float_range(*HAND_RATE_RANGE_HZ),
        help=f"hand samples per second, in [{HAND_RATE_RANGE_HZ[0]:g}, "
        f"{HAND_RATE_RANGE_HZ[1]:g}] (default: every frame with mediapipe, 5 with depth-net)",
    )
    parser.add_argument(
        "--fps",
        type=float_range(0.5, 120.0),
        help="sim / camera source: camera frame rate, Hz, in [0.5, 120] (30)",
    )
    parser.add_argument("--seed", type=seed, default=0, help="sim source: random seed, >= 0 (0)")
    parser.add_argument(
        "--intrinsics", help="camera and video sources: camera.json (K, size, objects)"
    )
    parser.add_argument(
        "--depth-reader",
        metavar="MODULE:FACTORY",
        help="camera source: factory() returns a depth reader (read() -> uint16 mm image)",
    )
    parser.add_argument(
        "--hand-model",
        metavar="MODEL",
        help="mediapipe, depth-net or a depth-net FILE.pt (default: mediapipe for cameras and "
        "image folders, depth-net for sim: sources)",
    )
    parser.add_argument(
        "--hand-size",
        type=float_range(*HAND_SIZE_RANGE),
        metavar="M",
        help="without depth: the demonstrator's hand length, wrist crease to the middle "
        "fingertip, m, in [0.1, 0.3] (e.g. 0.19); sets the distance of the hand (default: the "
        "landmark model's hand size)",
    )
    parser.add_argument(
        "--hand",
        choices=("right", "left"),
        help="keep this hand alone (another hand in view is tracked and ignored); default: "
        "both hands where two can be seen (mediapipe on a camera, images or a video, a "
        "two-hand sim: task), the right hand of a one-hand sim: task or with depth-net",
    )
    parser.add_argument(
        "--mirrored",
        action="store_true",
        help="the colour images are mirrored (a selfie view): swaps MediaPipe's handedness",
    )
    parser.add_argument(
        "--aruco-dict", default="DICT_4X4_50", help="ArUco dictionary of the tags (DICT_4X4_50)"
    )
    parser.add_argument(
        "--reference-size",
        type=positive_float,
        default=0.10,
        help="side of the reference tag's black square, m, > 0 (0.10)",
    )
    parser.add_argument("--no-hand", action="store_true", help="record object poses only")
    parser.add_argument("--images", action="store_true", help="also store colour + depth frames")
    parser.add_argument(
        "--live-segment",
        action="store_true",
        help="segment while recording: skills appear in Rerun as they settle and are written to "
        "/lfd/live/segments (kept apart from /lfd/ground_truth)",
    )
    from ._rerun import add_rerun_arguments

    add_rerun_arguments(parser)


def hand_model_choice(option: str | None, source: str) -> str:
    """``mediapipe`` or ``depth-net`` for ``--hand-model`` (None: by the source's kind)."""
    if option is None:
        return "depth-net" if source.startswith("sim:") else "mediapipe"
    if option in ("mediapipe", "depth-net"):
        return option
    if option.endswith(".pt"):
        return "depth-net"
    from ..errors import UsageError

    raise UsageError(
        f"--hand-model {option}: expected mediapipe, depth-net or a depth-net weights file .pt"
    )


def run(args: argparse.Namespace) -> int:
    from rich.console import Console

    from ..perception.sources import open_source
    from ._options import sigterm_interrupts
    from ._rerun import close_from_args, open_from_args

    model, model_file = _check(args)
    source = open_source(
        args.source,
        seed=args.seed,
        fps=args.fps,
        duration=args.duration,
        intrinsics=args.intrinsics,
        depth_reader=args.depth_reader,
    )
    try:
        sides = hand_sides(args.hand, model, getattr(source, "sides", None))
        if args.no_hand:  # no hand estimated: the one hand topic (unobserved), as always
            sides = sides[:1]
        args.hand = sides[0]  # the first hand's topics and summary (live: a lane per hand)
        args.hand_sides = sides
        estimator, hand_rate = _estimator(args, model, model_file, source)
        segmenter = _segmenter(args, source)
        view = open_from_args(args, "lfd_record")
        observer = _observer(source, segmenter, view, sides)
    except BaseException:
        source.close()
        raise
    max_frames = None
    if args.duration is not None and not args.source.startswith("sim:"):
        max_frames = max(1, round(args.duration * float(args.fps or source.fps or 30.0)))
    console = Console(stderr=True)
    # a process started in the background inherits SIGINT ignored, and Python then never raises
    # KeyboardInterrupt: stopping with SIGINT (or SIGTERM) is part of this command's contract
    try:
        with sigterm_interrupts():
            stats = _record(args, source, console, estimator, hand_rate, max_frames, observer)
    finally:
        close_from_args(args)
    console.print(_summary(args, stats, live=segmenter is not None))
    return 0


def _check(args: argparse.Namespace) -> tuple[str, str | None]:
    """Refuse what cannot be recorded before a source is opened: the hand model and its file,
    the inputs, the output. -> the hand model and its weights file (None: the shipped one)."""
    from ..outputs import ReadPath, check_output
    from ._options import check_inputs, read_files
    from ._rerun import check_rerun_args

    if args.live_segment and args.no_hand:
        from ..errors import UsageError

        raise UsageError("--live-segment needs the hand: drop --no-hand")
    model = hand_model_choice(args.hand_model, args.source)
    model_file = (
        args.hand_model if model == "depth-net" and args.hand_model != "depth-net" else None
    )
    check_inputs(intrinsics=args.intrinsics, hand_model=model_file)
    frames = None
    # the whole frames: folder is read (a re-run would take an output in color/ for a frame)
    if args.source.startswith("frames:") and args.source != "frames:":
        frames = ReadPath(args.source[len("frames:") :], tree=True, kind="a frames: source folder")
    video = args.source[len("video:") :] if args.source.startswith("video:") else None
    inputs = read_files(args, model_file, frames, video)  # and --intrinsics
    check_output(
        args.output,
        inputs=inputs,
        what="-o/--output",
        suffixes=(".mcap",),
        overwrite=args.overwrite,
    )
    check_rerun_args(args, inputs=[*inputs, args.output])
    return model, model_file


def hand_sides(
    hand: str | None, model: str, scene_sides: tuple[str, ...] | None
) -> tuple[str, ...]:
    """The hands ``lfd record`` keeps: ``--hand`` alone when given; else both where two can be
    seen (a two-hand simulated scene, MediaPipe on a real source), else the right hand (a
    one-hand simulated scene, the depth network on a real source)."""
    if hand is not None:
        return (hand,)
    if scene_sides is not None:  # a simulated scene knows its hands
        return tuple(scene_sides)
    return ("right", "left") if model == "mediapipe" else ("right",)


def _estimator(
    args: argparse.Namespace, model: str, model_file: str | None, source: Any = None
) -> tuple[Any, float | None]:
    """The hand estimator (None: ``--no-hand``; a mapping side -> estimator for two hands, or
    for a hand of a two-hand scene) and the hand rate (None: every frame)."""
    sides = tuple(getattr(args, "hand_sides", (args.hand,)))
    if args.no_hand:
        return None, args.hand_rate
    if model == "mediapipe":
        from ..perception.hand.rgbd import MediaPipeEstimator

        estimator = MediaPipeEstimator(
            sides[0], threads=1, mirrored=args.mirrored, hand_size=args.hand_size
        )
        if len(sides) == 1:
            return estimator, args.hand_rate
        return {sides[0]: estimator, sides[1]: estimator.for_side(sides[1])}, args.hand_rate
    from ..perception.hand.infer import HandEstimator

    net = HandEstimator(model_file, threads=1)
    scene = tuple(getattr(source, "sides", None) or ("right",))
    if sides == ("right",) and scene == ("right",):  # one right hand: the network as it is
        return net, args.hand_rate or 5.0
    from ..perception.hand.sides import DepthHands

    both = DepthHands(net)  # the arms told apart, a left one mirrored for the network
    return {s: both.side(s) for s in sides}, args.hand_rate or 5.0


def _segmenter(args: argparse.Namespace, source: Any) -> Any:
    """The live segmentation of ``--live-segment`` (None without it): of two hands a lane per
    hand (:class:`~lfd.segmentation.live_hands.LiveHands`)."""
    if not args.live_segment:
        return None
    from ..segmentation.live import LiveSegmentation
    from ..segmentation.live_hands import LiveHands

    sides = tuple(getattr(args, "hand_sides", None) or (args.hand,))
    names = [o["name"] for o in source.objects]
    sizes = [o["size"] for o in source.objects]
    tags = [o["tag_id"] for o in source.objects]
    meta = {"depth": source.has_depth}  # as the recording's (the hand's filter)
    if len(sides) > 1:
        return LiveHands(names, sizes, sides=sides, tag_ids=tags, metadata=meta)
    return LiveSegmentation(names, sizes, side=args.hand, tag_ids=tags, metadata=meta)


def _observer(source: Any, segmenter: Any, view: bool, sides: tuple[str, ...] | None = None) -> Any:
    """What is done beside the file: the live segmenter and the Rerun view (None: neither)."""
    if not view and segmenter is None:
        return None
    import numpy as np

    from ..live import LiveObserver

    objects = [(o["name"], o["tag_id"], np.asarray(o["size"], float)) for o in source.objects]
    return LiveObserver.open(objects, segmenter=segmenter, view=view, sides=sides)


def _record(
    args: argparse.Namespace,
    source: Any,
    console: Any,
    estimator: Any,
    hand_rate: float | None,
    max_frames: int | None,
    observer: Any,
) -> Any:
    """:func:`lfd.perception.record.record` with a progress line on stderr."""
    from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

    from ..perception.record import record

    with Progress(
        SpinnerColumn(),
        TextColumn("{task.description}"),
        TimeElapsedColumn(),
        console=console,
        disable=not console.is_terminal,  # off a terminal none (a transient one leaves a blank line)
    ) as progress:
        task = progress.add_task("recording", total=None)

        def update(st: Any) -> None:
            progress.update(
                task,
                description=f"{st.frames} frames, {st.object_poses} object poses, "
                f"{st.hand_estimates} hand estimates",
            )

        return record(
            source,
            args.output,
            hand_rate_hz=hand_rate,
            side=args.hand,
            sides=getattr(args, "hand_sides", None),
            estimator=estimator,
            save_images=args.images,
            max_frames=max_frames,
            progress=update,
            markers={"dictionary": args.aruco_dict, "reference_size": args.reference_size},
            observer=observer,
        )


def _summary(args: argparse.Namespace, stats: Any, *, live: bool) -> str:
    """The line saying what was recorded."""
    from ..io.topics import hand_camera_topic

    how = "stopped" if stats.interrupted else "done"
    sides = tuple(getattr(args, "hand_sides", (args.hand,)))
    return (
        f"{how}: {stats.frames} frames, {stats.object_poses} object poses, "
        f"{stats.hand_estimates} hand estimates ({stats.hand_missing} missed)"
        + (
            f", {stats.hand_in_camera} hands in the camera frame before the reference tag was "
            f"seen ({', '.join(hand_camera_topic(s) for s in sides)})"
            if stats.hand_in_camera
            else ""
        )
        + (f", {stats.live_segments} live segments" if live else "")
        + f" -> {args.output}"
    )
