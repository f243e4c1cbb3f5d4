"""``lfd perception``: check the hand model on photos; train / evaluate the depth network.

    lfd perception hands IMAGE... [--depth D.png... --intrinsics K.json] [--json OUT] [--rerun]
    lfd perception calibrate IMAGE|VIDEO... --board 9x6 --square 0.025 -o camera.json
    lfd perception train -o model.pt [--samples 6000] [--epochs 40] [--resume]
    lfd perception eval --hand-model model.pt [--samples 300]

``hands`` runs MediaPipe Hands (the real-camera model) on still images: for checking a camera
setup. ``calibrate`` fits a colour camera's intrinsics to views of a printed chessboard
(OpenCV) and writes the ``camera.json`` that ``lfd record`` reads. ``train`` / ``eval`` concern the depth network of the simulator (needs torch).

Training renders randomised hand crops with the simulated demonstrator (``--data`` caches them
as .npz), shows progress, and checkpoints every epoch to ``<output>.ckpt`` (``--resume``).
"""

from __future__ import annotations

import argparse
import os

from ._types import float_range, positive_float, positive_int, seed

NAME = "perception"
HELP = "Hands in photos (MediaPipe); train / evaluate the depth hand network (perception extra)."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="action", required=True)
    h = sub.add_parser("hands", help="find hands and their 21 keypoints in photos (MediaPipe)")
    h.add_argument("images", nargs="+", metavar="IMAGE", help="colour images (any OpenCV format)")
    h.add_argument(
        "--depth",
        nargs="+",
        metavar="D.png",
        help="aligned 16-bit depth PNGs in mm, one per image, in order: adds keypoints_3d (m)",
    )
    h.add_argument("--intrinsics", metavar="K.json", help='{"K": 3x3} or a camera.json')
    h.add_argument("--max-hands", type=positive_int, default=2, help="hands per image (2)")
    h.add_argument("--mirrored", action="store_true", help="the photos are mirrored (selfie view)")
    from ._options import add_json_argument
    from ._rerun import add_rerun_arguments

    add_json_argument(h, "the hands (keypoints in MediaPipe-21 order)")
    add_rerun_arguments(h)
    t = sub.add_parser("train", help="train the hand network on rendered depth crops")
    t.add_argument("-o", "--output", required=True, metavar="FILE.pt", help="output weights (.pt)")
    t.add_argument(
        "--samples", type=positive_int, default=6000, help="training crops to render (6000)"
    )
    t.add_argument(
        "--data",
        nargs="*",
        metavar="SET.npz",
        help="use these rendered sets (.npz) instead of rendering; a missing first one is "
        "rendered and cached there",
    )
    t.add_argument("--epochs", type=positive_int, default=40, help="training epochs (40)")
    t.add_argument("--batch", type=positive_int, default=64, help="batch size (64)")
    t.add_argument("--lr", type=positive_float, default=2e-3, help="Adam learning rate (0.002)")
    t.add_argument(
        "--seed", type=seed, default=1, help="random seed of renders and weights, >= 0 (1)"
    )
    t.add_argument("--threads", type=positive_int, default=2, help="torch CPU threads (2)")
    t.add_argument("--resume", action="store_true", help="continue from <output>.ckpt")
    t.add_argument(
        "--init", metavar="FILE.pt", help="start from the weights of this model (fine-tune)"
    )
    t.add_argument("--val-samples", type=positive_int, default=200, help="held-out crops (200)")
    c = sub.add_parser(
        "calibrate", help="camera intrinsics from views of a printed chessboard: a camera.json"
    )
    c.add_argument(
        "views",
        nargs="+",
        metavar="IMAGE|VIDEO",
        help="photos of the board from a dozen directions, or videos of it (.mp4 .mov .avi .mkv "
        ".webm .m4v: every --every-th frame)",
    )
    c.add_argument(
        "--board",
        required=True,
        type=board_size,
        metavar="COLSxROWS",
        help="inner corners of the chessboard, e.g. 9x6 (a board of 10 x 7 squares)",
    )
    from ..perception.calibration import SQUARE_RANGE_M

    c.add_argument(
        "--square",
        required=True,
        type=float_range(*SQUARE_RANGE_M),
        metavar="M",
        help=f"a square's side, m, in [{SQUARE_RANGE_M[0]:g}, {SQUARE_RANGE_M[1]:g}]",
    )
    c.add_argument("--every", type=positive_int, default=10, help="videos: every Nth frame (10)")
    c.add_argument(
        "-o", "--output", required=True, metavar="camera.json", help="the camera.json to write"
    )
    e = sub.add_parser("eval", help="keypoint error on held-out rendered crops")
    e.add_argument("--hand-model", metavar="FILE.pt", help="weights (default: shipped)")
    e.add_argument(
        "--samples", type=positive_int, default=300, help="held-out crops to render (300)"
    )
    e.add_argument("--seed", type=seed, default=99, help="seed of the held-out renders (99)")


def _hands(args: argparse.Namespace) -> int:
    from rich.progress import Progress

    from ..perception.hand.mediapipe import MediaPipeHands
    from ..perception.hand.stills import hands_in_images, read_inputs
    from ..viz.hands import log_still_hands
    from ._options import check_json, console, emit_json
    from ._rerun import check_rerun_args, close_from_args, open_from_args

    inputs = [*args.images, *(args.depth or []), *([args.intrinsics] if args.intrinsics else [])]
    check_json(args, inputs)
    check_rerun_args(args, inputs=inputs)
    con = console(args)
    loaded = read_inputs(args.images, args.depth, args.intrinsics)
    model = MediaPipeHands(mirrored=args.mirrored)
    with Progress(console=con, transient=True) as progress:
        task = progress.add_task(f"{len(args.images)} images", total=len(args.images))
        doc = hands_in_images(
            loaded,
            model=model,
            max_hands=args.max_hands,
            progress=lambda k: progress.update(task, completed=k),
        )
    for entry in doc["images"]:
        hands = ", ".join(
            f"{h['handedness']} ({h['score']:.2f}"
            + (", 3-D" if h["keypoints_3d"] is not None else "")
            + ")"
            for h in entry["hands"]
        )
        con.print(
            f"{entry['image']}: {len(entry['hands'])} hands" + (f": {hands}" if hands else "")
        )
    if open_from_args(args, "lfd_perception_hands"):
        try:
            log_still_hands(doc, loaded.rgb)
        finally:
            close_from_args(args)
    emit_json(args, doc, con)
    return 0


def board_size(text: str) -> tuple[int, int]:
    """``COLSxROWS`` inner corners of a chessboard, each in
    :data:`~lfd.perception.calibration.BOARD_RANGE`."""
    from ..perception.calibration import BOARD_RANGE

    cols, sep, rows = text.lower().partition("x")
    lo, hi = BOARD_RANGE
    if not sep or not cols.isdigit() or not rows.isdigit() or len(cols) > 4 or len(rows) > 4:
        raise argparse.ArgumentTypeError(
            f"expected COLSxROWS inner corners, e.g. 9x6, got {text!r}"
        )
    if not (lo <= int(cols) <= hi and lo <= int(rows) <= hi):
        raise argparse.ArgumentTypeError(
            f"each side must have {lo} to {hi} inner corners, e.g. 9x6, got {text!r}"
        )
    return int(cols), int(rows)


def _calibrate(args: argparse.Namespace) -> int:
    import json

    from ..outputs import atomic_write_text, check_output
    from ..perception.calibration import calibrate, views
    from ._options import console, read_files

    inputs = read_files(args, *args.views)
    check_output(args.output, inputs=inputs, what="-o/--output", suffixes=(".json",))
    cols, rows = args.board
    con = console(args)
    with con.status(f"finding the {cols}x{rows} board in {len(args.views)} files"):
        cal = calibrate(views(args.views, args.every), cols, rows, args.square)
    K = cal.K
    con.print(
        f"{cal.views} views with the whole board ({cal.skipped} without), {cal.width}x"
        f"{cal.height}: fx {K[0, 0]:.1f} fy {K[1, 1]:.1f} cx {K[0, 2]:.1f} cy {K[1, 2]:.1f} px, "
        f"reprojection error {cal.rms_px:.2f} px (RMS)"
    )
    atomic_write_text(args.output, json.dumps(cal.camera_json(), indent=2) + "\n")
    con.print(f'wrote {args.output} (add the tagged objects under "objects")')
    return 0


def _check(args: argparse.Namespace) -> None:
    """Refuse unusable outputs before torch is imported and anything is rendered."""
    from ..outputs import check_output
    from ._options import check_inputs, read_files

    if args.action != "train":
        check_inputs(hand_model=args.hand_model)
        return
    check_inputs(init=args.init)
    inputs = read_files(args, *(args.data or []))  # and --init
    check_output(args.output, inputs=inputs, what="-o/--output", suffixes=(".pt",))
    check_output(f"{args.output}.ckpt", inputs=inputs, what="checkpoint")
    if args.data and not all(os.path.exists(p) for p in args.data):
        check_output(args.data[0], what="--data cache", suffixes=(".npz",))


def _render(n: int, seed: int) -> dict:  # type: ignore[type-arg]
    from rich.progress import Progress

    from ..perception.hand.dataset import render_training_set

    with Progress() as progress:
        task = progress.add_task(f"rendering {n} crops", total=n)
        return render_training_set(n, seed=seed, progress=lambda k: progress.advance(task, k))


def run(args: argparse.Namespace) -> int:
    import numpy as np

    if args.action == "hands":
        return _hands(args)
    if args.action == "calibrate":
        return _calibrate(args)
    _check(args)

    from ..perception.hand.infer import _torch

    _torch()
    # the optimiser imports torch._dynamo -> triton; loading triton's native library after
    # MuJoCo's EGL context exists crashes the process, so load it before rendering
    import torch._dynamo  # noqa: F401

    from ..perception.hand.train import heldout_error_mm, load_arrays, train

    if args.action == "eval":
        from ..perception.hand.infer import HandEstimator

        est = HandEstimator(args.hand_model, threads=2)
        err = heldout_error_mm(est, args.samples, args.seed)
        print(
            f"mean keypoint error {err.mean():.1f} mm (median {np.median(err):.1f}, n={err.size}; "
            f"{est.views} point subsets)"
        )
        return 0
    if args.data and all(os.path.exists(p) for p in args.data):
        data = load_arrays(args.data)
    else:
        data = _render(args.samples, args.seed)
        if args.data:
            from ..outputs import atomic_output

            with atomic_output(args.data[0]) as tmp, open(tmp, "wb") as fh:
                np.savez(
                    fh, points=data["points"], keypoints=data["keypoints"], centre=data["centre"]
                )
    val = _render(args.val_samples, 99)
    summary = train(
        data,
        args.output,
        epochs=args.epochs,
        batch=args.batch,
        lr=args.lr,
        resume=args.resume,
        validation=val,
        threads=args.threads,
        seed=args.seed,
        init=args.init,
    )
    print(f"saved {args.output}: {summary}")
    return 0
