"""End to end: simulate -> render -> perceive (``lfd record``) -> segment, against the truth.

Run: ``python benches/perception_e2e.py [--tasks exp1,exp2,exp3,exp4] [--seeds 3,5,7]
[--model PATH] [--keep DIR]``.

Every demonstration is recorded through the real perception path (tags from the rendered
images, the hand from the depth network at 5 Hz) and compared with the simulator's ground
truth: hand keypoint error, box position error and visibility, and the skill sequence and
boundaries segmented (DP search, grammar enforced, as ``lfd reproduce --segment``) from the
perceived recording against those segmented from the noise-free truth
(:func:`lfd.sim.truth_demonstration`, hand sampled at the same times).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tasks", default="exp1,exp2,exp3,exp4")
    parser.add_argument("--seeds", default="3,5,7")
    parser.add_argument("--model", help="hand weights (default: shipped)")
    parser.add_argument("--keep", help="keep the recordings in this directory")
    args = parser.parse_args()

    import lfd
    from lfd.io import load
    from lfd.perception.hand.infer import HandEstimator
    from lfd.perception.record import record
    from lfd.perception.sources import SimSource
    from lfd.segmentation.metrics import boundary_error, frame_accuracy
    from lfd.sim import truth_demonstration

    out_dir = Path(args.keep or tempfile.mkdtemp())
    out_dir.mkdir(parents=True, exist_ok=True)
    est = HandEstimator(args.model, threads=2)
    kw = {"search": "dp", "grammar": "enforce"}
    rows, hand_err = [], []
    t_start = time.perf_counter()
    for seed in (int(s) for s in args.seeds.split(",")):
        for task in args.tasks.split(","):
            src = SimSource(task, seed=seed)
            result, truth = src.result, src.result.truth
            path = out_dir / f"{task}_{seed}.mcap"
            if not path.exists():
                record(src, path, estimator=est)
            demo = load(path)
            idx = np.searchsorted(truth.t_ns, demo.hand.t_ns)
            ok = np.all(np.isfinite(demo.hand.keypoints), axis=(1, 2))
            e = np.linalg.norm(demo.hand.keypoints[ok] - truth.keypoints[idx[ok]], axis=2)
            e = e.mean(axis=1) * 1e3
            hand_err.append(e)
            seen = np.mean([len(o) / truth.t_ns.size for o in demo.objects.values()])
            want = lfd.segment(truth_demonstration(result, demo.hand.t_ns), **kw)
            got = lfd.segment(demo, **kw)
            same = got.skill_sequence == want.skill_sequence
            labels = result.demo.skill_sequence
            rows.append((same, got.skill_sequence == labels, want.skill_sequence == labels))
            print(
                f"{task} seed {seed}: hand {ok.sum()}/{ok.size} estimates, error mean "
                f"{e.mean():.1f} / median {np.median(e):.1f} / max {e.max():.0f} mm; boxes seen "
                f"{seen:.0%} | sequence {'same' if same else 'DIFFERENT'} (= labels: perceived "
                f"{rows[-1][1]}, truth {rows[-1][2]}), frame accuracy "
                f"{frame_accuracy(got.segments, result.demo.labels):.1%} (truth "
                f"{frame_accuracy(want.segments, result.demo.labels):.1%}), boundary error "
                f"{boundary_error(got.segments, result.demo.labels):.2f} s",
                flush=True,
            )
            if not same:
                print(f"    truth:     {want.skill_sequence}\n    perceived: {got.skill_sequence}")
    e = np.concatenate(hand_err)
    print(
        f"\n{sum(r[0] for r in rows)}/{len(rows)} perceived recordings segment like the true "
        f"keypoints ({sum(r[1] for r in rows)}/{len(rows)} match the labels; the true keypoints "
        f"{sum(r[2] for r in rows)}/{len(rows)}); hand error "
        f"over {e.size} estimates: mean {e.mean():.1f} mm, median {np.median(e):.1f} mm, 90th "
        f"pct {np.percentile(e, 90):.1f} mm ({time.perf_counter() - t_start:.0f} s)"
    )


if __name__ == "__main__":
    main()
