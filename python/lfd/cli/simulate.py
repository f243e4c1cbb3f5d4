"""``lfd simulate``: record a demonstration of a task by the simulated demonstrator.

One demonstration::

    lfd simulate exp1 --seed 3 -o demo.mcap [--render] [--speed 1.0] [--noise-mm 2.5] ...
    lfd simulate exp5 --style natural --seed 500 -o lifts.mcap   # repeated lifts, mocap-like

A whole set, deterministically (the shipped recordings are made this way)::

    lfd simulate --set templates -o recordings/templates   # 9 demos per skill, seeds 0-8
    lfd simulate --set samples -o recordings               # exp1-4 seed 1000 + rendered sample
    lfd simulate --set eval -o /tmp/eval                   # 4 experiments x seeds 100-105
    lfd simulate --set eval --style natural -o /tmp/nat    # exp1-exp5 x seeds 100-105

Two hands (each hand's lane labelled, handovers marked)::

    lfd simulate handover --seed 3 -o handover.mcap        # pick up, pass to the other, place
    lfd simulate carry --style natural -o carry.mcap       # a large box carried with both hands
    lfd simulate hold_stack -o hs.mcap                     # hold a plank, stack on it
    lfd simulate hold_push -o hp.mcap                      # hold a cube, push another
    lfd simulate --set hands -o /tmp/hands                 # the four x seeds 100-105
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ._types import duration, finite_float, float_range, seed

NAME = "simulate"
HELP = "Record a task performed by the simulated human demonstrator (MuJoCo)."

SETS = ("templates", "eval", "samples", "hands")
"""The names of :data:`lfd.sim.sets.SETS` (not imported: ``lfd --help`` runs without the sim
extra; tests/unit/sim/test_sim.py checks they agree)."""
OBJECT_RATE_HZ = 30.0
"""Camera / tag tracking rate of the simulated recordings (``simulate``'s default), Hz: the
upper limit of the hand and render rates."""


def _variability_value(name: str) -> Callable[[str], float]:
    """A ``type=`` converter for the :class:`~lfd.sim.Variability` field ``name``: a finite
    number that :meth:`~lfd.sim.Variability.validate` accepts (its ranges are the only copy)."""

    def convert(text: str) -> float:
        from ..errors import UsageError
        from ..sim import Variability

        v = finite_float(text)
        try:
            given: dict[str, Any] = {name: v}
            Variability(**given).validate()
        except UsageError as err:
            raise argparse.ArgumentTypeError(str(err)) from None
        return v

    convert.__name__ = name
    return convert


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from ..sim.tasks import TASK_NAMES
    from ..sim.variability import STYLES

    parser.add_argument(
        "task",
        nargs="?",
        choices=sorted(TASK_NAMES),
        metavar="TASK",
        help="exp1-exp4, exp5/exp6 (6-10 repeated lifts of one box / two boxes), a two-hand "
        "task (handover, carry, hold_stack, hold_push) or a skill name for its template task "
        f"({', '.join(sorted(TASK_NAMES))})",
    )
    parser.add_argument(
        "--style",
        choices=STYLES,
        default="careful",
        help="demonstrator: careful (the paper's, default) or natural (fast grasps of several "
        "types, hand lingering at the object, 5-9 cm cubes, mocap-like 30 Hz keypoints)",
    )
    parser.add_argument(
        "-o", "--output", required=True, help="output .mcap (a directory with --set)"
    )
    parser.add_argument(
        "--overwrite",
        action="store_true",
        help="replace the -o recording when it exists (without it an existing file is refused; "
        "--set regenerates its set's files)",
    )
    parser.add_argument(
        "--set",
        choices=SETS,
        help="generate a whole recording set into the -o directory (no TASK then)",
    )
    parser.add_argument("--seed", type=seed, default=0, help="random seed, >= 0 (default 0)")
    parser.add_argument("--render", action="store_true", help="also render colour + depth frames")
    parser.add_argument(
        "--render-rate",
        type=float_range(0.0, OBJECT_RATE_HZ, lo_open=True),
        default=10.0,
        help=f"render rate, Hz, in (0, {OBJECT_RATE_HZ:g}] (10)",
    )
    parser.add_argument(
        "--color-format",
        choices=("raw", "png", "jpeg"),
        default="png",
        help="how rendered colour frames are stored (png)",
    )
    parser.add_argument(
        "--duration", type=duration, help="keep only the first seconds (> 0, at most 24 h)"
    )
    parser.add_argument(
        "--hand-rate",
        type=float_range(0.5, OBJECT_RATE_HZ),
        help=f"keypoint rate, Hz, in [0.5, {OBJECT_RATE_HZ:g}] (5; {OBJECT_RATE_HZ:g} with "
        "--style natural)",
    )
    v = parser.add_argument_group(
        "variability (default: drawn per demo; the careful style's defaults are shown, "
        "docs/skills.md lists the natural style's)"
    )
    var = _variability_value
    v.add_argument("--speed", type=var("speed"), help="speed factor in [0.2, 5] (U(0.8, 1.25))")
    v.add_argument(
        "--hand-scale", type=var("hand_scale"), help="hand size factor in [0.6, 1.5] (U(0.9, 1.1))"
    )
    v.add_argument("--noise-mm", type=var("noise_mm"), help="keypoint noise std, mm (U(2, 3))")
    v.add_argument(
        "--dropout", type=var("dropout"), help="missing tag fraction, <= 0.9 (U(0.01, 0.03))"
    )
    v.add_argument("--tremor-mm", type=var("tremor_mm"), help="tremor amplitude, mm (U(0.3, 1))")
    v.add_argument(
        "--detour", type=var("detour"), help="path detour scale, 0 = straight (U(0.5, 1.5))"
    )
    v.add_argument("--pauses", type=var("pauses"), help="pause probability, <= 0.9 (U(0.15, 0.5))")
    v.add_argument(
        "--outliers",
        type=var("outlier_rate"),
        help="fraction of hand frames with outliers, <= 0.9 (0.03)",
    )
    v.add_argument(
        "--approach-deg",
        type=var("approach_deg"),
        help="max approach azimuth deviation, deg, in [0, 180] (35)",
    )
    v.add_argument(
        "--hand-miss",
        type=var("hand_miss"),
        help="fraction of failed hand estimates, <= 0.9 (0.02)",
    )
    v.add_argument("--noise-free", action="store_true", help="no sensor noise, dropouts, tremor")
    from ._rerun import add_rerun_arguments

    add_rerun_arguments(parser)


def _variability(args: argparse.Namespace) -> Any:
    from ..sim import Variability

    given = {
        "speed": args.speed,
        "hand_scale": args.hand_scale,
        "noise_mm": args.noise_mm,
        "dropout": args.dropout,
        "tremor_mm": args.tremor_mm,
        "detour": args.detour,
        "pauses": args.pauses,
        "outlier_rate": args.outliers,
        "hand_miss": args.hand_miss,
        "approach_deg": args.approach_deg,
    }
    given = {k: v for k, v in given.items() if v is not None}
    given["style"] = args.style
    var = Variability.noise_free(**given) if args.noise_free else Variability(**given)
    var.validate()  # UsageError
    return var


def _check_set_directory(out: Path) -> None:
    """Refuse a ``--set`` destination that is a file or cannot be created or written."""
    from ..errors import UsageError

    if out.exists() and not out.is_dir():
        raise UsageError(f"-o/--output {out}: --set writes a directory, and this is a file")
    base = out
    while not base.exists():  # the nearest existing ancestor must let us create the rest
        base = base.parent
    from ..outputs import writable_dir

    if not writable_dir(base):
        raise UsageError(f"-o/--output {out}: directory {base} is not writable")


def run(args: argparse.Namespace) -> int:
    os.environ.setdefault("MUJOCO_GL", "egl")
    from ..errors import UsageError
    from ..outputs import check_output
    from ..sim.sets import record, set_jobs
    from ._rerun import check_rerun_args

    if args.set and args.task:
        raise UsageError(
            f"--set {args.set} generates its own tasks; drop {args.task} (or drop --set)"
        )
    if not args.set and not args.task:
        raise UsageError("give a TASK (e.g. exp1) or --set templates|eval|samples|hands")
    if args.set:
        _check_set_directory(Path(args.output))
    else:
        check_output(args.output, what="-o/--output", suffixes=(".mcap",), overwrite=args.overwrite)
    check_rerun_args(args, inputs=[args.output])
    from rich.progress import Progress

    var = _variability(args)
    if args.set:
        from ._rerun import wants_rerun

        if wants_rerun(args):
            print(
                "lfd simulate: warning: --rerun* shows a single demonstration; ignored with --set",
                file=sys.stderr,
            )
        jobs = set_jobs(args.set, Path(args.output), args.style)
        replaced = sum(Path(job["path"]).exists() for job in jobs)
        if replaced:
            print(
                f"lfd simulate: warning: replacing {replaced} existing recordings of the "
                f"{args.set} set in {args.output}",
                file=sys.stderr,
            )
        with Progress() as progress:
            bar = progress.add_task(f"simulating {args.set}", total=len(jobs))
            for job in jobs:
                record(
                    job["task"],
                    job["seed"],
                    job["path"],
                    variability=var,
                    render_rate=job.get("render"),
                    duration=job.get("duration"),
                    color_format=args.color_format,
                )
                progress.advance(bar)
        print(f"wrote {len(jobs)} recordings to {args.output}")
        return 0
    from ._rerun import close_from_args, open_from_args

    show = open_from_args(args, "lfd_simulate")
    with Progress(transient=True) as progress:
        progress.add_task(f"simulating {args.task} (seed {args.seed})", total=None)
        result = record(
            args.task,
            args.seed,
            args.output,
            variability=var,
            render_rate=args.render_rate if args.render else None,
            duration=args.duration,
            hand_rate=args.hand_rate,
            color_format=args.color_format,
        )
    demo = result.demo
    if demo.other_hand is None:
        what = f"{len(demo.hand)} hand samples, skills {' '.join(demo.skill_sequence)}"
    else:
        what = (
            "; ".join(
                f"{side} hand {len(h)} samples, skills "
                + " ".join(lab.skill for lab in demo.labels_of(side))
                for side, h in demo.hands.items()
            )
            + f"; {len(demo.handovers)} handovers"
        )
    print(f"{args.output}: {args.task} seed {args.seed}, {demo.duration_s:.1f} s, {what}")
    if show:
        from ..viz.pipeline import log_recorded_demo

        log_recorded_demo(demo)
        close_from_args(args)
    return 0
