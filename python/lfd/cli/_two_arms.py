"""``lfd reproduce --robot aloha``: a two-hand recording on a two-arm robot (each hand's lane
to the arm of its side, :mod:`lfd.reproduce.two_arms`)."""

from __future__ import annotations

import argparse
from typing import Any


def run_two_arms(args: argparse.Namespace, demo: Any, err: Any) -> int:
    """Reproduce ``demo``'s two-hand program of ground-truth labels on the two arms; print the
    program, each mode's outcome and every failure (naming the arm); exit 0 when achieved."""
    from ..errors import DemonstrationError, UsageError
    from ..preprocessing import preprocess
    from ..reproduce import PREPROCESSING, from_hand_labels
    from ..reproduce.aloha import TWO_ARM_ROBOTS
    from ..reproduce.two_arms import reproduce_two_arms
    from ._options import console, write_json

    used = [
        opt
        for opt, on in (
            ("--task", args.task),
            ("--segment", args.segment),
            ("--hand", args.hand),
            ("--displace", args.displace),
            ("--randomise", args.randomise),
            ("--video", args.video),
        )
        if on
    ]
    if used:
        raise UsageError(f"--robot {args.robot} cannot be combined with {used[0]} yet")
    if not demo.labels:
        raise DemonstrationError("the recording has no skill labels: nothing to reproduce")
    robot = TWO_ARM_ROBOTS[args.robot]()
    hands = from_hand_labels(
        demo.labels, demo.start_ns, sides=demo.sides, handovers=demo.handovers, objects=demo.objects
    )
    for line in hands.lines():
        err.print(line, highlight=False, markup=False)
    modes = ("replay", "skills", "dmp") if args.mode == "all" else (args.mode,)
    trajs = {s: preprocess(demo.one_hand(s), **PREPROCESSING) for s in hands.sides}
    results = {mode: reproduce_two_arms(trajs, hands, mode, robot=robot) for mode in modes}
    out = console(args)
    for mode, r in results.items():
        bases = ", ".join(f"{s} ({b[0]:.2f}, {b[1]:.2f})" for s, b in r.bases.items())
        verdict = "achieved" if r.success else "not achieved"
        out.print(f"{mode}: {verdict} on {robot.name} (bases {bases}; {r.execution_time_s:.1f} s)")
        for line in r.failures:
            err.print(f"  {line}", highlight=False, markup=False)
    if args.json:
        write_json(
            args.json,
            {
                "recording": args.recording,
                "robot": robot.name,
                "hands": hands.to_json(),
                "results": {
                    m: {
                        "success": r.success,
                        "failures": r.failures,
                        "bases": {s: b.tolist() for s, b in r.bases.items()},
                        "execution_time_s": r.execution_time_s,
                        "skills": {s: [k.to_json() for k in v] for s, v in r.skills.items()},
                    }
                    for m, r in results.items()
                },
            },
        )
    judged = [m for m in results if not (args.mode == "all" and m == "replay")]
    return 0 if all(results[m].success for m in judged) else 1
