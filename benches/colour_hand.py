"""The hand from colour alone, on real footage: ``lfd record --source video:FILE`` (no depth) and
MediaPipe's metric landmarks placed by PnP on real photographs.

The footage is ``../shared/realhands/video/hand_test_video.mp4`` (a real hand filmed by a phone,
25 fps, 640x360, no depth, no labels; Apache-2.0). It has no intrinsics: an assumed pinhole
camera with ``fx = fy = 0.9 * width`` (a phone's main camera, about 58 degrees across) and the
principal point at the centre (``--focal`` changes the factor), written as a ``camera.json`` in
a temporary folder.

1. **The landmark model alone** (``lift_from_colour`` per frame, no recorder): the bones of
   MediaPipe's metric hand relative to their median over the video (its raw variation), and
   the wrist's step between frames with those bones or with fixed ones.
2. **Through the recorder**: ``lfd record --source video:FILE --intrinsics camera.json`` (the
   skeleton measured over the first 30 confident hands, which are held until it is fixed, the
   distance voted by the bones, the causal distance filter), once per
   ``--hand`` side and once with ``--hand-size 0.19``; the recording is read back
   (``lfd.io.mcapfile.read``: ``lfd.load`` refuses a recording without any object pose, and
   this video has no tags; the hand is on ``/hand/<side>/keypoints_camera``, the camera frame,
   as the reference tag is never seen). Printed: the frames with the requested hand (handedness stable:
   the other side is found in none), each placed bone relative to its median over the video,
   largest and 95th percentile over all frames (the 20 bones
   the skeleton imposes; the wrist-pinky distance follows the palm), the wrist's largest and
   95th percentile step between frames and its median distance.
3. **Photographs** (``../shared/realhands``, 25 photos, 27 hands): hands found by MediaPipe and
   placed in metres from colour (each photo with the same assumed intrinsics).

Run: ``python benches/colour_hand.py [--video FILE] [--focal 0.9] [--realhands DIR]``.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
REALHANDS = ROOT.parent / "shared" / "realhands"
VIDEO = REALHANDS / "video" / "hand_test_video.mp4"


def intrinsics(width: int, height: int, focal: float) -> np.ndarray:
    """The assumed pinhole camera: fx = fy = focal * width, principal point at the centre."""
    f = focal * width
    return np.array([[f, 0.0, width / 2], [0.0, f, height / 2], [0.0, 0.0, 1.0]])


def landmark_model(video: str, K: np.ndarray) -> None:
    """Part 1: the landmark model's bones and the wrist path per frame, without the recorder."""
    import cv2
    from lfd.perception.hand.colour import bone_lengths
    from lfd.perception.hand.lift import lift_from_colour
    from lfd.perception.hand.mediapipe import HandTracker, MediaPipeHands

    cap = cv2.VideoCapture(video)
    tracker = HandTracker(MediaPipeHands(), max_hands=1)
    found = []
    while True:
        ok, bgr = cap.read()
        if not ok:
            break
        hands = tracker.update(cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB))
        if hands:
            found.append(max(hands, key=lambda x: x.score))
    cap.release()
    model = np.array([bone_lengths(hand.world) for hand in found])
    variants = {
        "landmark model's bones": None,
        "bones fixed (median of the whole video, offline)": np.median(model, axis=0),
    }
    for name, lengths in variants.items():
        points = []
        for hand in found:
            lifted = lift_from_colour(hand.keypoints_2d, hand.world, K, lengths=lengths)
            if lifted is not None:
                points.append(lifted.points)
        P = np.array(points)
        dev = np.abs(model / np.median(model, axis=0) - 1)
        steps = np.linalg.norm(np.diff(P[:, 0], axis=0), axis=1)
        bones = f"bones vs their median: largest {100 * dev.max():.0f} %, 95th percentile "
        bones += f"{100 * np.percentile(dev, 95):.0f} %; " if lengths is None else ""
        print(
            f"  {name}: placed in {len(P)}/{len(found)} frames; "
            + (bones if lengths is None else "")
            + f"wrist step largest {100 * steps.max():.1f} cm, 95th percentile "
            f"{100 * np.percentile(steps, 95):.1f} cm"
        )


def camera_frame_hand(raw: Any, side: str) -> tuple[np.ndarray, np.ndarray]:
    """The hand of a recording without the reference tag: keypoints (n, 21, 3) and confidence
    (n, 21) of ``/hand/<side>/keypoints_camera`` (camera frame), one sample per hand time of the
    world topic (NaN where none was found)."""
    from foxglove_schemas_protobuf.PosesInFrame_pb2 import PosesInFrame

    t_world = raw.tracks[f"/hand/{side}/keypoints"]["t_ns"]
    kp = np.full((len(t_world), 21, 3), np.nan)
    conf = np.zeros((len(t_world), 21))
    index = {int(t): i for i, t in enumerate(t_world)}
    for t, data in raw.encoded(f"/hand/{side}/keypoints_camera"):
        msg = PosesInFrame.FromString(data)
        kp[index[t]] = [[p.position.x, p.position.y, p.position.z] for p in msg.poses]
    for t, data in raw.encoded(f"/hand/{side}/confidence_camera"):
        conf[index[t]] = json.loads(data)["confidence"]
    return kp, conf


def recorded(video: str, camera_json: Path, out: Path, *extra: str) -> dict[str, float]:
    """Part 2: one ``lfd record`` run; the figures of the hand read back from the file."""
    from lfd.cli import main
    from lfd.io.mcapfile import read
    from lfd.perception.hand.colour import bone_lengths

    argv = ["record", "--source", f"video:{video}", "--intrinsics", str(camera_json)]
    if main([*argv, "-o", str(out), "--overwrite", *extra]) != 0:
        sys.exit(f"lfd record failed on {video}")
    raw = read(out, images=False)
    side = "left" if "left" in extra else "right"
    meta = json.loads(raw.metadata["demo"]["metadata"])
    kp, confidence = camera_frame_hand(raw, side)
    seen = np.isfinite(kp).all(axis=(1, 2))
    res: dict[str, float] = {"frames": len(kp), "found": int(seen.sum())}
    res["depth"] = meta["depth"]
    res["hand_lifting"] = meta.get("hand_lifting")
    if seen.sum() < 2:
        return res
    P = kp[seen]
    B = np.array([bone_lengths(p) for p in P])
    dev = np.abs(B / np.median(B, axis=0) - 1)
    imposed = np.delete(dev, 17, axis=1)  # bone 17 (wrist-pinky) is not imposed
    steps = np.linalg.norm(np.diff(P[:, 0], axis=0), axis=1)
    res.update(
        bones_max=float(imposed.max()),
        bones_p95=float(np.percentile(imposed, 95)),
        frames_over_10pct=int((imposed.max(axis=1) > 0.10).sum()),
        wrist_pinky_max=float(dev[:, 17].max()),
        step_max=float(steps.max()),
        step_p95=float(np.percentile(steps, 95)),
        distance_median=float(np.median(P[:, 0, 2])),
        confidence_median=float(np.median(confidence[seen])),
    )
    return res


def photos(realhands: Path, focal: float) -> tuple[int, int, int]:
    """Part 3: (hands expected, found, placed in metres) on the photographs."""
    import cv2
    from lfd.perception.hand.lift import lift_from_colour
    from lfd.perception.hand.mediapipe import MediaPipeHands

    model = MediaPipeHands()
    expected = found = placed = 0
    for js in sorted(realhands.glob("*.json")):
        doc = json.loads(js.read_text())
        rgb = cv2.cvtColor(cv2.imread(str(realhands / doc["image"])), cv2.COLOR_BGR2RGB)
        n = doc.get("expected_num_hands", len(doc.get("hands", [])))
        hands = model.detect(rgb)
        K = intrinsics(rgb.shape[1], rgb.shape[0], focal)
        ok = [lift_from_colour(h.keypoints_2d, h.world, K, score=h.score) for h in hands]
        expected += n
        found += min(len(hands), n)
        placed += min(sum(p is not None for p in ok), n)
    return expected, found, placed


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--video", default=str(VIDEO))
    ap.add_argument("--focal", type=float, default=0.9, help="fx = fy = FOCAL * width (0.9)")
    ap.add_argument("--realhands", default=str(REALHANDS))
    args = ap.parse_args()

    import cv2

    cap = cv2.VideoCapture(args.video)
    if not cap.isOpened():
        sys.exit(f"cannot open {args.video}")
    w = int(cap.get(cv2.CAP_PROP_FRAME_WIDTH))
    h = int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT))
    cap.release()
    K = intrinsics(w, h, args.focal)
    print(f"{args.video}: {w}x{h}, assumed fx = fy = {K[0, 0]:.0f} px, centred principal point")
    print("1. the landmark model alone, per frame:")
    landmark_model(args.video, K)
    print("2. through lfd record --source video: (read back from the recording):")
    with tempfile.TemporaryDirectory() as tmp:
        camera_json = Path(tmp) / "camera.json"
        camera_json.write_text(json.dumps({"width": w, "height": h, "K": K.tolist()}))
        runs = {
            "--hand right": ("--hand", "right"),
            "--hand left": ("--hand", "left"),
            "--hand right --hand-size 0.19": ("--hand", "right", "--hand-size", "0.19"),
        }
        for name, extra in runs.items():
            r = recorded(args.video, camera_json, Path(tmp) / "rec.mcap", *extra)
            line = (
                f"  {name}: hand in {r['found']}/{r['frames']} frames "
                f"({100 * r['found'] / r['frames']:.1f} %); metadata depth={r['depth']}, "
                f"hand_lifting={r['hand_lifting']!r}"
            )
            if "step_max" in r:
                line += (
                    f"; bones vs their median: largest {100 * r['bones_max']:.1f} %, 95th "
                    f"percentile {100 * r['bones_p95']:.1f} % "
                    f"({r['frames_over_10pct']} frames over 10 %), "
                    f"wrist-pinky {100 * r['wrist_pinky_max']:.0f} %; wrist step largest "
                    f"{100 * r['step_max']:.1f} cm, 95th percentile {100 * r['step_p95']:.1f} "
                    f"cm; wrist distance median {r['distance_median']:.2f} m; confidence "
                    f"median {r['confidence_median']:.2f}"
                )
            print(line)
    realhands = Path(args.realhands)
    if realhands.is_dir():
        n, found, placed = photos(realhands, args.focal)
        print(
            f"3. photographs ({realhands}): {found}/{n} hands found ({100 * found / n:.0f} %), "
            f"{placed}/{n} placed in metres from colour"
        )


if __name__ == "__main__":
    main()
