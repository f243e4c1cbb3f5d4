"""``lfd record`` keeps both hands where two can be seen, ``--hand`` keeps one: the hands a
source gets, the depth points split into the two arms, and recordings of a two-hand scene."""

from __future__ import annotations

import os

import numpy as np
import pytest

os.environ.setdefault("MUJOCO_GL", "egl")

from lfd.cli.record import hand_sides
from lfd.errors import LfdError


def test_which_hands_are_recorded() -> None:
    assert hand_sides(None, "depth-net", ("right", "left")) == ("right", "left")
    assert hand_sides(None, "depth-net", ("right",)) == ("right",)  # one-hand scene: as before
    assert hand_sides(None, "mediapipe", None) == ("right", "left")  # a camera: both
    assert hand_sides(None, "depth-net", None) == ("right",)
    assert hand_sides("left", "mediapipe", None) == ("left",)
    assert hand_sides("right", "depth-net", ("right", "left")) == ("right",)


def _arm(x0: float, rng: np.random.Generator) -> np.ndarray:
    """Points of a forearm from the demonstrator's side (y = 0) to a hand at y = 0.3."""
    s = rng.uniform(0.0, 1.0, 800)
    pts = np.column_stack(
        [x0 + 0.5 * (0.0 - x0) * s, 0.3 * s, 0.1 + 0.01 * rng.normal(size=s.size), np.zeros(800)]
    )
    pts[:, :2] += 0.01 * rng.normal(size=(800, 2))
    return pts


def test_depth_points_split_into_right_and_left_arm() -> None:
    from lfd.perception.hand.sides import split_arms

    rng = np.random.default_rng(0)
    right, left = _arm(0.3, rng), _arm(-0.3, rng)
    arms = split_arms(np.concatenate([left, right]))
    assert set(arms) == {"right", "left"}
    assert len(arms["right"]) == len(right) and np.all(arms["right"][:, 0] > 0.1)
    assert len(arms["left"]) == len(left) and np.all(arms["left"][:, 0] < -0.1)
    assert set(split_arms(left)) == {"left"}  # one arm: its side from where it comes from
    assert split_arms(left[:10]) == {}  # too few points: no hand


def test_two_hands_need_an_estimator_each() -> None:
    pytest.importorskip("mujoco")
    from lfd.perception.record import record
    from lfd.perception.sources import open_source

    source = open_source("sim:handover", seed=1, duration=0.5)
    assert source.sides == ("right", "left")
    with pytest.raises(LfdError, match="one estimator per hand"):
        record(source, "unused.mcap", sides=("right", "left"), estimator=object())
    source = open_source("sim:handover", seed=1, duration=0.5)
    with pytest.raises(LfdError, match="no hand estimator for the left hand"):
        record(source, "unused.mcap", sides=("right", "left"), estimator={"right": object()})
    assert not os.path.exists("unused.mcap")


def _truth(task: str, seed: int, side: str):  # type: ignore[no-untyped-def]
    from lfd.sim import simulate

    truth = simulate(task, seed).truth
    return truth if side == "right" else truth.other


@pytest.mark.slow  # renders and perceives 2 s of a two-hand scene twice (~30 s)
def test_record_two_hand_scene_keeps_both_hands_or_one(tmp_path) -> None:  # type: ignore[no-untyped-def]
    pytest.importorskip("torch")
    from lfd.cli import main
    from lfd.io import load

    both, left = tmp_path / "both.mcap", tmp_path / "left.mcap"
    argv = ["record", "--source", "sim:carry", "--seed", "2", "--duration", "3"]
    assert main([*argv, "--live-segment", "-o", str(both)]) == 0
    assert main([*argv, "--hand", "left", "-o", str(left)]) == 0
    demo, one = load(both), load(left)
    assert demo.sides == ("right", "left")
    assert one.sides == ("left",)  # the left hand alone, a one-hand file
    assert demo.live_segments and {x.hand for x in demo.live_segments} == {"right", "left"}
    np.testing.assert_array_equal(one.hand.t_ns, demo.hands["left"].t_ns)
    for side, hand in [*demo.hands.items(), ("left", one.hand)]:
        seen = np.isfinite(hand.keypoints).all(axis=(1, 2))
        assert seen.sum() >= 10, side
        truth = _truth("carry", 2, side)  # each hand is where that hand truly is
        idx = np.searchsorted(truth.t_ns, hand.t_ns[seen])
        err = np.linalg.norm(hand.keypoints[seen] - truth.keypoints[idx], axis=2).mean(axis=1)
        assert np.median(err) < 0.03, (side, np.median(err))


def test_mediapipe_gives_both_hands_from_one_tracker() -> None:
    """The second hand's estimator takes the hands its leader's tracker found in the frame: both
    hands, each its own, with one palm detection for the whole clip."""
    pytest.importorskip("ai_edge_litert")
    pytest.importorskip("cv2")
    import test_hands_mediapipe as T

    if not T.REALHANDS.is_dir():
        pytest.skip(f"real hand photographs not found at {T.REALHANDS}")
    from lfd.perception.hand.rgbd import MediaPipeEstimator

    right = MediaPipeEstimator("right")
    left = right.for_side("left")
    assert left.tracker is right.tracker and left.side == "left"
    K = np.array([[600.0, 0.0, 319.5], [0.0, 600.0, 239.5], [0.0, 0.0, 1.0]])
    for frame in T._two_hand_video(6):
        r = right.estimate_frame(frame, None, K, None)
        l_ = left.estimate_frame(frame, None, K, None)
        assert r is not None and l_ is not None
        assert r.hand is not None and l_.hand is not None
        assert (r.hand.handedness, l_.hand.handedness) == ("right", "left")
        assert r.hand.track_id != l_.hand.track_id
        gap = np.abs(r.hand.keypoints_2d[:, 0].mean() - l_.hand.keypoints_2d[:, 0].mean())
        assert gap > 50  # two different hands in the image
    assert right.tracker.palm_runs == 1
