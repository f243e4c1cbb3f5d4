"""Colour only against RGB-D on renders of the simulator's scene, over a range of distances.

The simulated demonstration (``--task``, ``--seed``) is rendered (colour and true depth,
640x480, f = 615 px) with the camera moved along its viewing line to each ``--distances``
(metres from the camera to the workspace point it looks at, ``lfd.sim.scene.CameraSpec``'s
target; the default camera is at 0.79 m). Per distance:

- **Hand**: a window of ``--frames`` consecutive frames taken every ``--step`` camera frames
  from the middle of the demonstration, through two ``MediaPipeEstimator`` instances (the
  estimator of ``lfd record``): with the depth image (MediaPipe on colour lifted with depth) and
  without (``ColourHand``: the skeleton measured over the first confident hands, each keypoint
  on its viewing ray, the distance voted by the bones and smoothed; ``estimate_frame``, one
  frame at a time, no frames held), the latter once with the landmark model's hand size and once with
  ``hand_size`` = the simulated hand's true length (``lfd record --hand-size``). Printed: the
  frames in which each finds the hand (the simulator's hand is a capsule hand: MediaPipe does
  not find it in every frame) and the 3-D keypoint error against the simulator's true
  keypoints, the mean over the 21 keypoints per frame, then its mean and 95th percentile over
  the frames (on the frames both paths found, so the columns compare the same frames).
- **Hand, landmarks from the truth** (the detector replaced, as in ``benches/hands_realcam.py``
  part 3, since MediaPipe rarely finds the capsule hand): on the frames whose 21 true keypoints
  project inside the image, the true 2-D keypoints; for the depth path the true relative depth
  with a 0.8-1.2 scale error and 5 mm noise (``--scale-error``, ``--noise-mm``) (``tests/_hand_render.relative_z_from_truth``)
  lifted with the rendered depth (``lift_keypoints``, boxes and table excluded as the recorder
  does); for the colour path the true hand in the camera frame, centred, as the landmark
  model's metric hand, with the same kind of error (the whole hand scaled by 0.8-1.2 per frame,
  5 mm noise per keypoint), placed by ``ColourHand`` frame after frame (without and with the
  true hand size). Mean keypoint error per frame, then mean / 95th percentile over frames.
- **Tags**: ``MarkerTracker.process(color, depth)`` against ``process(color, None)`` (PnP
  alone). The boxes' poses on the same frames with the camera pose known (so only the box
  tags' error counts): position error (mm) and angle error (deg) against the true box poses,
  mean and 95th percentile over every box seen; and the camera pose found from the reference
  tag on an empty-workspace frame (hand out of view): position (mm) and angle (deg) error.

The camera pose and intrinsics are the renderer's (exact). Run:
``python benches/colour_vs_depth.py [--task exp1] [--seed 3] [--distances 0.5,0.7,0.9,1.2]
[--frames 60] [--step 2]`` (about a minute per distance on 2 CPUs).
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # _hand_render


def camera_at(distance: float) -> Any:
    """The default camera moved along its viewing line to ``distance`` m from its target."""
    from lfd.sim.scene import CameraSpec

    cam = CameraSpec()
    target = np.asarray(cam.target, float)
    direction = np.asarray(cam.position, float) - target
    position = target + distance * direction / np.linalg.norm(direction)
    return CameraSpec(position=tuple(float(v) for v in position), target=cam.target)


def hand_errors(
    color: Any, depth: Any, truth_kp: np.ndarray, K: np.ndarray, T: np.ndarray, **kw: Any
) -> np.ndarray:
    """Per frame: the mean keypoint error (m) of one estimator run, NaN where no hand."""
    from lfd.perception.hand.rgbd import MediaPipeEstimator

    est = MediaPipeEstimator("right", threads=2, **kw)
    err = np.full(len(color.frames), np.nan)
    for k in range(len(color.frames)):
        d = None if depth is None else depth.frames[k]
        found = est.estimate_frame(color.frames[k], d, K, T)
        if found is not None and np.isfinite(found.keypoints).all():
            err[k] = np.linalg.norm(found.keypoints - truth_kp[k], axis=1).mean()
    return err


def oracle_errors(
    color: Any,
    depth: Any,
    truth_kp: np.ndarray,
    cam: Any,
    boxes: list[Any],
    seed: int,
    scale_error: float = 0.2,
    noise_m: float = 0.005,
) -> dict[str, np.ndarray]:
    """Per frame, the mean keypoint error (m) of the depth lifting and of ``ColourHand``
    (without / with the true hand size) fed the true 2-D landmarks with a landmark model's
    errors (see the module notes); NaN where the hand is not wholly in the image."""
    from _hand_render import relative_z_from_truth
    from lfd.perception.hand.colour import ColourHand, hand_length
    from lfd.perception.hand.lift import lift_keypoints
    from lfd.perception.hand.mediapipe import Hand, Rect
    from lfd.perception.hand.rgbd import not_hand_mask

    rng = np.random.default_rng(seed)
    K, T = cam.intrinsics(), cam.world_T_camera()
    camera_T_world = np.linalg.inv(T)
    n = len(color.frames)
    size = float(np.median([hand_length(k) for k in truth_kp]))
    placers = {"colour": ColourHand(), "colour_size": ColourHand(size)}
    out = {k: np.full(n, np.nan) for k in ("rgbd", *placers)}
    for k in range(n):
        kp_c = truth_kp[k] @ camera_T_world[:3, :3].T + camera_T_world[:3, 3]
        uv = kp_c[:, :2] / kp_c[:, 2:] * [K[0, 0], K[1, 1]] + K[:2, 2]
        inside = (uv >= 0).all() and (uv[:, 0] < cam.width - 1).all()
        if not (inside and (uv[:, 1] < cam.height - 1).all() and (kp_c[:, 2] > 0).all()):
            for placer in placers.values():
                placer.lost()
            continue
        lo, hi = uv.min(0) - 20, uv.max(0) + 20
        region = (*np.floor(lo).astype(int), *np.ceil(hi).astype(int))
        exclude = not_hand_mask(depth.frames[k], K, T, boxes[k], region)  # type: ignore[arg-type]
        rel = relative_z_from_truth(
            kp_c, K[0, 0], rng, noise_m=noise_m, scale_range=(1 - scale_error, 1 + scale_error)
        )
        lifted = lift_keypoints(uv, rel, depth.frames[k], K, exclude=exclude)
        if lifted is not None:
            out["rgbd"][k] = np.linalg.norm(lifted.to_world(T) - truth_kp[k], axis=1).mean()
        scale = rng.uniform(1 - scale_error, 1 + scale_error)
        world = (kp_c - kp_c.mean(axis=0)) * scale + rng.normal(0, noise_m, (21, 3))
        hand = Hand(uv, rel, world, "right", 1.0, 1.0, Rect(0.0, 0.0, 1.0, 0.0))
        for name, placer in placers.items():
            placed = placer.place(hand, K)
            if placed is not None:
                err = np.linalg.norm(placed.to_world(T) - truth_kp[k], axis=1).mean()
                out[name][k] = err
    return out


def tag_errors(result: Any, scene: Any, color: Any, depth: Any, frames: np.ndarray) -> Any:
    """(position errors m, angle errors deg) of every box seen, with or without ``depth``."""
    from lfd.perception.markers import MarkerConfig, MarkerTracker
    from scipy.spatial.transform import Rotation

    cfg = MarkerConfig.from_objects(scene.objects)
    cam = scene.camera
    trk = MarkerTracker(cfg, cam.intrinsics(), world_T_camera=cam.world_T_camera())
    truth = result.truth
    pos, ang = [], []
    for k, i in enumerate(frames):
        seen = trk.process(color.frames[k], None if depth is None else depth.frames[k])
        for name, (p, q) in seen.poses.items():
            pos.append(np.linalg.norm(p - truth.object_pos[name][i]))
            rt = Rotation.from_euler("z", truth.object_yaw[name][i])
            ang.append(np.rad2deg((rt.inv() * Rotation.from_quat(q)).magnitude()))
    return np.array(pos), np.array(ang)


def reference_error(result: Any, scene: Any, use_depth: bool) -> tuple[float, float] | None:
    """Camera pose error (m, deg) found from the reference tag, hand out of view."""
    from lfd.perception.markers import MarkerConfig, MarkerTracker
    from lfd.sim.render import render_frames
    from scipy.spatial.transform import Rotation

    truth = result.truth
    away = replace(truth, wrist_pos=truth.wrist_pos.copy())
    away.wrist_pos[0] = (0.0, -1.2, 1.5)
    color, depth = render_frames(scene, away, np.array([0]))
    assert depth is not None
    trk = MarkerTracker(MarkerConfig.from_objects(scene.objects), scene.camera.intrinsics())
    trk.process(color.frames[0], depth.frames[0] if use_depth else None)
    if trk.world_T_camera is None:
        return None
    want = scene.camera.world_T_camera()
    got = trk.world_T_camera
    dp = float(np.linalg.norm(got[:3, 3] - want[:3, 3]))
    da = float(np.rad2deg(Rotation.from_matrix(want[:3, :3].T @ got[:3, :3]).magnitude()))
    return dp, da


def true_boxes(result: Any, scene: Any, i: int) -> list[Any]:
    """The boxes (centre, R, size) at frame ``i`` of the simulation (what the recorder gets from
    the tags), for excluding them from the hand's depth."""
    from scipy.spatial.transform import Rotation

    truth = result.truth
    return [
        (
            np.asarray(truth.object_pos[o.name][i]),
            Rotation.from_euler("z", truth.object_yaw[o.name][i]).as_matrix(),
            np.asarray(o.size),
        )
        for o in scene.objects
    ]


def _stats(x: np.ndarray, scale: float) -> str:
    x = x[np.isfinite(x)]
    if x.size == 0:
        return "-"
    return f"{scale * x.mean():.1f} / {scale * np.percentile(x, 95):.1f}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--task", default="exp1")
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--distances", default="0.5,0.7,0.9,1.2")
    ap.add_argument("--frames", type=int, default=60, help="hand frames per distance (60)")
    ap.add_argument("--step", type=int, default=2, help="every STEP camera frames (2: 15 Hz)")
    ap.add_argument(
        "--scale-error", type=float, default=0.2, help="landmarks from the truth: 3-D scale error"
    )
    ap.add_argument("--noise-mm", type=float, default=5.0, help="... and noise per keypoint, mm")
    args = ap.parse_args()

    from lfd.perception.hand.colour import hand_length
    from lfd.sim import simulate
    from lfd.sim.render import render_frames
    from lfd.sim.scene import build_scene

    t0 = time.perf_counter()
    result = simulate(args.task, seed=args.seed)
    truth = result.truth
    n = truth.t_ns.size
    span = args.frames * args.step
    start = max(0, (n - span) // 2)
    frames = np.arange(start, min(n, start + span), args.step)
    size = float(np.median([hand_length(truth.keypoints[i]) for i in frames]))
    print(
        f"{args.task} seed {args.seed}: {frames.size} frames every {args.step} from frame "
        f"{start} of {n} (30 Hz); the simulated hand's length {size:.3f} m"
    )
    head = (
        "distance | hand found: RGB-D / colour / colour+size | hand error mm, mean / p95: "
        "RGB-D | colour | colour + true hand size | boxes mm mean / p95: depth | PnP | box deg "
        "mean / p95: depth | PnP | reference (camera pose) mm, deg: depth | PnP"
    )
    print(head)
    for d in (float(x) for x in args.distances.split(",")):
        scene = build_scene(result.scene.objects, hand_scale=result.scene.hand_scale,
                            camera=camera_at(d))  # fmt: skip
        cam = scene.camera
        K, T = cam.intrinsics(), cam.world_T_camera()
        color, depth = render_frames(scene, truth, frames)
        kp = truth.keypoints[frames]
        rgbd = hand_errors(color, depth, kp, K, T)
        colour = hand_errors(color, None, kp, K, T)
        sized = hand_errors(color, None, kp, K, T, hand_size=size)
        both = np.isfinite(rgbd) & np.isfinite(colour) & np.isfinite(sized)
        m = frames.size
        boxes = [true_boxes(result, scene, i) for i in frames]
        oracle = oracle_errors(
            color, depth, kp, cam, boxes, args.seed, args.scale_error, args.noise_mm / 1e3
        )
        found = np.isfinite(oracle["rgbd"]) & np.isfinite(oracle["colour"])
        print(
            f"{d:.2f} m, landmarks from the truth | hand in the image {found.sum()}/{m} | "
            f"RGB-D {_stats(oracle['rgbd'][found], 1e3)} | colour "
            f"{_stats(oracle['colour'][found], 1e3)} | colour + true hand size "
            f"{_stats(oracle['colour_size'][found], 1e3)}",
            flush=True,
        )
        pd, ad = tag_errors(result, scene, color, depth, frames)
        pc, ac = tag_errors(result, scene, color, None, frames)
        refs = [reference_error(result, scene, u) for u in (True, False)]
        ref = " | ".join("-" if r is None else f"{1e3 * r[0]:.1f}, {r[1]:.2f}" for r in refs)
        print(
            f"{d:.2f} m | {np.isfinite(rgbd).sum()}/{m} / {np.isfinite(colour).sum()}/{m} / "
            f"{np.isfinite(sized).sum()}/{m} | {_stats(rgbd[both], 1e3)} | "
            f"{_stats(colour[both], 1e3)} | {_stats(sized[both], 1e3)} (on {both.sum()} "
            f"frames) | {_stats(pd, 1e3)} | {_stats(pc, 1e3)} ({pd.size}, {pc.size} poses) | "
            f"{_stats(ad, 1)} | {_stats(ac, 1)} | {ref}",
            flush=True,
        )
    print(f"({time.perf_counter() - t0:.0f} s)")


if __name__ == "__main__":
    main()
