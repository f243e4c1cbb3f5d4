"""Tune the change-point baseline's penalty on training demos only (issue 13).

Run: ``MUJOCO_GL=egl python benches/changepoint_penalty.py [--out /tmp/lfd_cpd_train]``

Simulates the training demos (careful-style demonstrator, exp1-4 x seeds 0-29; the held-out seeds
300-399 and 1000+ are never used here), preprocesses each once and scores
:func:`lfd.segmentation.changepoint.changepoint_segmentation` at every penalty of a grid against the
simulator's ground truth. Prints the tuning curve (penalty vs mean frame accuracy, exact
sequences, boundary error) and the penalty with the highest mean frame accuracy, which is
:data:`lfd.segmentation.changepoint.DEFAULT_PENALTY`.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from segment_robustness import simulate_condition  # same folder: benches/

PENALTIES = (0.02, 0.05, 0.1, 0.2, 0.3, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 5.0, 10.0)
TRAINING_SEEDS = range(30)


def main() -> int:
    from lfd.io import load
    from lfd.segmentation.changepoint import DEFAULT_PENALTY, changepoint_segmentation
    from lfd.segmentation.metrics import all_metrics
    from lfd.segmentation.pipeline import as_trajectory

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="/tmp/lfd_cpd_train", help="where to write the recordings")
    ap.add_argument("--seeds", type=int, default=len(TRAINING_SEEDS), help="seeds 0..N-1 (<= 30)")
    args = ap.parse_args()
    if not 1 <= args.seeds <= len(TRAINING_SEEDS):
        ap.error(f"--seeds must be 1..{len(TRAINING_SEEDS)} (training seeds only)")
    paths = simulate_condition(Path(args.out), {}, range(args.seeds))
    demos = [load(p) for p in paths]
    trajs = [as_trajectory(d) for d in demos]
    print(f"{len(demos)} training demos (exp1-4 x seeds 0-{args.seeds - 1})")
    print()
    print("| penalty | frame acc. | exact | boundary error s | ms / demo |")
    print("|---|---|---|---|---|")
    best = (-1.0, 0.0)
    for pen in PENALTIES:
        rows = []
        t0 = time.perf_counter()
        for demo, traj in zip(demos, trajs, strict=True):
            seg = changepoint_segmentation(traj, penalty=pen)
            rows.append(all_metrics(seg.segments, demo.labels))
        ms = 1e3 * (time.perf_counter() - t0) / len(demos)
        acc = float(np.mean([r["frame_accuracy"] for r in rows]))
        exact = int(sum(r["sequence_match"] for r in rows))
        be = float(np.mean([r["boundary_error_s"] for r in rows]))
        print(f"| {pen:g} | {100 * acc:.1f} % | {exact}/{len(rows)} | {be:.3f} | {ms:.0f} |")
        if acc > best[0]:
            best = (acc, pen)
    print()
    print(f"best penalty {best[1]:g} (frame accuracy {100 * best[0]:.1f} %); ", end="")
    print(f"DEFAULT_PENALTY is {DEFAULT_PENALTY:g}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
