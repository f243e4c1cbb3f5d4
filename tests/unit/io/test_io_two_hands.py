"""Two hands in one recording (issue 40, data): lfd.save / McapRecorder write both hands, their
labels (metadata ``hand``) and handovers; lfd.load reads them back; merge_hands joins two
one-hand files of one take; a one-hand file is written and read as before. The files are
made with lfd's own writer (exp1 given a second hand, tests/_two_hands.py)."""

from __future__ import annotations

import dataclasses
import json
import warnings
from pathlib import Path

import lfd
import numpy as np
import pytest
from _paths import EXP1, SHARED
from _two_hands import left_of, save_two_hands, two_hand_demo
from lfd.demo import Handover, SkillLabel
from lfd.errors import DemonstrationError, RecordingFormatError
from lfd.io import topics as T
from lfd.io.hands import clock_problem, merge_hands
from lfd.io.mcapfile import scan

BIMANUAL = SHARED / "realmotion" / "bimanual"


def _same_hand(a: lfd.HandTrack, b: lfd.HandTrack) -> None:
    assert a.side == b.side
    np.testing.assert_array_equal(a.t_ns, b.t_ns)
    np.testing.assert_array_equal(a.keypoints, b.keypoints)
    np.testing.assert_array_equal(a.confidence, b.confidence)
    np.testing.assert_array_equal(a.visible, b.visible)


def test_save_load_round_trip_of_two_hands(tmp_path: Path) -> None:
    path = tmp_path / "two.mcap"
    saved = save_two_hands(path)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # two lanes' labels at one time are not duplicates
        back = lfd.load(path)
    assert back.sides == ("right", "left")
    _same_hand(back.hand, saved.hand)
    assert back.other_hand is not None and saved.other_hand is not None
    _same_hand(back.other_hand, saved.other_hand)
    assert back.labels == saved.labels
    assert [lab.hand for lab in back.labels_of("left")] == ["left", "left"]
    assert back.labels_of("right") == [lab for lab in saved.labels if lab.hand == "right"]
    assert back.handovers == saved.handovers
    assert back.objects.keys() == saved.objects.keys()
    # the file: both hands' topics, labels with their hand, the demo record lists the hands
    raw = scan(path)
    for side in ("right", "left"):
        assert raw.channels[T.hand_topic(side)].count == len(saved.hands[side])
        assert raw.channels[T.hand_topic(side)].metadata["side"] == side
    assert raw.channels[T.HANDOVERS_TOPIC].count == 1
    record = raw.metadata[T.DEMO_METADATA]
    assert record["hand_side"] == "right" and json.loads(record["hands"]) == ["right", "left"]
    # and again: save(load(x)) == load(x)
    again = tmp_path / "again.mcap"
    lfd.save(back, again)
    twice = lfd.load(again)
    assert twice.labels == back.labels and twice.handovers == back.handovers
    _same_hand(twice.other_hand, back.other_hand)  # type: ignore[arg-type]


def test_one_hand_file_is_written_as_before(tmp_path: Path) -> None:
    """A one-hand demonstration: one hand topic, no ``hands`` record key, labels without a
    ``hand``; it loads with ``demo.hand`` and labels whose hand is None, as before."""
    demo = lfd.load(EXP1, images=False)
    path = tmp_path / "one.mcap"
    lfd.save(demo, path)
    raw = scan(path)
    assert sorted(t for t in raw.channels if t.startswith("/hand/")) == [
        "/hand/right/confidence",
        "/hand/right/keypoints",
    ]
    record = raw.metadata[T.DEMO_METADATA]
    assert "hands" not in record and record["hand_side"] == "right"
    assert T.HANDOVERS_TOPIC not in raw.channels
    back = lfd.load(path)
    assert back.other_hand is None and back.sides == ("right",)
    assert back.labels == demo.labels and all(lab.hand is None for lab in back.labels)
    # the same channels as the shipped file, and no label names a hand
    assert scan(EXP1).channels.keys() == raw.channels.keys()
    from foxglove_schemas_protobuf.Event_pb2 import Event

    for _, data in raw.encoded(T.GROUND_TRUTH_TOPIC):
        event = Event()
        event.ParseFromString(data)
        assert "hand" not in {kv.key for kv in event.metadata}


def test_recorder_takes_samples_of_either_hand(tmp_path: Path) -> None:
    demo = two_hand_demo()
    path = tmp_path / "live.mcap"
    objects = [(o.name, o.tag_id, o.size) for o in demo.objects.values()]
    with lfd.io.McapRecorder(path, objects=objects, hands=("left", "right")) as rec:
        assert rec.sides == ("right", "left") and rec.side == "right"
        for side, hand in demo.hands.items():
            for i in range(5):
                rec.add_hand(int(hand.t_ns[i]), hand.keypoints[i], side=side)
        box = demo.objects["box_1"]
        for i in range(10):
            rec.add_object_pose("box_1", int(box.t_ns[i]), box.position[i], box.quaternion[i])
        rec.add_live_segment(
            SkillLabel("move", int(box.t_ns[0]), int(box.t_ns[9]), hand="left"), int(box.t_ns[9])
        )
        with pytest.raises(DemonstrationError, match="names no hand"):
            rec.add_label(SkillLabel("move", int(box.t_ns[0]), int(box.t_ns[9])))
    back = lfd.load(path)
    assert back.sides == ("right", "left")
    np.testing.assert_array_equal(back.other_hand.t_ns, demo.other_hand.t_ns[:5])  # type: ignore[union-attr]
    assert [(s.skill, s.hand) for s in back.live_segments] == [("move", "left")]
    one = tmp_path / "one.mcap"
    with lfd.io.McapRecorder(one, objects=objects) as rec:
        with pytest.raises(DemonstrationError, match="records the right hand"):
            rec.add_hand(0, demo.hand.keypoints[0], side="left")
        with pytest.raises(
            DemonstrationError, match="names the left hand, which the recording lacks"
        ):
            rec.add_handover(Handover(1, 2, "right", "left"))
        with pytest.raises(DemonstrationError, match="left hand, which the recording lacks"):
            rec.add_label(SkillLabel("move", 1, 2, hand="left"))
        rec.discard()


def test_merge_hands_of_two_one_hand_files(tmp_path: Path) -> None:
    """Each hand saved alone (one file per hand, one clock), merged back: the two-hand
    demonstration, labels tagged by side; a hand on another clock is refused."""
    two = two_hand_demo()
    paths = {}
    for side in ("right", "left"):
        paths[side] = tmp_path / f"take.{side}.mcap"
        one = two.one_hand(side)  # as a one-hand recorder writes it: labels name no hand
        one.labels = [dataclasses.replace(lab, hand=None) for lab in one.labels]
        lfd.save(one, paths[side])
    right, left = lfd.load(paths["right"]), lfd.load(paths["left"])
    assert all(lab.hand is None for lab in left.labels)  # one-hand files: the only hand
    merged = merge_hands(left, right, two.handovers)  # either order
    assert merged.sides == ("right", "left")
    _same_hand(merged.other_hand, two.other_hand)  # type: ignore[arg-type]
    assert merged.labels == two.labels and merged.handovers == two.handovers
    with pytest.raises(DemonstrationError, match="a right and a left"):
        merge_hands(right, right)
    epoch = dataclasses.replace(left, hand=left_of(right.hand, shift_ns=-int(right.hand.t_ns[0])))
    with pytest.raises(DemonstrationError, match="not on one clock"):
        merge_hands(right, epoch)
    fewer = dataclasses.replace(left, objects={"box_1": left.objects["box_1"]})
    with pytest.raises(DemonstrationError, match="different objects"):
        merge_hands(right, fewer)


@pytest.mark.skipif(not BIMANUAL.is_dir(), reason="the real bimanual data is not here")
def test_merge_hands_reads_real_bimanual_takes() -> None:
    """The real bimanual takes (one file per hand, read from ../shared, never copied): merged
    into two-hand demonstrations on one clock, each hand's labels in its lane."""
    rights = sorted(BIMANUAL.glob("*.right.mcap"))
    assert rights
    for r in rights[:2]:
        right = lfd.load(r, images=False)
        left = lfd.load(r.with_name(r.name.replace(".right.", ".left.")), images=False)
        demo = merge_hands(right, left)
        assert demo.sides == ("right", "left")
        assert len(demo.labels_of("right")) == len(right.labels)
        assert len(demo.labels_of("left")) == len(left.labels)
        assert clock_problem({"right": (0, 10), "left": (0, 10)}, None) is None


def test_clock_rule() -> None:
    assert clock_problem({"right": (0, 10)}, (100, 200)) is None  # one hand: not checked
    assert clock_problem({"right": (0, 10), "left": (5, 20)}, (0, 30)) is None
    epoch = 1_700_000_000_000_000_000
    assert "not on one clock" in (
        clock_problem({"right": (epoch, epoch + 10**9), "left": (0, 10**9)}, (epoch, epoch + 10**9))
        or ""
    )
    assert "objects' clock" in (
        clock_problem({"right": (0, 10), "left": (5, 20)}, (epoch, epoch + 1)) or ""
    )


def test_save_refuses_hands_on_two_clocks(tmp_path: Path) -> None:
    demo = two_hand_demo()
    shifted = left_of(demo.hand, shift_ns=-int(demo.hand.t_ns[0]))  # zero-based beside epoch
    bad = dataclasses.replace(demo, other_hand=shifted, labels=[], handovers=[])
    with pytest.raises(DemonstrationError, match="not on one clock"):
        lfd.save(bad, tmp_path / "bad.mcap")
    assert not (tmp_path / "bad.mcap").exists()


def test_follow_carries_both_hands(tmp_path: Path) -> None:
    path = tmp_path / "two.mcap"
    demo = save_two_hands(path)
    follower = lfd.io.follow(path, idle_timeout_s=2.0)
    counts: dict[tuple[str, str | None], int] = {}
    for msg in follower:
        counts[(msg.kind, msg.side)] = counts.get((msg.kind, msg.side), 0) + 1
    assert follower.sides == ("right", "left")
    for side in ("right", "left"):
        assert counts[("hand", side)] == len(demo.hands[side])
        assert counts[("confidence", side)] == len(demo.hands[side])
        assert counts[("label", side)] == len(demo.labels_of(side))
    assert counts[("handover", None)] == 1


def test_info_json_lists_hands_labels_per_hand_and_handovers(tmp_path: Path) -> None:
    path = tmp_path / "two.mcap"
    demo = save_two_hands(path)
    for check in (False, True):
        s = lfd.io.summarise(path, check=check)
        assert s["error"] is None
        assert [(h["side"], h["samples"]) for h in s["hands"]] == [
            ("right", len(demo.hand)),
            ("left", len(demo.other_hand)),  # type: ignore[arg-type]
        ]
        assert all(h["rate_hz"] > 4 for h in s["hands"])
        assert [(lab["hand"], lab["skill"]) for lab in s["labels"]] == [
            (lab.hand, lab.skill) for lab in demo.labels
        ]
        assert [(h["giver"], h["taker"], h["object"]) for h in s["handovers"]] == [
            ("right", "left", demo.handovers[0].object)
        ]
    one = lfd.io.summarise(EXP1)
    assert [h["side"] for h in one["hands"]] == ["right"] and one["handovers"] == []
    assert all(lab["hand"] is None for lab in one["labels"])


def test_load_refuses_label_for_a_missing_hand(tmp_path: Path) -> None:
    """Written by the recorder's lower level, as another program could: a one-hand file with a
    label for the left hand."""
    from lfd.io import messages as M

    path = tmp_path / "lefty.mcap"
    demo = lfd.load(EXP1, images=False)
    lfd.save(dataclasses.replace(demo, labels=[]), path)
    from lfd.io.labels import write_labels

    write_labels(path, [SkillLabel("move", demo.start_ns, demo.start_ns + 10**9, hand="left")])
    assert M.event(SkillLabel("move", 0, 1, hand="left")).metadata[-1].value == "left"
    with pytest.raises(RecordingFormatError, match="left hand, which the recording lacks"):
        lfd.load(path)
