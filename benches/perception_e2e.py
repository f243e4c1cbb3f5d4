"""End to end: simulate -> render -> perceive (``lfd record``) -> segment, against the truth.

Run: ``python benches/perception_e2e.py [--tasks exp1,exp2,exp3,exp4] [--seeds 3,5,7]
[--model PATH] [--keep DIR] [--colour-only mediapipe|truth-landmarks]``.

Every demonstration is recorded through the real perception path (tags from the rendered
images, the hand from the depth network at 5 Hz) and compared with the simulator's ground
truth: hand keypoint error, box position error and visibility, and the skill sequence and
boundaries segmented (DP search, grammar enforced, as ``lfd reproduce --segment``) from the
perceived recording against those segmented from the noise-free truth
(:func:`lfd.sim.truth_demonstration`, hand sampled at the same times).

``--colour-only``: the frames' depth is dropped (the empty-workspace calibration frame's too):
the tags by PnP alone and the hand placed from colour (``ColourHand``, as ``lfd record
--source video:`` does), at the same 5 Hz hand times. ``mediapipe``: MediaPipe Hands on every
frame (``MediaPipeEstimator``, the path of a real webcam; it rarely finds the simulator's
capsule hand). ``truth-landmarks``: the detector replaced by the truth, as in
``benches/colour_vs_depth.py``: the true 2-D keypoints and, as the landmark model's metric hand,
the true hand centred, scaled by 0.8-1.2 per frame, with 5 mm noise per keypoint
(``--landmark-noise``); the hand is found when the centre of its palm and at least 17 of its 21
keypoints are in the image (MediaPipe tracks a hand partly out of the image; ``--whole-hand``:
all 21, as in ``benches/colour_vs_depth.py``). Both are
given the simulated hand's true length as the hand size (``lfd record --hand-size``), unless
``--no-hand-size``. The hand error is then the colour-only placement's.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np


def colour_only(
    src: Any,
    kind: str,
    seed: int,
    sized: bool,
    noise_m: float = 0.005,
    whole: bool = False,
    noise_px: float = 0.0,
) -> Any:
    """Make ``src`` (a ``SimSource``) colour-only and return the hand estimator of ``kind``,
    given the simulated hand's true length when ``sized``."""
    from lfd.perception.hand.colour import hand_length
    from lfd.perception.hand.rgbd import MediaPipeEstimator
    from lfd.perception.sources import Frame

    frames, calibration = src.frames, src.calibration_frame
    src.has_depth = False
    truth = src.result.truth
    size = float(np.median([hand_length(k) for k in truth.keypoints])) if sized else None
    if kind == "mediapipe":
        est: Any = MediaPipeEstimator("right", threads=2, hand_size=size)
    else:
        est = TruthLandmarks(truth, seed, size, noise_m, whole, noise_px)

    def colour_frames() -> Iterator[Any]:
        for frame in frames():
            est.t_ns = frame.t_ns
            yield Frame(frame.t_ns, frame.color, None)

    def colour_calibration() -> Any:
        frame = calibration()
        return None if frame is None else Frame(frame.t_ns, frame.color, None)

    src.frames, src.calibration_frame = colour_frames, colour_calibration
    return est


PALM = (0, 5, 9, 13, 17)
"""Wrist and finger bases: the stand-in finds the hand when their centre is in the image..."""
MIN_IN_IMAGE = 17
"""...and at least this many of its 21 keypoints (MediaPipe tracks a hand partly out of the
image, its landmarks outside it; ``--whole-hand``: all 21 in the image, as before)."""


class TruthLandmarks:
    """A stand-in for MediaPipe fed every frame: the true 2-D keypoints and the true hand,
    centred, scaled by 0.8-1.2 and with 5 mm noise per keypoint, as the landmark model's
    metric hand, placed by ``ColourHand`` (with ``hand_size``, m, when given)."""

    needs_colour = True

    def __init__(
        self,
        truth: Any,
        seed: int,
        hand_size: float | None,
        noise_m: float = 0.005,
        whole: bool = False,
        noise_px: float = 0.0,
    ) -> None:
        from lfd.perception.hand.colour import ColourHand

        self.truth = truth
        self.rng = np.random.default_rng(seed)
        self.colour = ColourHand(hand_size)
        self.noise_m = noise_m
        self.noise_px = noise_px
        self.whole = whole
        self.t_ns = 0
        self.last_missing = True
        self.info = {"model": "truth landmarks"}

    def lifting(self, depth: bool) -> str:
        return "colour pnp (true 2-D landmarks)"

    def feed(self, color, depth_mm, K, world_T_camera, boxes):  # type: ignore[no-untyped-def]
        """As ``MediaPipeEstimator.feed``: frames held until the bones are fixed."""
        hand = self._landmarks(color, K, world_T_camera)
        restart = hand is None or self.last_missing
        self.last_missing = hand is None
        placed = self.colour.push((hand, world_T_camera), hand, K, restart=restart)
        return [_estimate(h, w, lifted) for (h, w), lifted in placed]

    def drain(self):  # type: ignore[no-untyped-def]
        return [_estimate(h, w, lifted) for (h, w), lifted in self.colour.release()]

    def _landmarks(self, color, K, world_T_camera):  # type: ignore[no-untyped-def]
        from lfd.perception.hand.mediapipe import Hand, Rect

        if world_T_camera is None:
            return None
        i = int(np.searchsorted(self.truth.t_ns, self.t_ns))
        c_T_w = np.linalg.inv(world_T_camera)
        kp = self.truth.keypoints[i] @ c_T_w[:3, :3].T + c_T_w[:3, 3]
        uv = kp[:, :2] / kp[:, 2:] * [K[0, 0], K[1, 1]] + K[:2, 2]
        h, w = np.asarray(color).shape[:2]
        inside = (uv[:, 0] >= 0) & (uv[:, 1] >= 0) & (uv[:, 0] < w - 1) & (uv[:, 1] < h - 1)
        palm = uv[list(PALM)].mean(axis=0)
        palm_in = 0 <= palm[0] < w - 1 and 0 <= palm[1] < h - 1
        if not (inside.all() if self.whole else palm_in and inside.sum() >= MIN_IN_IMAGE):
            return None
        world = (kp - kp.mean(axis=0)) * self.rng.uniform(0.8, 1.2)
        world = world + self.rng.normal(0.0, self.noise_m, (21, 3))
        if self.noise_px > 0:
            uv = uv + self.rng.normal(0.0, self.noise_px, uv.shape)
        return Hand(uv, np.zeros(21), world, "right", 1.0, 1.0, Rect(0.0, 0.0, 1.0, 0.0))


def _estimate(hand: Any, world_T_camera: Any, lifted: Any) -> Any:
    from lfd.perception.hand.rgbd import HandEstimate

    if hand is None or lifted is None:
        return None
    pts = lifted.to_world(world_T_camera)
    return HandEstimate(pts, lifted.confidence, lifted.visible, hand)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tasks", default="exp1,exp2,exp3,exp4")
    parser.add_argument("--seeds", default="3,5,7")
    parser.add_argument("--model", help="hand weights (default: shipped)")
    parser.add_argument("--keep", help="keep the recordings in this directory")
    parser.add_argument(
        "--colour-only",
        choices=("mediapipe", "truth-landmarks"),
        help="drop depth: tags by PnP, the hand placed from colour (see above)",
    )
    parser.add_argument(
        "--no-hand-size",
        action="store_true",
        help="colour only: no hand size (default: the simulated hand's true length, as "
        "lfd record --hand-size)",
    )
    parser.add_argument(
        "--landmark-noise",
        type=float,
        default=5.0,
        help="truth-landmarks: noise per keypoint of the metric hand, mm (default 5)",
    )
    parser.add_argument(
        "--landmark-px",
        type=float,
        default=0.0,
        help="truth-landmarks: noise per image landmark, pixels per axis (default 0)",
    )
    parser.add_argument(
        "--whole-hand",
        action="store_true",
        help="truth-landmarks: the hand is found only when all 21 keypoints are in the image",
    )
    args = parser.parse_args()

    import lfd
    from lfd.errors import LfdError
    from lfd.io import load
    from lfd.perception.hand.infer import HandEstimator
    from lfd.perception.record import record
    from lfd.perception.sources import SimSource
    from lfd.segmentation.metrics import boundary_error, frame_accuracy
    from lfd.sim import truth_demonstration

    out_dir = Path(args.keep or tempfile.mkdtemp())
    out_dir.mkdir(parents=True, exist_ok=True)
    est = None if args.colour_only else HandEstimator(args.model, threads=2)
    kw = {"search": "dp", "grammar": "enforce"}
    rows, hand_err = [], []
    t_start = time.perf_counter()
    for seed in (int(s) for s in args.seeds.split(",")):
        for task in args.tasks.split(","):
            src = SimSource(task, seed=seed)
            result, truth = src.result, src.result.truth
            suffix = f"_{args.colour_only}_every" if args.colour_only else ""
            suffix += "_nosize" if args.colour_only and args.no_hand_size else ""
            if args.colour_only == "truth-landmarks" and args.landmark_noise != 5.0:
                suffix += f"_noise{args.landmark_noise:g}"
            if args.colour_only == "truth-landmarks" and args.landmark_px:
                suffix += f"_px{args.landmark_px:g}"
            if args.colour_only == "truth-landmarks" and args.whole_hand:
                suffix += "_whole"
            path = out_dir / f"{task}_{seed}{suffix}.mcap"
            if not path.exists():
                if args.colour_only:
                    estimator = colour_only(
                        src,
                        args.colour_only,
                        seed,
                        not args.no_hand_size,
                        args.landmark_noise * 1e-3,
                        args.whole_hand,
                        args.landmark_px,
                    )
                else:
                    estimator = est
                # colour only: the hand on every frame, as `lfd record` does with MediaPipe
                rate = None if args.colour_only else 5.0
                record(src, path, estimator=estimator, hand_rate_hz=rate)
            demo = load(path)
            idx = np.searchsorted(truth.t_ns, demo.hand.t_ns)
            ok = np.all(np.isfinite(demo.hand.keypoints), axis=(1, 2))
            e = np.linalg.norm(demo.hand.keypoints[ok] - truth.keypoints[idx[ok]], axis=2)
            e = e.mean(axis=1) * 1e3
            hand_err.append(e)
            if e.size == 0:
                e = np.full(1, np.nan)
            seen = np.mean([len(o) / truth.t_ns.size for o in demo.objects.values()])
            want = lfd.segment(truth_demonstration(result, demo.hand.t_ns), **kw)
            try:
                got = lfd.segment(demo, **kw)
            except LfdError as err:  # e.g. colour only with MediaPipe: (almost) no hand found
                rows.append((False, False, want.skill_sequence == result.demo.skill_sequence))
                print(f"{task} seed {seed}: hand {ok.sum()}/{ok.size} estimates; not segmented: "
                      f"{err}", flush=True)  # fmt: skip
                continue
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
    e = np.concatenate([*hand_err, np.full(0, np.nan)])
    e = e if e.size else np.full(1, np.nan)
    print(
        f"\n{sum(r[0] for r in rows)}/{len(rows)} perceived recordings segment like the true "
        f"keypoints ({sum(r[1] for r in rows)}/{len(rows)} match the labels; the true keypoints "
        f"{sum(r[2] for r in rows)}/{len(rows)}); hand error "
        f"over {e.size} estimates: mean {e.mean():.1f} mm, median {np.median(e):.1f} mm, 90th "
        f"pct {np.percentile(e, 90):.1f} mm ({time.perf_counter() - t_start:.0f} s)"
    )


if __name__ == "__main__":
    main()
