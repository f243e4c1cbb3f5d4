"""Recording without depth: the video source (``lfd record --source video:FILE``), its bad
input, and the colour-only hand's fixed skeleton and distance smoothing
(:mod:`lfd.perception.hand.colour`). Inputs are generated here."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

cv2 = pytest.importorskip("cv2")

from lfd.errors import LfdError  # noqa: E402
from lfd.perception.hand.colour import (  # noqa: E402
    HAND_SIZE_RANGE,
    BoneLengths,
    ColourHand,
    DepthSmoother,
    bone_lengths,
)

W, H, FPS = 96, 64, 20.0


def _video(path: Path, n: int = 6, size: tuple[int, int] = (W, H)) -> Path:
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), FPS, size)
    assert writer.isOpened()
    for i in range(n):
        writer.write(np.full((size[1], size[0], 3), 20 * i, np.uint8))
    writer.release()
    return path


def _camera_json(path: Path, width: int = W, height: int = H) -> Path:
    K = [[80.0, 0, width / 2], [0, 80.0, height / 2], [0, 0, 1]]
    path.write_text(json.dumps({"width": width, "height": height, "K": K, "objects": []}))
    return path


def test_video_source_frames_and_times(tmp_path: Path) -> None:
    from lfd.perception.sources import open_source

    video = _video(tmp_path / "v.avi")
    src = open_source(f"video:{video}", intrinsics=_camera_json(tmp_path / "c.json"))
    assert src.has_depth is False and src.fps == pytest.approx(FPS)
    assert src.metadata["source"] == f"video:{video}"
    frames = list(src.frames())
    src.close()
    assert len(frames) == 6
    t = np.array([f.t_ns for f in frames])
    np.testing.assert_allclose(t, np.arange(6) * 1e9 / FPS, atol=1)  # the container's times
    for i, f in enumerate(frames):
        assert f.depth is None and f.color.shape == (H, W, 3) and f.color.dtype == np.uint8
        assert abs(int(f.color.mean()) - 20 * i) <= 3  # in order, colour converted


def _one_error_line(capsys: pytest.CaptureFixture[str], argv: list[str], expected: str) -> str:
    from lfd.cli import main

    status = main(argv)
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert status == 2, err
    assert len(lines) == 1 and "Traceback" not in err, err
    assert lines[0].startswith("lfd record: error: ") and expected in lines[0], lines[0]
    return lines[0]


def test_record_refuses_an_undecodable_video(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "broken.mp4"
    bad.write_bytes(b"\x00\x00\x00\x18ftypmp42" + bytes(range(256)) * 40)
    out = tmp_path / "rec.mcap"
    argv = ["record", "--source", f"video:{bad}", "-o", str(out)]
    line = _one_error_line(
        capsys, [*argv, "--intrinsics", str(_camera_json(tmp_path / "c.json"))], str(bad)
    )
    assert "not a readable video" in line
    assert not out.exists() and not list(tmp_path.glob("*.partial"))
    _one_error_line(capsys, argv, "needs --intrinsics")  # a video has no intrinsics of its own
    _one_error_line(
        capsys,
        [*argv[:2], f"video:{tmp_path / 'none.mp4'}", *argv[3:], "--intrinsics", str(bad)],
        "none.mp4",
    )
    assert not out.exists()


def test_record_refuses_intrinsics_of_another_size(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    video = _video(tmp_path / "v.avi")
    cam = _camera_json(tmp_path / "c.json", 640, 480)
    out = tmp_path / "rec.mcap"
    argv = ["record", "--source", f"video:{video}", "--intrinsics", str(cam), "-o", str(out)]
    line = _one_error_line(capsys, argv, "640x480")
    assert f"{W}x{H}" in line and str(video) in line
    assert not out.exists() and not list(tmp_path.glob("*.partial"))


def test_record_refuses_the_depth_network_without_depth(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    pytest.importorskip("torch")
    video = _video(tmp_path / "v.avi")
    out = tmp_path / "rec.mcap"
    argv = [
        "record", "--source", f"video:{video}", "--intrinsics",
        str(_camera_json(tmp_path / "c.json")), "-o", str(out), "--hand-model", "depth-net",
    ]  # fmt: skip
    _one_error_line(capsys, argv, "--hand-model mediapipe")
    assert not out.exists()


def test_hand_size_range_is_checked(capsys: pytest.CaptureFixture[str]) -> None:
    from lfd.cli import main

    with pytest.raises(SystemExit) as stop:
        main(["record", "--source", "video:x.mp4", "-o", "x.mcap", "--hand-size", "1.9"])
    assert stop.value.code == 2 and "--hand-size" in capsys.readouterr().err
    with pytest.raises(LfdError, match="hand size"):
        BoneLengths(HAND_SIZE_RANGE[1] + 0.01)


# --- the colour-only hand -------------------------------------------------------------------
def _hand(rng: np.random.Generator) -> np.ndarray:
    """A hand-like point set (21, 3), metres, around the origin."""
    from lfd.demo import HAND_BONES

    pts = np.zeros((21, 3))
    for a, b in HAND_BONES:
        if b != 17 or a == 13:
            pts[b] = pts[a] + rng.normal([0.0, -0.03, 0.0], 0.01)
    return pts - pts.mean(axis=0)


def test_bone_lengths_are_measured_then_fixed() -> None:
    """The hand length is the median of the confident hands' (or ``hand_size``), the proportions
    the median of theirs, fixed once ``frames`` of them are measured."""
    from lfd.perception.hand.colour import hand_length

    rng = np.random.default_rng(0)
    hands = [_hand(rng) for _ in range(6)]

    def proportions(h: np.ndarray) -> np.ndarray:
        return bone_lengths(h) / hand_length(h)

    bones = BoneLengths(frames=3)
    bones.measure(hands[5], score=0.3)  # a doubtful hand is not measured...
    assert bones.length is None  # ...and before any confident one a hand has its own bones
    np.testing.assert_allclose(bones.lengths(hands[5]), bone_lengths(hands[5]))
    bones.measure(hands[0])
    np.testing.assert_allclose(bones.lengths(hands[5]), bone_lengths(hands[0]))
    assert bones.length == pytest.approx(hand_length(hands[0]))
    bones.measure(hands[1] * 1.3)
    assert bones.fixed is None
    bones.measure(hands[2])
    median = np.median([proportions(hands[i]) for i in (0, 1, 2)], axis=0)
    length = np.median([hand_length(hands[0]), 1.3 * hand_length(hands[1]), hand_length(hands[2])])
    assert bones.fixed is not None and bones.length == pytest.approx(length)
    np.testing.assert_allclose(bones.fixed, median * length)
    bones.measure(hands[3])  # fixed from now on
    np.testing.assert_array_equal(bones.lengths(hands[4]), bones.fixed)
    # the user's hand size is the skeleton's scale
    small, large = BoneLengths(0.15, frames=3), BoneLengths(0.20, frames=3)
    for h in hands[:3]:
        small.measure(h * 1.4)
        large.measure(h)
    assert small.fixed is not None and large.fixed is not None
    np.testing.assert_allclose(large.fixed / small.fixed, 0.20 / 0.15)
    assert small.length == 0.15
    with pytest.raises(LfdError, match="frames"):
        BoneLengths(frames=0)


def test_depth_smoother_removes_outliers_and_follows_steps() -> None:
    sm = DepthSmoother()
    out = [sm.update(z) for z in [0.5, 0.5, 0.9, 0.5, 0.5]]
    assert max(out) == pytest.approx(0.5)  # a one-sample outlier is the median's
    out = [sm.update(0.6) for _ in range(8)]
    assert out[0] == pytest.approx(0.5) and out[1] == pytest.approx(0.55)  # two samples late
    assert out[-1] == pytest.approx(0.6, abs=1e-3)
    sm.reset()
    assert sm.update(1.0) == 1.0


def _camera_hand(rng: np.random.Generator, z: float) -> np.ndarray:
    """A hand-like point set at distance ``z`` in front of the camera, turned at random."""
    from scipy.spatial.transform import Rotation

    R = Rotation.random(random_state=int(rng.integers(1 << 30))).as_matrix()
    return _hand(rng) @ R.T + [rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.1), z]


def test_the_distance_is_voted_by_the_bones_across_the_view() -> None:
    """With the right bones and exact image landmarks, a landmark-model hand with 5 mm of noise
    per keypoint is placed at its distance about twice as well by the bones' votes
    (:func:`ray_scale`) than by a perspective-n-point fit of the whole hand, which the
    slanted finger bones throw off."""
    from lfd.perception.hand.colour import on_rays, ray_scale
    from lfd.perception.hand.lift import lift_from_colour

    rng = np.random.default_rng(3)
    K = np.array([[600.0, 0, 320], [0, 600.0, 240], [0, 0, 1]])
    voted, pnp = [], []
    for _ in range(200):
        cam = _camera_hand(rng, rng.uniform(0.4, 0.8))
        uv = cam[:, :2] / cam[:, 2:] * 600 + [320, 240]
        world = cam - cam.mean(axis=0) + rng.normal(0.0, 0.005, (21, 3))
        lifted = lift_from_colour(uv, world, K, lengths=bone_lengths(cam))
        assert lifted is not None
        rays = on_rays(lifted.points, uv, K)
        np.testing.assert_allclose(rays[:, :2] / rays[:, 2:] * 600 + [320, 240], uv)
        scaled = rays * ray_scale(rays, bone_lengths(cam), K)
        voted.append(abs(scaled[0, 2] - cam[0, 2]))
        pnp.append(abs(lifted.points[0, 2] - cam[0, 2]))
    # measured: 13 mm against 25 mm (median over 200 random hands and views)
    assert np.median(voted) < 0.6 * np.median(pnp), (np.median(voted), np.median(pnp))
    assert np.median(voted) < 0.02


def test_keep_lengths_keeps_the_joints_on_their_rays() -> None:
    """Each joint is put back on its viewing ray at its bone's length from the joint before
    (the nearer of the two places to the guess); when the ray is out of reach, at the bone's
    length nearest the ray."""
    from lfd.perception.hand.colour import keep_lengths

    rng = np.random.default_rng(4)
    cam = _camera_hand(rng, 0.5)
    lengths = bone_lengths(cam)
    guess = cam * (1.0 + rng.normal(0.0, 0.01, (21, 1)))  # on the rays, depths off by ~5 mm
    out = keep_lengths(guess, lengths)
    np.testing.assert_allclose(np.delete(bone_lengths(out), 17), np.delete(lengths, 17))
    rays = cam / np.linalg.norm(cam, axis=1, keepdims=True)
    off = np.linalg.norm(np.cross(out, rays), axis=1)
    assert off.max() < 1e-9  # every joint on its ray
    np.testing.assert_allclose(out, cam, atol=0.01)  # the right one of the two places
    short = keep_lengths(guess, lengths * 0.5)  # rays out of reach: lengths kept all the same
    np.testing.assert_allclose(np.delete(bone_lengths(short), 17), np.delete(lengths, 17) * 0.5)


def test_push_holds_the_frames_until_the_bones_are_fixed() -> None:
    """Frames are held while the bones are measured, then all placed with the fixed ones, in
    order; a frame without a hand comes out as None; :meth:`release` places what is held."""
    from lfd.perception.hand.mediapipe import Hand, Rect

    rng = np.random.default_rng(5)
    K = np.array([[600.0, 0, 320], [0, 600.0, 240], [0, 0, 1]])
    model = _hand(rng)

    def frame(k: int) -> Hand:
        cam = model + np.array([0.01 * k, 0.0, 0.5])
        uv = cam[:, :2] / cam[:, 2:] * 600 + [320, 240]
        world = model * rng.uniform(0.8, 1.2) + rng.normal(0.0, 0.003, (21, 3))
        return Hand(uv, np.zeros(21), world, "right", 1.0, 1.0, Rect(0, 0, 1, 0))

    placer = ColourHand()
    placer.bones = BoneLengths(frames=4)
    got = []
    for k in range(6):
        out = placer.push(k, None if k == 1 else frame(k), K, restart=k == 0)
        assert [key for key, _ in out] == list(range(len(got), len(got) + len(out)))
        got += out
        assert len(got) == (0 if k < 4 else k + 1)  # four hands measured at k == 4
    assert got[1][1] is None
    fixed = placer.bones.fixed
    assert fixed is not None
    for key, lifted in got:
        if key != 1:
            assert lifted is not None
            np.testing.assert_allclose(
                np.delete(bone_lengths(lifted.points), 17), np.delete(fixed, 17)
            )
    held = ColourHand()
    assert held.push("a", frame(0), K) == [] and held.holding == 1
    ((key, lifted),) = held.release()
    assert key == "a" and lifted is not None and held.holding == 0


def test_colour_hand_keeps_the_wrist_on_its_pixel_and_the_bones() -> None:
    """Placed hands project their wrist where the image has it (the distance filter moves the
    hand along the rays), keep the fixed bones exactly and, with exact landmarks, are where the
    hand is, whatever size the landmark model gives it."""
    from lfd.perception.hand.mediapipe import Hand, Rect

    rng = np.random.default_rng(1)
    K = np.array([[600.0, 0, 320], [0, 600.0, 240], [0, 0, 1]])
    model = _hand(rng)
    placer = ColourHand()
    placer.bones = BoneLengths(frames=1)  # fixed from the first hand
    distances = [0.5, 0.5, 0.8, 0.5, 0.5]  # 0.8: a one-frame jump
    sizes = [1.0, 1.1, 0.9, 1.08, 0.93]  # the landmark model's metric hand wavers
    for k, (z, size) in enumerate(zip(distances, sizes, strict=True)):
        cam = model + np.array([0.01 * k, 0.0, z])
        uv = cam[:, :2] / cam[:, 2:] * 600 + [320, 240]
        world = model * size
        hand = Hand(uv, np.zeros(21), world, "right", 1.0, 1.0, Rect(0, 0, 1, 0))
        placed = placer.place(hand, K)
        assert placed is not None
        p = placed.points
        np.testing.assert_allclose(p[0, :2] / p[0, 2] * 600 + [320, 240], uv[0], atol=1e-6)
        fixed = placer.bones.fixed
        assert fixed is not None  # (0, 17), bone 17, is not imposed: it follows the palm
        np.testing.assert_allclose(np.delete(bone_lengths(p), 17), np.delete(fixed, 17))
        if k == 2:
            assert p[0, 2] < 0.6  # a one-frame jump to 0.8 m is the median's
        else:
            np.testing.assert_allclose(p, cam, atol=1e-6)  # the size wavering is gone
