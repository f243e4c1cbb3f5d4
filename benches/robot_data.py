"""Robot data from human demonstrations (issue 42): yield, seconds per episode, dataset size.

Usage::

    MUJOCO_GL=egl OMP_NUM_THREADS=1 python benches/robot_data.py --layouts 10 \
        --out /tmp/robot_data --json robot_data.json

For each experiment (exp1-4: ``recordings/expN.mcap``; exp5: simulated with seed 1000, the
samples' seed, and saved beside the datasets) runs ``lfd export robot-data REC -o DIR
--layouts N`` (:func:`lfd.export.robot_data.export_robot_data`, ground-truth program, skills
mode, 10 Hz, 160x120 images, libsvtav1) and prints per experiment: the yield (successful /
tried layouts), the seconds per tried layout (drawing it, simulating, rendering), the seconds
per episode (everything, the dataset's encoding and writing included, over the episodes), the
dataset's size and its size per episode, and the failure reasons. Rerunning the same command
resumes an interrupted experiment (an experiment whose dataset exists is read back, not redone).

Two arms (``--robot aloha``): the two-hand experiments (default all four: ``handover``,
``hold_push``, ``carry``, ``hold_stack``) simulated with ``--sim-seed`` (default 9501, held out) in ``--style`` (default careful) and
saved beside the datasets, each exported with ``lfd export robot-data REC --robot aloha``::

    MUJOCO_GL=egl OMP_NUM_THREADS=1 nice -n 10 python benches/robot_data.py --robot aloha \
        --layouts 100 --out /tmp/robot_data_aloha --json robot_data_aloha.json
"""

from __future__ import annotations

import argparse
import json
import time
from collections import Counter
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
EXPERIMENTS = ("exp1", "exp2", "exp3", "exp4", "exp5")


def recording(exp: str, out: Path, args: Any) -> Path:
    """The experiment's demonstration: the shipped sample, exp5 simulated (seed 1000), or a
    two-hand experiment simulated (``--sim-seed``, ``--style``)."""
    shipped = ROOT / "recordings" / f"{exp}.mcap"
    if shipped.is_file():
        return shipped
    from lfd.sim import TWO_HAND_EXPERIMENTS

    two = exp in TWO_HAND_EXPERIMENTS
    path = out / (f"{exp}_{args.style}_{args.sim_seed}.mcap" if two else f"{exp}.mcap")
    if not path.is_file():
        import lfd
        from lfd.sim import Variability, simulate

        if two:
            sim = simulate(exp, seed=args.sim_seed, variability=Variability(style=args.style))
        else:
            sim = simulate(exp, seed=1000)
        lfd.save(sim.demo, path)
    return path


def one(exp: str, args: Any) -> dict[str, Any]:
    from lfd.export.robot_data import LAYOUTS_PATH, export_robot_data

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rec = recording(exp, out, args)
    dest = out / exp
    t = time.perf_counter()
    if not (dest / LAYOUTS_PATH).is_file():
        report = export_robot_data(
            rec,
            dest,
            layouts=args.layouts,
            seed=args.seed,
            vcodec=args.vcodec,
            robot=args.robot,
            progress=lambda r, n: print(
                f"{exp} layout {r.index + 1}/{n}: {'ok' if r.success else 'failed'} "
                f"{r.seconds:.1f} s",
                flush=True,
            ),
        )
        write_s = report.write_seconds
    else:
        write_s = float("nan")
    total_s = time.perf_counter() - t
    doc = json.loads((dest / LAYOUTS_PATH).read_text())
    size = sum(f.stat().st_size for f in dest.rglob("*") if f.is_file())
    layouts = doc["layouts"]
    ok = [r for r in layouts if r["success"]]
    reasons: Counter[str] = Counter()
    for r in layouts:
        if not r["success"]:
            for f in r["failures"]:
                reasons[f.split(": ", 1)[-1].split(" (")[0]] += 1
    return {
        "experiment": exp,
        "tried": len(layouts),
        "succeeded": len(ok),
        "yield": len(ok) / max(len(layouts), 1),
        "frames": sum(r["frames"] for r in ok),
        "layout_s": sum(r["seconds"] for r in layouts) / max(len(layouts), 1),
        "write_s": write_s,
        "total_s": total_s,
        "s_per_episode": total_s / max(len(ok), 1),
        "bytes": size,
        "bytes_per_episode": size / max(len(ok), 1),
        "reasons": dict(reasons),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument(
        "--experiments", nargs="+", help="(default exp1-5; aloha: the four two-hand tasks)"
    )
    ap.add_argument("--robot", default="kuka_lwr4", help="kuka_lwr4, panda or aloha (two arms)")
    ap.add_argument("--sim-seed", type=int, default=9501, help="two-hand demos' seed (9501)")
    ap.add_argument("--style", default="careful", help="two-hand demos' style (careful)")
    ap.add_argument("--layouts", type=int, default=10)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--vcodec", default="libsvtav1")
    ap.add_argument("--out", default="/tmp/robot_data")
    ap.add_argument("--json", help="write the figures here")
    args = ap.parse_args()
    if not args.experiments:
        from lfd.sim import TWO_HAND_EXPERIMENTS

        two = args.robot == "aloha"
        args.experiments = list(TWO_HAND_EXPERIMENTS if two else EXPERIMENTS)
    rows = [one(exp, args) for exp in args.experiments]
    print(
        f"{'exp':9} {'yield':>9} {'frames':>7} {'s/layout':>9} {'write s':>8} "
        f"{'s/episode':>10} {'MB':>6} {'MB/ep':>6}  failures"
    )
    for r in rows:
        print(
            f"{r['experiment']:9} {r['succeeded']:>3}/{r['tried']:<3} ({100 * r['yield']:3.0f}%)"
            f" {r['frames']:>6} {r['layout_s']:9.1f} {r['write_s']:8.1f} "
            f"{r['s_per_episode']:10.1f} {r['bytes'] / 1e6:6.2f} "
            f"{r['bytes_per_episode'] / 1e6:6.3f}  {r['reasons']}"
        )
    tried = sum(r["tried"] for r in rows)
    ok = sum(r["succeeded"] for r in rows)
    print(f"all       {ok}/{tried} ({100 * ok / max(tried, 1):.1f} %)")
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1) + "\n")


if __name__ == "__main__":
    main()
