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


def test_record_without_depth_marks_the_hand_unobserved(frames: Path, tmp_path: Path) -> None:
    import shutil

    from lfd.io import load

    colour_only = tmp_path / "frames"
    shutil.copytree(frames, colour_only)
    shutil.rmtree(colour_only / "depth")
    out = tmp_path / "rec.mcap"
    proc = _lfd("record", "--source", f"frames:{colour_only}", "-o", str(out), "--duration", "0.3")
    assert proc.returncode == 0, proc.stderr
    hand = load(out).hand
    assert hand.t_ns.size > 0
    assert np.isnan(hand.keypoints).all() and (hand.confidence == 0).all()


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
