"""Two-hand simulated demonstrations on two arms, one run per demonstration and mode (issue 42).

Usage::

    MUJOCO_GL=egl python benches/reproduce_two_arms_seeds.py --seeds 301-310 \
        [--tasks hold_push handover hold_stack carry] [--style careful] [--modes skills dmp] \
        [--robot aloha] [--json out.json]

For every task and seed: simulate a two-hand demonstration (``lfd.sim``, the given style),
take its two-hand program of ground-truth labels per hand (as ``lfd reproduce F.mcap --robot
aloha`` does), and reproduce it on the two-arm robot in each mode
(:func:`lfd.reproduce.two_arms.reproduce_two_arms`: both bases placed, both lanes planned,
run in one scene, the arms' contacts with each other and the table checked). Prints one line
per run with its failures, then a Markdown table: achieved per task and mode, and the
failures counted. A demonstration the arms refuse (one line, as ``lfd reproduce`` says it) is
counted as not achieved, with its reason.
"""

from __future__ import annotations

import argparse
import json
import time
from collections import Counter
from typing import Any


def seeds_of(spec: list[str]) -> list[int]:
    out: list[int] = []
    for s in spec:
        a, _, b = s.partition("-")
        out += list(range(int(a), int(b or a) + 1))
    return out


def run_one(task: str, seed: int, style: str, modes: list[str], robot: Any) -> list[dict[str, Any]]:
    """Every mode's run of one simulated demonstration."""
    from lfd.errors import LfdError
    from lfd.preprocessing import preprocess
    from lfd.reproduce import PREPROCESSING, from_hand_labels
    from lfd.reproduce.two_arms import reproduce_two_arms
    from lfd.sim import Variability, simulate

    demo = simulate(task, seed=seed, variability=Variability(style=style)).demo
    hands = from_hand_labels(
        demo.labels, demo.start_ns, sides=demo.sides, handovers=demo.handovers, objects=demo.objects
    )
    trajs = {s: preprocess(demo.one_hand(s), **PREPROCESSING) for s in demo.sides}
    rows = []
    for mode in modes:
        t = time.perf_counter()
        row: dict[str, Any] = {"task": task, "seed": seed, "style": style, "mode": mode}
        try:
            r = reproduce_two_arms(trajs, hands, mode, robot=robot)
        except LfdError as err:
            row |= {"success": False, "refused": str(err), "failures": [f"refused: {err}"]}
        else:
            row |= {
                "success": r.success,
                "arms": {s: r.arm_success(s) for s in r.skills},
                "failures": r.failures,
                "collisions": [c.describe() for c in r.collisions],
            }
        row["seconds"] = time.perf_counter() - t
        rows.append(row)
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--tasks", nargs="+", default=["hold_push", "handover", "hold_stack", "carry"])
    ap.add_argument("--seeds", nargs="+", default=["301-310"], help="e.g. 301-310 or 101 102")
    ap.add_argument("--style", default="careful")
    ap.add_argument("--modes", nargs="+", default=["skills", "dmp"])
    ap.add_argument("--robot", default="aloha", help="a two-arm robot (lfd.reproduce.ROBOTS)")
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    from lfd.reproduce.robots import any_robot

    robot = any_robot(args.robot)
    rows: list[dict[str, Any]] = []
    t_all = time.perf_counter()
    for task in args.tasks:
        for seed in seeds_of(args.seeds):
            for row in run_one(task, seed, args.style, args.modes, robot):
                rows.append(row)
                ok = "achieved" if row["success"] else "FAILED"
                print(f"{task} {seed} {row['mode']}: {ok} ({row['seconds']:.0f} s)", flush=True)
                for f in row["failures"]:
                    print(f"    {f}", flush=True)
    print(f"\n{time.perf_counter() - t_all:.0f} s in all\n")
    print("| task | " + " | ".join(args.modes) + " | failures |")
    print("|---|" + "---|" * len(args.modes) + "---|")
    for task in args.tasks:
        sel = [r for r in rows if r["task"] == task]
        cells = []
        for mode in args.modes:
            runs = [r for r in sel if r["mode"] == mode]
            cells.append(f"{sum(r['success'] for r in runs)}/{len(runs)}")
        failed: Counter[str] = Counter()
        for r in sel:
            if not r["success"]:
                failed[f"{r['seed']} {r['mode']}"] += 1
        why = ", ".join(failed) or "none"
        print(f"| `{task}` | " + " | ".join(cells) + f" | {why} |")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"settings": vars(args), "rows": rows}, fh, indent=1)


if __name__ == "__main__":
    main()
