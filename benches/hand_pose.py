"""Hand keypoint network: 3-D keypoint error on held-out renders and CPU speed.

Run: ``python benches/hand_pose.py [--model PATH] [--samples 100] [--seeds 95,96,97,98,99]``.

1. Held-out frames (``randomised_views`` with seeds 95-99, never used for training): mean 3-D
   keypoint error, in mm, of the whole estimator on the hand points of each frame, with one
   point subset or the estimator's ``views`` subsets averaged (the default, second line).
2. End to end on a simulated demonstration (exp1, seed 5, 5 Hz frames): the estimator on the
   rendered depth image (boxes excluded at their true poses, as the recorder does with the tag
   poses) vs the simulator's true keypoints, and frames per second of the whole
   estimate (back-projection + crop + network) and of the network alone.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", help="weights (default: shipped)")
    parser.add_argument("--samples", type=int, default=100, help="frames per seed (100)")
    parser.add_argument("--seeds", default="95,96,97,98,99", help="held-out render seeds")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--frames", type=int, default=40, help="end-to-end frames (40)")
    args = parser.parse_args()

    import torch
    from lfd.perception.hand.dataset import N_POINTS, POINT_DIM
    from lfd.perception.hand.infer import HandEstimator
    from lfd.perception.hand.train import heldout_error_mm
    from lfd.sim import simulate
    from lfd.sim.render import render_frames
    from scipy.spatial.transform import Rotation

    torch.set_num_threads(args.threads)
    est = HandEstimator(args.model)
    path = args.model or "shipped"
    size = os.path.getsize(args.model) if args.model else None
    print(f"model: {path}  ({sum(p.numel() for p in est.model.parameters())} parameters)")
    if size:
        print(f"file size {size / 1e6:.2f} MB")

    # the same held-out frames for every variant (randomised_views is deterministic per seed);
    # each seed draws its poses from four other simulated demonstrations
    seeds = [int(x) for x in args.seeds.split(",")]
    for views in (1, est.views):
        variant = HandEstimator(args.model, views=views)
        err = np.concatenate([heldout_error_mm(variant, args.samples, seed=s) for s in seeds])
        print(
            f"held-out frames (seeds {args.seeds}, n={err.size}; {views} point subset(s)): mean "
            f"keypoint error {err.mean():.1f} mm, median {np.median(err):.1f} mm, 90th pct "
            f"{np.percentile(err, 90):.1f} mm"
        )

    r = simulate("exp1", seed=5)
    step = 6  # 30 Hz camera -> 5 Hz hand estimates
    idx = np.arange(0, r.truth.t_ns.size, step)[: args.frames]
    _, depth = render_frames(r.scene, r.truth, idx)
    assert depth is not None and r.demo.camera is not None
    cam = r.demo.camera
    errs, times = [], []
    for k, i in enumerate(idx):
        boxes = [  # as the recorder passes them: the boxes' (tag) poses
            (
                r.truth.object_pos[o.name][i],
                Rotation.from_euler("z", r.truth.object_yaw[o.name][i]).as_matrix(),
                np.asarray(o.size),
            )
            for o in r.scene.objects
        ]
        t0 = time.perf_counter()
        kp = est.estimate(depth.frames[k], cam.K, cam.world_T_camera, boxes)
        times.append(time.perf_counter() - t0)
        if kp is not None:
            errs.append(np.linalg.norm(kp - r.truth.keypoints[i], axis=1).mean() * 1000)
    e = np.array(errs)
    print(
        f"end to end (exp1 seed 5, {len(idx)} frames, {e.size} with a hand found): mean "
        f"{e.mean():.1f} mm, median {np.median(e):.1f} mm"
    )
    print(
        f"whole estimate ({est.views} point subsets): {1.0 / np.median(times):.0f} frames/s on "
        f"{args.threads} threads"
    )
    x = np.random.default_rng(0).uniform(-0.5, 0.5, (1, N_POINTS, POINT_DIM)).astype(np.float32)
    est.predict(x)
    t0 = time.perf_counter()
    for _ in range(200):
        est.predict(x)
    print(f"network alone: {200 / (time.perf_counter() - t0):.0f} frames/s")


if __name__ == "__main__":
    main()
