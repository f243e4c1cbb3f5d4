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
    from ..reproduce.robots import TWO_ARM_ROBOTS
    from ..reproduce.two_arms import reproduce_two_arms
    from ._options import console, write_json

    used = [
        opt
        for opt, on in (
            ("--task", args.task),
            ("--segment", args.segment),
            ("--hand", args.hand),
            ("--displace", args.displace),
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
    if args.randomise:
        from ..reproduce.two_arms_randomise import check_busy

        check_busy(hands, args.robot)
    modes = ("replay", "skills", "dmp") if args.mode == "all" else (args.mode,)
    trajs = {s: preprocess(demo.one_hand(s), **PREPROCESSING) for s in hands.sides}
    if args.randomise:
        return _randomised(args, trajs, hands, robot, modes, err)
    for line in hands.lines():
        err.print(line, highlight=False, markup=False)
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


def _randomised(
    args: argparse.Namespace,
    trajs: dict[str, Any],
    hands: Any,
    robot: Any,
    modes: tuple[str, ...],
    err: Any,
) -> int:
    """``--randomise N --robot aloha``: every mode on N layouts with both arms; the success
    table (the task's and each arm's per mode, per arm and skill), every failure naming the
    arm, the JSON of the one-arm ``--randomise`` with each arm's success."""
    from rich.progress import Progress

    from ..reproduce.two_arms_randomise import first_layout, reproduce_two_arms_randomised
    from ._randomised import randomised_report

    settings = {"seed": args.seed, "max_shift": args.max_shift, "max_turn_deg": args.max_turn}
    # refused (one line) before the progress bar starts: settings, the program, no layout
    first_layout(trajs, hands, modes=modes, robot=robot, **settings)
    for line in hands.lines():
        err.print(line, highlight=False, markup=False)
    with Progress(console=err, transient=True, disable=not err.is_terminal) as bar:
        task = bar.add_task("layouts", total=1.0)

        def tick(i: int, n: int) -> None:
            bar.update(task, completed=i / max(n, 1))

        res = reproduce_two_arms_randomised(
            trajs, hands, args.randomise, modes=modes, progress=tick, robot=robot, **settings
        )
    for lay in res.layouts:
        if lay.rejected:
            why = ", ".join(f"{k} {v}" for k, v in sorted(lay.rejected.items()))
            err.print(f"layout {lay.index}: drawn again for {why}", highlight=False, markup=False)
    skills = list(dict.fromkeys(f"{s} {g.skill}" for s in hands.sides for g in hands.lanes[s]))
    return randomised_report(args, res, skills, hands.to_json(), err)
