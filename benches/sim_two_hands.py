"""The two-hand simulated experiments: segmentation of both hands, and perception of both hands.

Run: ``MUJOCO_GL=egl python benches/sim_two_hands.py [--seeds 700-705] [--perceive 700-702]
[--out /tmp/lfd_two_hands] [--json out.json]``

Held-out seeds (the demonstrator was written and looked at on seeds 0-11, 300-303 and 500-510;
these are 700-705 unless told otherwise; perception 700-702, about 2 minutes a recording), the
four two-hand experiments (``handover``, ``carry``, ``hold_stack``, ``hold_push``), careful and
natural styles:

1. **Segmentation** (``lfd.segment_hands`` with its defaults) of the simulated recordings
   against the simulator's ground truth: a demonstration is *exact* when every hand's skill
   sequence is the true one and every true handover is found (same giver and taker, end within
   0.3 s) with no false one.
2. **Perception** (the ``--perceive`` seeds): ``lfd record --source sim:TASK[:natural]`` (both
   hands, the depth network, 5 Hz) and the same demonstration's true keypoints at the
   perceived sample times (:func:`lfd.sim.demonstrator.truth_demonstration`) are both
   segmented; they *agree* when every hand's skill sequence and the handovers are the same.
   The keypoint error of each hand (mean over keypoints, median over samples) is printed too.

Both tables are printed as Markdown.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

TASKS = ("handover", "carry", "hold_stack", "hold_push")
STYLES = ("careful", "natural")


def seeds_of(spec: str) -> list[int]:
    a, _, b = spec.partition("-")
    return list(range(int(a), int(b or a) + 1))


def handovers_match(pred: list[Any], true: list[Any], tol_ns: int = 300_000_000) -> bool:
    """Every true handover found once (giver, taker, |end - end| <= 0.3 s), none false."""
    left = list(pred)
    for h in true:
        hit = next(
            (
                p
                for p in left
                if p.giver == h.giver and p.taker == h.taker and abs(p.end_ns - h.end_ns) <= tol_ns
            ),
            None,
        )
        if hit is None:
            return False
        left.remove(hit)
    return not left


def sequences(result: Any) -> dict[str, list[str]]:
    return {side: list(seg.skill_sequence) for side, seg in result.lanes.items()}


def segmentation_table(seeds: list[int]) -> list[dict[str, Any]]:
    import lfd
    from lfd.sim import Variability, simulate

    rows = []
    for style in STYLES:
        for task in TASKS:
            for seed in seeds:
                demo = simulate(task, seed, Variability(style=style)).demo
                t0 = time.perf_counter()
                res = lfd.segment_hands(demo)
                ms = 1e3 * (time.perf_counter() - t0)
                true = {s: [lab.skill for lab in demo.labels_of(s)] for s in demo.sides}
                pred = sequences(res)
                lanes = {s: pred[s] == true[s] for s in demo.sides}
                ho = handovers_match(res.handovers, demo.handovers)
                rows.append(
                    {
                        "style": style,
                        "task": task,
                        "seed": seed,
                        "lanes_exact": lanes,
                        "handovers_ok": ho,
                        "exact": all(lanes.values()) and ho,
                        "ms": ms,
                        "pred": pred,
                        "true": true,
                    }
                )
    return rows


def perceive(task: str, style: str, seed: int, out: Path) -> Path:
    """``lfd record --source sim:...`` into ``out`` (cached)."""
    path = out / f"{task}_{style}_{seed}.mcap"
    if not path.exists():
        spec = f"sim:{task}" + (":natural" if style == "natural" else "")
        cmd = [sys.executable, "-m", "lfd.cli", "record", "--source", spec, "--seed", str(seed)]
        subprocess.run([*cmd, "-o", str(path)], check=True, capture_output=True)
    return path


def perception_table(seeds: list[int], out: Path) -> list[dict[str, Any]]:
    import lfd
    import numpy as np
    from lfd.sim import Variability, simulate
    from lfd.sim.demonstrator import truth_demonstration

    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for style in STYLES:
        for task in TASKS:
            for seed in seeds:
                t0 = time.perf_counter()
                path = perceive(task, style, seed, out)
                rec_s = time.perf_counter() - t0
                seen = lfd.load(path)
                result = simulate(task, seed, Variability(style=style))
                times = {s: h.t_ns for s, h in seen.hands.items()}
                truth = truth_demonstration(result, times.get("right"), times.get("left"))
                a, b = lfd.segment_hands(seen), lfd.segment_hands(truth)
                err = {}
                for side, h in seen.hands.items():
                    ok = np.isfinite(h.keypoints).all(axis=(1, 2))
                    d = np.linalg.norm(h.keypoints[ok] - truth.hands[side].keypoints[ok], axis=2)
                    err[side] = float(np.median(d.mean(axis=1))) * 1e3 if ok.any() else float("nan")
                lanes = {s: sequences(a).get(s) == sequences(b)[s] for s in truth.sides}
                ho = handovers_match(a.handovers, b.handovers)
                rows.append(
                    {
                        "style": style,
                        "task": task,
                        "seed": seed,
                        "sides": list(seen.sides),
                        "agree": all(lanes.values()) and ho,
                        "lanes_agree": lanes,
                        "keypoint_error_mm": err,
                        "record_s": rec_s,
                        "perceived": sequences(a),
                        "true_keypoints": sequences(b),
                    }
                )
                print(".", end="", file=sys.stderr, flush=True)
    print(file=sys.stderr)
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", default="700-705")
    ap.add_argument("--perceive", default="700-702", help="seeds recorded by perception ('' none)")
    ap.add_argument("--out", default="/tmp/lfd_two_hands")
    ap.add_argument("--json")
    args = ap.parse_args()
    os.environ.setdefault("MUJOCO_GL", "egl")
    rows = segmentation_table(seeds_of(args.seeds))
    print("| style | task | exact per-hand sequences, handovers included | lanes exact | ms |")
    print("|---|---|---|---|---|")
    for style in STYLES:
        for task in (*TASKS, "all"):
            sel = [r for r in rows if r["style"] == style and task in (r["task"], "all")]
            ex = sum(r["exact"] for r in sel)
            lanes = sum(sum(r["lanes_exact"].values()) for r in sel)
            ms = sum(r["ms"] for r in sel) / len(sel)
            print(f"| {style} | {task} | {ex}/{len(sel)} | {lanes}/{2 * len(sel)} | {ms:.0f} |")
    report: dict[str, Any] = {"segmentation": rows}
    if args.perceive:
        prow = perception_table(seeds_of(args.perceive), Path(args.out))
        report["perception"] = prow
        print()
        print("| style | task | perceived = true keypoints | keypoint error mm (R / L) |")
        print("|---|---|---|---|")
        for style in STYLES:
            for task in (*TASKS, "all"):
                sel = [r for r in prow if r["style"] == style and task in (r["task"], "all")]
                ag = sum(r["agree"] for r in sel)
                er = [r["keypoint_error_mm"] for r in sel]
                e_r = sum(e.get("right", 0.0) for e in er) / len(er)
                e_l = sum(e.get("left", 0.0) for e in er) / len(er)
                print(f"| {style} | {task} | {ag}/{len(sel)} | {e_r:.1f} / {e_l:.1f} |")
    if args.json:
        Path(args.json).write_text(json.dumps(report, indent=1, default=str))


if __name__ == "__main__":
    main()
