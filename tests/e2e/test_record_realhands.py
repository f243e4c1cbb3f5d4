"""``lfd record`` with the real-camera hand model on RGB-D frames of real hands, and
``lfd perception hands`` on photos."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import _paths
import numpy as np
import pytest

pytest.importorskip("ai_edge_litert")
pytest.importorskip("cv2")

import _realhand_scene as S
from lfd.perception.hand.lift import JOINT_RADIUS

REALHANDS = _paths.SHARED / "realhands"
pytestmark = pytest.mark.skipif(not REALHANDS.is_dir(), reason=f"no photos at {REALHANDS}")


def _lfd(*argv: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "lfd.cli", *argv], capture_output=True, text=True, timeout=300
    )


@pytest.fixture(scope="module")
def frames(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return S.write_folder(tmp_path_factory.mktemp("realhands_rgbd"), REALHANDS, n=16)


@pytest.mark.parametrize(
    "side",
    ["right", pytest.param("left", marks=pytest.mark.slow)],  # left: the same path mirrored
)
def test_record_picks_the_requested_hand_and_lifts_it(
    frames: Path, tmp_path: Path, side: str
) -> None:
    from lfd.io import load

    out = tmp_path / "rec.mcap"
    argv = ["record", "--source", f"frames:{frames}", "-o", str(out)]
    proc = _lfd(*argv, *(["--hand", side] if side != "right" else []))
    assert proc.returncode == 0, proc.stderr
    demo = load(out)
    hand = demo.hand
    assert hand.side == side
    assert demo.metadata["hand_model"] == "mediapipe-hands-full"
    # every frame estimated (the default rate of the colour model), none missed
    assert hand.t_ns.size == 16
    assert np.isfinite(hand.keypoints).all()
    hands = S.cutouts(REALHANDS)
    for i in range(16):
        _, _, masks = S.frame(hands, i)
        uv = np.round(S.project(hand.keypoints[i])).astype(int)
        on = masks[side][np.clip(uv[:, 1], 0, S.H - 1), np.clip(uv[:, 0], 0, S.W - 1)]
        assert on.mean() >= 0.9, f"frame {i}: keypoints are not on the {side} hand"
    # the depth image shows each hand as a sheet at a known height; joints lie a radius below
    expected = S.HAND_HEIGHT[side] - np.asarray(JOINT_RADIUS)
    err = np.abs(hand.keypoints[:, :, 2] - expected)
    assert err.mean() < 0.005, err.mean()
    assert hand.visible.mean() > 0.8
    assert (hand.confidence[hand.visible] > 0.5).all()


def _on_the_hand(world: np.ndarray, i: int, side: str = "right") -> None:
    """The keypoints ``world`` (21, 3) of frame ``i`` project onto the ``side`` hand's pixels:
    on average within 4 px of them, none farther than :data:`NEAR_PX` (the landmark model's
    metric hand fitted to its image landmarks leaves pixels of error, most at the fingertips,
    which sit at the finger's edge), much nearer than to the other hand."""
    import cv2

    _, _, masks = S.frame(S.cutouts(REALHANDS), i)
    uv = np.round(S.project(world)).astype(int)
    rows, cols = np.clip(uv[:, 1], 0, S.H - 1), np.clip(uv[:, 0], 0, S.W - 1)
    d = {}
    for s, mask in masks.items():
        d[s] = cv2.distanceTransform((~mask).astype(np.uint8), cv2.DIST_L2, 5)[rows, cols]
    other = "left" if side == "right" else "right"
    mine = d[side]
    assert mine.mean() <= 4 and mine.max() <= NEAR_PX, f"frame {i}: {side} hand by {mine} px"
    assert d[other].mean() > 10 * max(mine.mean(), 1), f"frame {i}: near the {other} hand"


NEAR_PX = 30.0


def _colour_only_checks(hand, metadata, n: int, side: str = "right") -> np.ndarray:  # type: ignore[no-untyped-def]
    """Every sample observed on the ``side`` hand's pixels with the colour confidence and the
    same bones; the metadata says no depth was used. Returns the keypoints' camera-frame depth (n, 21)."""
    from lfd.perception.hand.lift import COLOUR_CONFIDENCE

    assert metadata["depth"] is False and metadata["hand_lifting"] == "colour pnp"
    assert hand.t_ns.size == n and np.isfinite(hand.keypoints).all()
    assert ((hand.confidence > 0.2) & (hand.confidence <= COLOUR_CONFIDENCE)).all()
    for i in range(n):
        _on_the_hand(hand.keypoints[i], i, side)
    # one skeleton for the whole recording: the first hands are held until it is measured
    from lfd.perception.hand.colour import bone_lengths

    bones = np.delete(np.array([bone_lengths(k) for k in hand.keypoints]), 17, axis=1)
    np.testing.assert_allclose(bones, np.broadcast_to(bones[0], bones.shape), rtol=1e-9)
    return np.asarray(S.CAMERA_HEIGHT - hand.keypoints[:, :, 2])


HAND_SIZE = 0.19
"""The demonstrator's hand length for ``--hand-size``. The scene's hands are photos pasted at a
depth, not hands of a known size: the distance colour gives them is checked for being plausible
and for following the hand size, not against the pasted depth."""


def test_record_without_depth_places_the_hand_from_colour(frames: Path, tmp_path: Path) -> None:
    """No depth images: the hand is placed from colour (``--hand-size``), on the hand, at the
    distance its size implies; without ``--hand-size`` at the landmark model's hand size."""
    import shutil

    from lfd.io import load

    colour_only = tmp_path / "frames"
    shutil.copytree(frames, colour_only)
    shutil.rmtree(colour_only / "depth")
    argv = ["record", "--source", f"frames:{colour_only}", "--duration", "0.3"]
    out = tmp_path / "rec.mcap"
    proc = _lfd(*argv, "-o", str(out), "--hand-size", str(HAND_SIZE))
    assert proc.returncode == 0, proc.stderr
    demo = load(out)
    depth = _colour_only_checks(demo.hand, demo.metadata, 4)
    wrist = depth[:, 0]
    assert (0.2 < wrist).all() and (wrist < 1.5).all(), wrist
    # the distance follows the hand size: twice the size, twice as far (the fit is scale-free)
    twice = tmp_path / "twice.mcap"
    proc = _lfd(*argv, "-o", str(twice), "--hand-size", str(2 * HAND_SIZE / 1.5))
    assert proc.returncode == 0, proc.stderr
    far = S.CAMERA_HEIGHT - load(twice).hand.keypoints[:, 0, 2]
    np.testing.assert_allclose(far / wrist, 2 / 1.5, rtol=1e-3)


def _video(frames: Path, out: Path, fps: float = 15.0) -> Path:
    """The colour images of a ``frames:`` folder as a video file (MJPG in AVI)."""
    import cv2

    files = sorted((frames / "color").glob("*.png"))
    writer = cv2.VideoWriter(str(out), cv2.VideoWriter_fourcc(*"MJPG"), fps, (S.W, S.H))
    assert writer.isOpened()
    for f in files:
        writer.write(cv2.imread(str(f)))
    writer.release()
    return out


def test_record_video_source(frames: Path, tmp_path: Path) -> None:
    """``--source video:FILE --intrinsics camera.json``: times from the container, the hand
    from colour in every frame, the tagged box by PnP without depth."""
    from lfd.io import load

    video = _video(frames, tmp_path / "demo.avi")
    out = tmp_path / "rec.mcap"
    proc = _lfd(
        "record", "--source", f"video:{video}", "--intrinsics", str(frames / "camera.json"),
        "-o", str(out), "--hand-size", str(HAND_SIZE),
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    demo = load(out)
    assert demo.metadata["source"] == f"video:{video}"
    depth = _colour_only_checks(demo.hand, demo.metadata, 16)
    assert (0.2 < depth[:, 0]).all() and (depth[:, 0] < 1.5).all(), depth[:, 0]
    np.testing.assert_allclose(demo.hand.t_ns, np.arange(16) * 1e9 / 15, atol=1)  # the file's
    box = demo.objects["box_1"]
    assert box.t_ns.size == 16
    assert np.linalg.norm(box.position - S.BOX_CENTRE, axis=1).max() < 0.01
    info = _lfd("info", str(out))
    assert info.returncode == 0, info.stderr
    text = " ".join(info.stdout.split())  # however the console wraps it
    assert "depth=false" in text and 'hand_lifting="colour pnp"' in text


def test_camera_source_without_a_depth_reader_is_colour_only(
    frames: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``--source camera:N --intrinsics camera.json`` and no ``--depth-reader`` (a webcam,
    here a stand-in OpenCV device serving the real-hand frames): the hand from colour."""
    import cv2
    from lfd.cli import main
    from lfd.io import load

    served = [cv2.imread(str(f)) for f in sorted((frames / "color").glob("*.png"))[:6]]

    class Webcam:
        def __init__(self, index: int) -> None:
            self.frames = list(served) if index == 0 else []

        def isOpened(self) -> bool:
            return bool(self.frames)

        def read(self) -> tuple[bool, np.ndarray | None]:
            return (True, self.frames.pop(0)) if self.frames else (False, None)

        def release(self) -> None:
            self.frames = []

    monkeypatch.setattr(cv2, "VideoCapture", Webcam)
    out = tmp_path / "webcam.mcap"
    argv = ["record", "--source", "camera:0", "--intrinsics", str(frames / "camera.json")]
    assert main([*argv, "-o", str(out), "--hand-size", str(HAND_SIZE)]) == 0
    demo = load(out)
    assert demo.metadata["source"] == "camera:0"
    _colour_only_checks(demo.hand, demo.metadata, 6)
    assert demo.objects["box_1"].t_ns.size == 6


def test_record_video_interrupted_with_live_segmentation_is_complete(
    frames: Path, tmp_path: Path
) -> None:
    """Ctrl+C during ``lfd record --source video:FILE --live-segment``: exit 0, the recording
    closed, complete (it loads without recovery) and holding the hand up to the interrupt."""
    import warnings

    from _interrupt import interrupt_record, partial_bytes
    from lfd.io import load

    video = _video(frames, tmp_path / "long.avi")
    long = tmp_path / "longer.avi"
    import cv2

    cap = cv2.VideoCapture(str(video))
    images = []
    while True:
        ok, bgr = cap.read()
        if not ok:
            break
        images.append(bgr)
    cap.release()
    writer = cv2.VideoWriter(str(long), cv2.VideoWriter_fourcc(*"MJPG"), 15.0, (S.W, S.H))
    for k in range(40 * len(images)):  # 640 frames, far more than are perceived before Ctrl+C
        writer.write(images[k % len(images)])
    writer.release()
    out = tmp_path / "int.mcap"
    argv = [
        "record", "--source", f"video:{long}", "--intrinsics", str(frames / "camera.json"),
        "--hand-size", str(HAND_SIZE), "--live-segment", "-o", str(out),
    ]  # fmt: skip
    status, err = interrupt_record(argv, out, after_bytes=40_000)
    assert status == 0, err
    said = " ".join(err.split())  # however the console wraps it
    assert "stopped:" in said and "live segments" in said, said
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a truncated file would warn while recovering
        demo = load(out)
    n = len(demo.hand)
    assert 0 < n < 40 * len(images), n
    assert np.isfinite(demo.hand.keypoints[:, 0]).all()
    assert partial_bytes(out) == 0  # renamed, nothing left beside it


def test_record_video_without_the_reference_tag_keeps_the_hand(
    frames: Path, tmp_path: Path
) -> None:
    """No reference tag in view and no camera pose: each of the scene's two hands is recorded in
    the camera frame on a topic of its own (/hand/<side>/keypoints_camera), the world hand
    topics have every sample unobserved (no camera-frame point on them), the objects are
    unobserved, no camera calibration is written."""
    import json

    from foxglove_schemas_protobuf.PosesInFrame_pb2 import PosesInFrame
    from lfd.io.mcapfile import read

    video = _video(frames, tmp_path / "demo.avi")
    cam = json.loads((frames / "camera.json").read_text())
    del cam["world_T_camera"]
    intrinsics = tmp_path / "camera.json"
    intrinsics.write_text(json.dumps(cam))
    out = tmp_path / "rec.mcap"
    proc = _lfd(
        "record", "--source", f"video:{video}", "--intrinsics", str(intrinsics),
        "-o", str(out), "--hand-size", str(HAND_SIZE),
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    said = " ".join(proc.stderr.split())
    assert "0 hand estimates (0 missed), 32 hands in the camera frame" in said, said
    assert "(/hand/right/keypoints_camera, /hand/left/keypoints_camera)" in said, said
    raw = read(out, images=False)
    world_kp = raw.tracks["/hand/right/keypoints"]["keypoints"]
    assert world_kp.shape == (16, 21, 3) and np.isnan(world_kp).all()
    assert (raw.tracks["/hand/right/confidence"]["confidence"] == 0).all()
    msgs = [PosesInFrame.FromString(d) for _, d in raw.encoded("/hand/right/keypoints_camera")]
    assert len(msgs) == 16 and {m.frame_id for m in msgs} == {"camera"}
    assert len(list(raw.encoded("/hand/left/keypoints_camera"))) == 16
    kp = np.array([[[p.position.x, p.position.y, p.position.z] for p in m.poses] for m in msgs])
    assert kp.shape == (16, 21, 3) and np.isfinite(kp).all()
    # camera frame: in front of the camera at the hand's distance, on the hand's pixels
    assert (0.2 < kp[:, 0, 2]).all() and (kp[:, 0, 2] < 1.5).all()
    world = kp @ S.WORLD_T_CAMERA[:3, :3].T + S.WORLD_T_CAMERA[:3, 3]
    for i in range(16):
        _on_the_hand(world[i], i)
    assert not [t for t in raw.channels if t.startswith("/objects/")]
    assert "/camera/color/camera_info" not in raw.channels


def test_perception_hands_json(tmp_path: Path) -> None:
    import cv2

    photo = REALHANDS / "tfjs_hands.jpg"
    img = cv2.imread(str(photo))
    h, w = img.shape[:2]
    # a depth image: the hands (not white) a flat sheet at 60 cm, the white wall at 90 cm
    depth = tmp_path / "d.png"
    cv2.imwrite(str(depth), np.where(img.min(axis=2) < 235, 600, 900).astype(np.uint16))
    k = tmp_path / "k.json"
    k.write_text(json.dumps({"K": [[600, 0, w / 2], [0, 600, h / 2], [0, 0, 1]]}))
    out = tmp_path / "hands.json"
    empty = tmp_path / "empty.png"
    cv2.imwrite(str(empty), np.full((240, 320, 3), 200, np.uint8))
    proc = _lfd("perception", "hands", str(photo), str(empty), "--json", str(out))
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(out.read_text())
    first, second = doc["images"]
    assert first["image"] == str(photo) and second["hands"] == []
    assert [hd["handedness"] for hd in first["hands"]] == ["left", "left"]
    for hd in first["hands"]:
        assert np.asarray(hd["keypoints_2d"]).shape == (21, 2)
        assert hd["keypoints_3d"] is None and 0.5 < hd["score"] <= 1
    ref = json.loads((REALHANDS / "tfjs_hands.json").read_text())["hands"]
    for r in ref:
        err = min(
            np.linalg.norm(np.asarray(hd["keypoints_2d"]) - r["keypoints_2d"], axis=1).mean()
            for hd in first["hands"]
        )
        assert err < 8
    proc = _lfd(
        "perception", "hands", str(photo), "--depth", str(depth), "--intrinsics", str(k),
        "--json", str(out),
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    hand = json.loads(out.read_text())["images"][0]["hands"][0]
    pts = np.asarray(hand["keypoints_3d"])
    assert pts.shape == (21, 3)
    visible = np.asarray(hand["visible"])
    assert visible.mean() > 0.8
    err = np.abs(pts[:, 2] - (0.6 + np.asarray(JOINT_RADIUS)))
    assert err[visible].max() < 0.004, err
    uv = pts[:, :2] / pts[:, 2:] * 600 + [w / 2, h / 2]
    assert np.abs(uv - hand["keypoints_2d"]).max() < 0.5


def test_camera_source_with_an_rgbd_reader_plugin(frames: Path, tmp_path: Path) -> None:
    """``--source camera:N --depth-reader FILE.py:factory`` where the reader gives colour and
    depth together (``read_frame``, like docs/examples/realsense_reader.py): no video device."""
    from lfd.io import load

    plugin = tmp_path / "fake_rgbd.py"
    plugin.write_text(
        f"""
import sys
sys.path.insert(0, {str(_paths.TESTS)!r})
from pathlib import Path
import _realhand_scene as S

class Reader:
    def __init__(self):
        self.hands = S.cutouts(Path({str(REALHANDS)!r}))
        self.f = 0
        self.closed = False

    def read_frame(self):
        if self.f >= 6:
            return None
        color, depth, _ = S.frame(self.hands, self.f)
        self.f += 1
        return color, depth

    def read(self):
        raise AssertionError("read_frame is used when present")

def make_reader():
    return Reader()
"""
    )
    out = tmp_path / "cam.mcap"
    proc = _lfd(
        "record", "--source", "camera:7", "--intrinsics", str(frames / "camera.json"),
        "--depth-reader", f"{plugin}:make_reader", "-o", str(out),
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    demo = load(out)
    assert demo.hand.t_ns.size == 6 and np.isfinite(demo.hand.keypoints).all()
    assert "box_1" in demo.objects


@pytest.mark.slow  # records and perceives real-hand frames with Rerun, twice
def test_record_and_hands_rerun_show_the_skeleton(frames: Path, tmp_path: Path) -> None:
    rr = pytest.importorskip("rerun")
    rrd = tmp_path / "rec.rrd"
    proc = _lfd(
        "record", "--source", f"frames:{frames}", "-o", str(tmp_path / "r.mcap"),
        "--duration", "0.4", "--rerun-save", str(rrd),
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    photos = tmp_path / "p.rrd"
    proc = _lfd(
        "perception", "hands", str(REALHANDS / "tfjs_hands.jpg"), "--rerun-save", str(photos)
    )
    assert proc.returncode == 0, proc.stderr
    for path, entity in ((rrd, "/camera/color/hand"), (photos, "/image/hands/1")):
        paths = {chunk.entity_path for chunk in rr.chunk.RrdReader(path).stream()}
        assert entity in paths, sorted(paths)
