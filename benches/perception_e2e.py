"""End to end: simulate -> render -> perceive (``lfd record``) -> segment, against the truth.

Run: ``python benches/perception_e2e.py [--task exp1] [--seed 3] [--model PATH]``.

Records the simulated demonstration through the real perception path (tags from the rendered
images, hand from the depth network at 5 Hz), then reports the hand keypoint error and object
position error against the simulator's ground truth, the tag visibility, and the skill
sequences segmented from (a) the simulator's own noisy streams, (b) the perceived recording,
(c) perceived objects + true hand, (d) true objects + perceived hand.
"""

from __future__ import annotations

import argparse
import copy
import tempfile
import time
from pathlib import Path

import numpy as np


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", default="exp1")
    parser.add_argument("--seed", type=int, default=3)
    parser.add_argument("--model", help="hand weights (default: shipped)")
    args = parser.parse_args()

    import lfd
    from lfd.demo import HandTrack
    from lfd.io import load
    from lfd.perception.hand.infer import HandEstimator
    from lfd.perception.record import record
    from lfd.perception.sources import SimSource

    src = SimSource(args.task, seed=args.seed)
    ref = src.result
    truth = ref.truth
    out = Path(tempfile.mkdtemp()) / "perceived.mcap"
    t0 = time.perf_counter()
    stats = record(src, out, estimator=HandEstimator(args.model, threads=2))
    print(f"recorded {stats.frames} frames in {time.perf_counter() - t0:.0f} s: {stats}")
    demo = load(out)

    idx = np.searchsorted(truth.t_ns, demo.hand.t_ns)
    ok = np.all(np.isfinite(demo.hand.keypoints), axis=(1, 2))
    e = np.linalg.norm(demo.hand.keypoints[ok] - truth.keypoints[idx[ok]], axis=2).mean(axis=1)
    print(
        f"hand: {ok.sum()}/{ok.size} estimates, keypoint error mean {e.mean() * 1e3:.1f} mm, "
        f"median {np.median(e) * 1e3:.1f} mm, 90th pct {np.percentile(e, 90) * 1e3:.1f} mm"
    )
    for name, obj in demo.objects.items():
        t = np.searchsorted(truth.t_ns, obj.t_ns)
        err = np.linalg.norm(obj.position - truth.object_pos[name][t], axis=1) * 1e3
        print(
            f"{name}: visible in {len(obj) / stats.frames:.0%} of frames, position error "
            f"median {np.median(err):.1f} mm, max {err.max():.1f} mm"
        )

    print("truth labels:           ", ref.demo.skill_sequence)
    print("simulator streams:      ", lfd.segment(ref.demo).skill_sequence)
    print("perceived:              ", lfd.segment(demo).skill_sequence)
    d1 = copy.deepcopy(demo)
    d1.hand = HandTrack(demo.hand.t_ns, truth.keypoints[idx], np.ones((idx.size, 21)))
    print("perceived objects+true hand:", lfd.segment(d1).skill_sequence)
    d2 = copy.deepcopy(demo)
    d2.objects = ref.demo.objects
    print("true objects+perceived hand:", lfd.segment(d2).skill_sequence)


if __name__ == "__main__":
    main()
