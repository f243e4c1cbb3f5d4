"""The real-camera hand path: MediaPipe Hands + depth lifting (docs/results.md, Perception).

Run: ``MUJOCO_GL=egl python benches/hands_realcam.py [--realhands ../shared/realhands]``

1. **Real photographs** (``../shared/realhands``: 25 photos, 22 hands with MediaPipe-full
   reference keypoints, 5 hands in 4 photos with only a count): hands found, mean / max keypoint
   error in pixels against the reference.
2. **Speed** at 640 x 480 on one core (TFLite with one thread): real hands (cut out of the shared
   photos) moving over a table with a depth image, two hands in view, the right one recorded.
   Per frame: tracking + landmarks + lifting (``lfd record``'s path), against the reference of
   running palm detection + landmarks on every frame (MediaPipe's static-image mode).
3. **Lifting alone** on rendered scenes of the simulator's hand with known intrinsics and true
   keypoints (true 2-D projections as the "detector", relative depth from the truth with scale
   error and noise): 3-D error in mm.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))


def photos(realhands: Path) -> dict[str, float]:
    import cv2
    from lfd.perception.hand.mediapipe import MediaPipeHands

    model = MediaPipeHands()
    errors, counted, expected, times = [], 0, 0, []
    for js in sorted(realhands.glob("*.json")):
        doc = json.loads(js.read_text())
        rgb = cv2.cvtColor(cv2.imread(str(realhands / doc["image"])), cv2.COLOR_BGR2RGB)
        t = time.perf_counter()
        hands = model.detect(rgb)
        times.append(time.perf_counter() - t)
        if doc["annotation_type"] == "hand_count_only":
            counted += min(len(hands), doc["expected_num_hands"])
            expected += doc["expected_num_hands"]
            print(f"  {doc['image']}: {len(hands)} of {doc['expected_num_hands']} hands")
            continue
        for ref in doc["hands"]:
            r = np.asarray(ref["keypoints_2d"], float)
            err = [float(np.linalg.norm(h.keypoints_2d - r, axis=1).mean()) for h in hands]
            errors.append(min(err) if err and min(err) < 30 else np.nan)
    e = np.asarray(errors)
    found = int(np.isfinite(e).sum())
    return {
        "reference_hands": len(e),
        "found": found,
        "mean_px": float(np.nanmean(e)),
        "max_px": float(np.nanmax(e)),
        "count_only_found": counted,
        "count_only_expected": expected,
        "detect_ms": 1000 * float(np.median(times)),
    }


def speed(realhands: Path, frames: int) -> dict[str, float]:
    import _realhand_scene as S
    from lfd.perception.hand.lift import lift_keypoints
    from lfd.perception.hand.mediapipe import MediaPipeHands, select_hand
    from lfd.perception.hand.rgbd import MediaPipeEstimator

    hands = S.cutouts(realhands)
    clip = [S.frame(hands, f % 20)[:2] for f in range(frames)]
    est = MediaPipeEstimator("right", threads=1)
    for c, d in clip[:3]:
        est.estimate_frame(c, d, S.K, S.WORLD_T_CAMERA, [])
    t_track = []
    for c, d in clip:
        t = time.perf_counter()
        got = est.estimate_frame(c, d, S.K, S.WORLD_T_CAMERA, [])
        t_track.append(time.perf_counter() - t)
        assert got is not None
    model = MediaPipeHands(threads=1)
    t_detect = []
    for c, d in clip:
        t = time.perf_counter()
        hand = select_hand(model.detect(c), "right")
        assert hand is not None
        lift_keypoints(hand.keypoints_2d, hand.relative_z, d, S.K, score=hand.score)
        t_detect.append(time.perf_counter() - t)
    tr, de = np.median(t_track), np.median(t_detect)
    return {
        "frames": frames,
        "track_ms": 1000 * float(tr),
        "track_p99_ms": 1000 * float(np.percentile(t_track, 99)),
        "track_fps": float(1 / tr),
        "detect_ms": 1000 * float(de),
        "detect_fps": float(1 / de),
        "ratio": float(de / tr),
        "palm_runs": est.tracker.palm_runs,
    }


def lifting(seeds: list[int], per_seed: int) -> dict[str, float]:
    from _hand_render import render_views
    from lfd.perception.hand.lift import lift_keypoints

    err, vis = [], []
    for seed in seeds:
        for v in render_views(per_seed, seed=seed):
            got = lift_keypoints(v.uv, v.relative_z, v.depth_mm, v.K, exclude=v.box_mask)
            assert got is not None
            err.append(np.linalg.norm(got.points - v.keypoints, axis=1))
            vis.append(got.visible)
    e, m = np.concatenate(err), np.concatenate(vis)
    return {
        "views": len(err),
        "mean_mm": 1000 * float(e.mean()),
        "median_mm": 1000 * float(np.median(e)),
        "p95_mm": 1000 * float(np.percentile(e, 95)),
        "measured_fraction": float(m.mean()),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--realhands", default=str(ROOT.parent / "shared" / "realhands"))
    parser.add_argument("--frames", type=int, default=150, help="frames timed (150)")
    parser.add_argument("--seeds", default="0,5,7,11", help="render seeds of the lifting test")
    parser.add_argument("--views", type=int, default=24, help="rendered views per seed (24)")
    parser.add_argument("--json", help="write every number here")
    args = parser.parse_args()
    realhands = Path(args.realhands)
    print("real photographs:")
    p = photos(realhands)
    print(
        f"  {p['found']}/{p['reference_hands']} reference hands, mean {p['mean_px']:.2f} px, "
        f"max {p['max_px']:.2f} px; count-only photos {p['count_only_found']}/"
        f"{p['count_only_expected']} hands; {p['detect_ms']:.0f} ms per photo"
    )
    s = speed(realhands, args.frames)
    print(
        f"640x480, one core, two hands in view: tracking + lifting {s['track_ms']:.1f} ms "
        f"({s['track_fps']:.0f} frames/s, p99 {s['track_p99_ms']:.1f} ms, {s['palm_runs']} palm "
        f"detections in {s['frames']} frames) vs detecting every frame {s['detect_ms']:.1f} ms "
        f"({s['detect_fps']:.0f} frames/s): {s['ratio']:.2f}x"
    )
    lf = lifting([int(x) for x in args.seeds.split(",")], args.views)
    print(
        f"lifting alone, {lf['views']} rendered views: mean {lf['mean_mm']:.1f} mm, median "
        f"{lf['median_mm']:.1f} mm, p95 {lf['p95_mm']:.1f} mm, "
        f"{100 * lf['measured_fraction']:.0f} % of joints measured (others from relative z)"
    )
    if args.json:
        Path(args.json).write_text(json.dumps({"photos": p, "speed": s, "lifting": lf}, indent=2))


if __name__ == "__main__":
    main()
