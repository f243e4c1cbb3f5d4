"""Success of skills and dmp over randomised layouts, per experiment (issue 18).

Usage::

    MUJOCO_GL=egl python benches/reproduce_randomised.py --seeds 20 21 22 23 24 --layouts 1 \
        --json randomised.json [--robot panda]

Experiments: exp1-4 and exp5 (repeated pick-carry-place cycles of one box). For every
experiment and held-out seed: simulate a demonstration (``lfd.sim``), preprocess it,
take its ground-truth task program (or ``--segment``: the segmentation's), draw ``--layouts``
layouts with every object shifted up to ``--max-shift`` m and turned up to ``--max-turn`` deg
(reachable, collision-free: :func:`lfd.reproduce.random_layouts`) and execute each with the
requested modes on ``--robot`` (default the KUKA LWR 4+; the layouts are checked against that
robot's reach, so two robots get the same layouts where both reach them). Prints success per
experiment and mode, per skill, and the failure reasons.
The issue's target: 100 layouts per experiment, skills and dmp >= 95%.

Two arms (``--robot aloha``, issue 42): the two-hand experiments (default ``hold_push`` and
``handover``) in each of ``--styles`` (default careful and natural); each demonstration's
two-hand program of ground-truth labels runs on both arms over the layouts
(:func:`lfd.reproduce.two_arms_randomise.reproduce_two_arms_randomised`), and the table adds
each arm's success. A demonstration the arms cannot do at all (e.g. a held box wider than the
gripper) is reported as refused, with its reason, and counted as no layout::

    MUJOCO_GL=egl python benches/reproduce_randomised.py --robot aloha --seeds 9501 9502 \
        --layouts 25 --json two_arms.json
"""

from __future__ import annotations

import argparse
import json
import time
from collections import Counter
from typing import Any


def run_two_arms(job: tuple[str, int, str], args: Any) -> tuple[dict[str, Any], float]:
    """One two-hand demonstration's layouts on two arms (a worker of
    :func:`lfd.batch.run_batch`)."""
    from lfd.errors import LfdError
    from lfd.preprocessing import preprocess
    from lfd.reproduce import PREPROCESSING, from_hand_labels
    from lfd.reproduce.robots import any_robot
    from lfd.reproduce.two_arms_randomise import reproduce_two_arms_randomised
    from lfd.sim import Variability, simulate

    exp, seed, style = job
    demo = simulate(exp, seed=seed, variability=Variability(style=style)).demo
    hands = from_hand_labels(
        demo.labels, demo.start_ns, sides=demo.sides, handovers=demo.handovers, objects=demo.objects
    )
    trajs = {s: preprocess(demo.one_hand(s), **PREPROCESSING) for s in demo.sides}
    head = {"experiment": f"{exp}:{style}", "seed": seed, "program": hands.to_json()}
    t = time.perf_counter()
    try:
        res = reproduce_two_arms_randomised(
            trajs,
            hands,
            args.layouts,
            modes=args.modes,
            seed=args.layout_seed + seed,
            max_shift=args.max_shift,
            max_turn_deg=args.max_turn,
            robot=any_robot(args.robot),  # type: ignore[arg-type]
        )
    except LfdError as err:
        return head | {"refused": str(err), "layouts": [], "summary": {}}, time.perf_counter() - t
    return head | res.to_json(), time.perf_counter() - t


def run_demo(job: tuple[str, int], args: Any) -> tuple[dict[str, Any], float]:
    """One held-out demonstration's layouts (a worker of :func:`lfd.batch.run_batch`)."""
    from lfd.preprocessing import preprocess
    from lfd.reproduce import PREPROCESSING, from_labels, from_segmentation, reproduce_randomised
    from lfd.segmentation import segment
    from lfd.sim import simulate

    exp, seed = job
    demo = simulate(exp, seed=seed).demo
    traj = preprocess(demo, **PREPROCESSING)
    t0 = int(traj.t_ns[0])
    program = from_segmentation(segment(demo), t0) if args.segment else from_labels(demo.labels, t0)
    t = time.perf_counter()
    res = reproduce_randomised(
        traj,
        program,
        args.layouts,
        modes=args.modes,
        seed=args.layout_seed + seed,
        max_shift=args.max_shift,
        max_turn_deg=args.max_turn,
        robot=args.robot,
    )
    doc = res.to_json()
    return {"experiment": exp, "seed": seed, "program": program.skills, **doc}, (
        time.perf_counter() - t
    )


def main() -> None:
    from functools import partial

    from lfd.batch import run_batch

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument(
        "--experiments", nargs="+", help="default exp1-exp5 (two arms: hold_push handover)"
    )
    ap.add_argument("--styles", nargs="+", default=["careful", "natural"], help="two arms only")
    ap.add_argument("--seeds", nargs="+", type=int, default=[20, 21, 22, 23, 24])
    ap.add_argument("--layouts", type=int, default=1, help="layouts per demonstration")
    ap.add_argument("--modes", nargs="+", default=["skills", "dmp"])
    ap.add_argument("--max-shift", type=float, default=0.10)
    ap.add_argument("--max-turn", type=float, default=45.0)
    ap.add_argument("--layout-seed", type=int, default=0)
    ap.add_argument("--segment", action="store_true", help="segment instead of ground truth")
    ap.add_argument("--robot", default="kuka_lwr4", help="the robot (lfd.reproduce.ROBOTS)")
    ap.add_argument("--json", default=None)
    ap.add_argument("--jobs", type=int, default=1, help="demonstrations run in parallel")
    args = ap.parse_args()
    from lfd.reproduce.robots import TWO_ARM_ROBOTS

    two = args.robot in TWO_ARM_ROBOTS
    if not args.experiments:
        two_hand = ["hold_push", "handover"]
        args.experiments = two_hand if two else ["exp1", "exp2", "exp3", "exp4", "exp5"]
    rows: list[dict[str, Any]] = []
    t_all = time.perf_counter()
    if two:
        jobs: list[Any] = [
            (exp, seed, style)
            for exp in args.experiments
            for style in args.styles
            for seed in args.seeds
        ]
        worker: Any = partial(run_two_arms, args=args)
        args.experiments = [f"{exp}:{style}" for exp in args.experiments for style in args.styles]
    else:
        jobs = [(exp, seed) for exp in args.experiments for seed in args.seeds]
        worker = partial(run_demo, args=args)
    failed: list[str] = []

    def report(res: Any) -> None:
        """Print one demonstration's line as soon as it is done, and keep the JSON up to date
        (a run stopped early keeps what it finished)."""
        if not res.ok:
            failed.append(f"{res.item}: {res.error}")
            print(failed[-1], flush=True)
            return
        row, took = res.value
        rows.append(row)
        print_row(args, row, took, two)
        if args.json:
            write_json(args.json, args, rows)

    run_batch(worker, jobs, jobs=args.jobs, progress=report)
    if failed:
        raise SystemExit(failed[0])
    rows.sort(key=lambda r: (args.experiments.index(r["experiment"]), args.seeds.index(r["seed"])))
    print(f"\n{time.perf_counter() - t_all:.0f} s in all")
    print_table(args, rows, two)
    if args.json:
        write_json(args.json, args, rows)


def write_json(path: str, args: Any, rows: list[dict[str, Any]]) -> None:
    """The settings and the rows so far, replacing ``path`` whole (atomically)."""
    from lfd.outputs import atomic_write_text

    atomic_write_text(path, json.dumps({"settings": vars(args), "rows": rows}, indent=1))


def print_row(args: Any, row: dict[str, Any], took: float, two: bool) -> None:
    """One demonstration's success per mode, its redrawn layouts and its failures."""
    exp, seed = row["experiment"], row["seed"]
    if row.get("refused"):
        print(f"{exp} seed {seed}: refused: {row['refused']}", flush=True)
        return
    line = " ".join(
        f"{m} {sum(lay['results'][m]['success'] for lay in row['layouts'] if m in lay['results'])}"
        f"/{args.layouts}"
        for m in args.modes
    )
    print(f"{exp} seed {seed}: {line} ({took:.0f} s)", flush=True)
    for lay in row["layouts"]:
        if two and lay["rejected"]:
            why = ", ".join(f"{k} {v}" for k, v in lay["rejected"].items())
            print(f"    layout {lay.get('index')}: drawn again for {why}", flush=True)
        for m, r in lay["results"].items():
            for f in r.get("failures", []):
                print(f"    layout {lay.get('index')} {m}: {f}", flush=True)


def print_table(args: Any, rows: list[dict[str, Any]], two: bool) -> None:
    """Success per experiment and mode, per skill (of two arms: per arm), and the reasons."""
    print("experiment  mode    success      per skill (ok/total)                      reasons")
    for exp in args.experiments:
        for mode in args.modes:
            sel = [lay for row in rows if row["experiment"] == exp for lay in row["layouts"]]
            runs = [lay["results"][mode] for lay in sel if mode in lay["results"]]
            ok = sum(r["success"] for r in runs)
            skills: dict[str, list[int]] = {}
            reasons: Counter[str] = Counter()
            for row in rows:
                if row["experiment"] != exp or row.get("refused"):
                    continue
                for k, (a, b) in row["summary"][mode]["skills"].items():
                    c = skills.setdefault(k, [0, 0])
                    c[0] += a
                    c[1] += b
                reasons.update(row["summary"][mode]["reasons"])
            per_skill = " ".join(f"{k} {a}/{b}" for k, (a, b) in skills.items())
            if two:
                per_arm = Counter(
                    a for r in runs for a, good in (r.get("arms") or {}).items() if good
                )
                per_skill = " ".join(f"{a} arm {v}/{len(runs)}" for a, v in per_arm.items()) + (
                    f" | {per_skill}"
                )
                refused = sum(1 for row in rows if row["experiment"] == exp and row.get("refused"))
                if refused:
                    per_skill += f" | {refused} demonstration(s) refused"
            why = ", ".join(f"{k} {v}" for k, v in reasons.most_common()) or "-"
            pct = 100 * ok / max(len(runs), 1)
            print(f"{exp:10}  {mode:6}  {ok:3}/{len(runs):<3} {pct:5.1f}%  {per_skill:40}  {why}")


if __name__ == "__main__":
    main()
