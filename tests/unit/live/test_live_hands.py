"""Live segmentation of two hands (:mod:`lfd.segmentation.live_hands`): a lane per hand, the
runs over both hands together; at the end each lane is the batch one (``lfd.segment_hands``)."""

from __future__ import annotations

import warnings

import _paths
import lfd
import numpy as np
import pytest
from _two_hands import idle_left
from lfd.errors import InvalidParameterError
from lfd.segmentation.live import HandMessage, LiveSegmentation, demo_messages
from lfd.segmentation.live_hands import LiveHands, segment_hands_live


@pytest.fixture(scope="module")
def two() -> lfd.Demonstration:
    return idle_left(lfd.load(_paths.EXP1, images=False))


def test_live_hands_equal_batch_at_the_end(two: lfd.Demonstration) -> None:
    """Every lane: the batch skills of that hand, each settled after its batch end, boundaries
    within a few samples, the same end; the handovers are the batch ones."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        batch = lfd.segment_hands(two)
        live, settled = segment_hands_live(two)
    assert live.sides == batch.sides == ("right", "left")
    for side in two.sides:
        got, want = live.lanes[side].segments, batch.lanes[side].segments
        assert [(s.skill, s.object) for s in got] == [(s.skill, s.object) for s in want], side
        late = (settled[side] - np.array([s.end_ns for s in want])) * 1e-9
        assert np.all(late[:-1] > 0), late
        starts = np.array([s.start for s in got]) - np.array([s.start for s in want])
        assert np.median(np.abs(starts)) <= 2, starts
        assert got[-1].end_ns == want[-1].end_ns
    assert [(h.giver, h.taker, h.object) for h in live.handovers] == [
        (h.giver, h.taker, h.object) for h in batch.handovers
    ]
    # the right hand's skills settle while it is recorded, as with one hand
    assert sum(t < two.end_ns - 2_000_000_000 for t in settled["right"]) >= 4


def test_settled_labels_name_their_hand(two: lfd.Demonstration) -> None:
    """What an update settles, as labels for /lfd/live/segments: each names its hand; the
    labels of all updates are the lanes of the result."""
    live = LiveHands.for_demonstration(two)
    labels = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for msg in demo_messages(two):
            labels += live.push(msg).labels
        labels += live.finish().labels
    assert {lab.hand for lab in labels} == {"right", "left"}
    result = live.result().to_labels()
    key = lambda lab: (lab.hand, lab.start_ns, lab.skill)  # noqa: E731
    assert sorted(labels, key=key) == sorted(result, key=key)


def test_hand_frames_must_name_a_known_side(two: lfd.Demonstration) -> None:
    live = LiveHands.for_demonstration(two)
    frame = np.zeros((21, 3))
    with pytest.raises(InvalidParameterError, match="names no side"):
        live.push(HandMessage(0, frame))
    one = LiveHands.for_demonstration(two.one_hand("right"))
    assert one.sides == ("right",)
    one.push(HandMessage(0, frame))  # the only hand
    with pytest.raises(InvalidParameterError, match="left-hand frame"):
        one.push(HandMessage(1, frame, side="left"))
    with pytest.raises(InvalidParameterError, match="left-hand frame"):
        LiveSegmentation(["box_1"], [[0.05] * 3]).push(HandMessage(0, frame, side="left"))
    with pytest.raises(lfd.errors.DemonstrationError, match="hand side"):
        LiveHands(["box_1"], [[0.05] * 3], sides=("up",))
