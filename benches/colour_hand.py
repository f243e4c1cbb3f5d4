"""The hand from colour alone, on real footage: MediaPipe's metric landmarks placed by PnP
(``lfd.perception.hand.lift.lift_from_colour``) on every frame of a real video.

The footage is ``../shared/realhands/video/hand_test_video.mp4`` (a real hand filmed by a phone,
25 fps, 640x360, no depth, no labels; Apache-2.0). It has no intrinsics: an assumed pinhole
camera with ``fx = fy = 0.9 * width`` (a phone's main camera, about 58 degrees across) and the
principal point at the centre (``--focal`` changes the factor). Printed per video: the frames
with a hand, the handedness labels, each bone's length relative to its median over the video
(the largest and the 95th percentile of ``|length / median - 1|``), the wrist's largest and 95th
percentile step between frames, and the median distance of the wrist.

Run: ``python benches/colour_hand.py [--video FILE] [--focal 0.9]``.
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
VIDEO = ROOT.parent / "shared" / "realhands" / "video" / "hand_test_video.mp4"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--video", default=str(VIDEO))
    ap.add_argument("--focal", type=float, default=0.9, help="fx = fy = FOCAL * width (0.9)")
    args = ap.parse_args()

    import cv2
    from lfd.demo import HAND_BONES
    from lfd.perception.hand.lift import lift_from_colour
    from lfd.perception.hand.mediapipe import HandTracker, MediaPipeHands

    cap = cv2.VideoCapture(args.video)
    if not cap.isOpened():
        sys.exit(f"cannot open {args.video}")
    w = cap.get(cv2.CAP_PROP_FRAME_WIDTH)
    h = cap.get(cv2.CAP_PROP_FRAME_HEIGHT)
    f = args.focal * w
    K = np.array([[f, 0.0, w / 2], [0.0, f, h / 2], [0.0, 0.0, 1.0]])
    tracker = HandTracker(MediaPipeHands(), max_hands=1)
    frames, found, labels = 0, [], []
    while True:
        ok, bgr = cap.read()
        if not ok:
            break
        frames += 1
        hands = tracker.update(cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB))
        if hands:
            hand = max(hands, key=lambda x: x.score)
            found.append(hand)
            labels.append(hand.handedness)
    cap.release()
    print(f"{args.video}: {frames} frames, {int(w)}x{int(h)}, assumed fx = fy = {f:.0f} px")
    print(f"hand found in {len(found)} frames ({100 * len(found) / max(frames, 1):.1f} %)")
    print(f"handedness: {dict(Counter(labels))}")
    if len(found) < 2:
        return

    def bones(p: np.ndarray) -> np.ndarray:
        return np.array([np.linalg.norm(p[a] - p[b]) for a, b in HAND_BONES])

    model = np.array([bones(hand.world) for hand in found])
    # the skeletons: the landmark model's hand as it comes, and the same with fixed bones (the
    # median over the frames so far: what a recording knows as it goes)
    variants = {
        "landmark model's bones": None,
        "bones fixed (running median)": "running",
        "bones fixed (median of the whole video, offline)": "whole",
    }
    for name, how in variants.items():
        points = []
        for k, hand in enumerate(found):
            upto = len(model) if how == "whole" else k + 1
            lengths = None if how is None else np.median(model[:upto], axis=0)
            lifted = lift_from_colour(
                hand.keypoints_2d, hand.world, K, score=hand.score, lengths=lengths
            )
            if lifted is not None:
                points.append(lifted.points)
        P = np.array(points)
        lengths = np.array([bones(p) for p in P])
        dev = np.abs(lengths / np.median(lengths, axis=0) - 1)
        steps = np.linalg.norm(np.diff(P[:, 0], axis=0), axis=1)
        print(
            f"{name}: placed in {len(P)} frames; bone length vs its median: largest "
            f"{100 * dev.max():.0f} %, 95th percentile {100 * np.percentile(dev, 95):.0f} %; "
            f"wrist step between frames: largest {100 * steps.max():.1f} cm, 95th percentile "
            f"{100 * np.percentile(steps, 95):.1f} cm; wrist distance median "
            f"{np.median(P[:, 0, 2]):.2f} m"
        )


if __name__ == "__main__":
    main()
