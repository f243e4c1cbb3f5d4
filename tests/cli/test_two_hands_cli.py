"""Two-hand recordings through the CLI (issue 40, data): ``lfd info`` and ``lfd label`` per
hand, and the bad input of two hands, each one line and exit status 2 with nothing written: a
hand topic of an unknown side, two hands on different clocks, labels for a hand the recording
lacks (in the file, or given to ``lfd label``). Files are made with lfd's own writer (exp1
given a second hand, tests/_two_hands.py) or the ``mcap`` package's writer."""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path
from typing import Any

import lfd
import pytest
from _mcapcopy import copy_records
from _paths import EXP1
from _two_hands import left_of, save_two_hands, two_hand_demo
from lfd.demo import SkillLabel


def _lfd(capsys: pytest.CaptureFixture[str], *argv: Any) -> tuple[int, str, str]:
    from lfd.cli import main

    try:
        status = main([str(a) for a in argv])
    except SystemExit as stop:
        status = stop.code  # type: ignore[assignment]
    out = capsys.readouterr()
    return status, out.out, out.err


def _one_line(capsys: pytest.CaptureFixture[str], *argv: Any, expected: str = "") -> str:
    status, _, err = _lfd(capsys, *argv)
    lines = [line for line in err.splitlines() if line.strip()]
    assert status == 2, err
    assert "Traceback" not in err and len(lines) == 1, err
    assert lines[0].startswith(f"lfd {argv[0]}: error: "), lines[0]
    assert expected in lines[0], lines[0]
    return lines[0]


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _refused_everywhere(
    capsys: pytest.CaptureFixture[str], rec: Path, tmp_path: Path, expected: str
) -> None:
    """``lfd info`` (text and --json), ``lfd segment --json`` and ``lfd label -o`` refuse
    ``rec`` in one line; nothing is written, the recording is unchanged."""
    before = _digest(rec)
    labels = tmp_path / "labels.json"
    labels.write_text(json.dumps([{"skill": "move", "start_s": 0, "end_s": 1}]))
    out_json, out_mcap = tmp_path / "out.json", tmp_path / "out.mcap"
    _one_line(capsys, "info", rec, expected=expected)
    _one_line(capsys, "info", rec, "--json", out_json, expected=expected)
    _one_line(capsys, "segment", rec, "--json", out_json, expected=expected)
    _one_line(capsys, "label", rec, "--from", labels, "-o", out_mcap, expected=expected)
    assert not out_json.exists() and not out_mcap.exists()
    assert _digest(rec) == before


def test_unknown_hand_side_is_one_line(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    """exp1 with its right hand also on /hand/middle/keypoints (the mcap package's writer)."""
    from mcap.reader import make_reader
    from mcap.writer import Writer

    rec = tmp_path / "middle.mcap"
    with open(EXP1, "rb") as f, open(rec, "wb") as out:
        reader = make_reader(f)
        writer = Writer(out)
        writer.start()
        copy_records(reader, writer)
        f.seek(0)
        reader = make_reader(f)
        middle = None
        for schema, channel, message in reader.iter_messages(topics=["/hand/right/keypoints"]):
            if middle is None:
                assert schema is not None
                sid = writer.register_schema(schema.name, schema.encoding, schema.data)
                middle = writer.register_channel(
                    "/hand/middle/keypoints", channel.message_encoding, sid, {}
                )
            writer.add_message(middle, message.log_time, message.data, message.publish_time)
        writer.finish()
    _refused_everywhere(capsys, rec, tmp_path, "/hand/middle/keypoints names an unknown side")


def test_hands_on_two_clocks_is_one_line(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    """The right hand and the objects in epoch nanoseconds, the left counted from zero (the
    recorder writes what it is given; readers refuse it)."""
    demo = two_hand_demo()
    zero = left_of(demo.hand, shift_ns=-int(demo.hand.t_ns[0]))
    rec = tmp_path / "clocks.mcap"
    objects = [(o.name, o.tag_id, o.size) for o in demo.objects.values()]
    with lfd.io.McapRecorder(rec, objects=objects, hands=("right", "left")) as w:
        for hand in (demo.hand, zero):
            for t, kp in zip(hand.t_ns, hand.keypoints, strict=True):
                w.add_hand(int(t), kp, side=hand.side)
        for o in demo.objects.values():
            for i in range(len(o)):
                w.add_object_pose(o.name, int(o.t_ns[i]), o.position[i], o.quaternion[i])
    _refused_everywhere(capsys, rec, tmp_path, "the two hands are not on one clock")


def test_label_in_the_file_for_a_missing_hand(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    from lfd.io.labels import write_labels

    rec = tmp_path / "lefty.mcap"
    shutil.copyfile(EXP1, rec)
    start = lfd.load(rec, images=False).start_ns
    write_labels(rec, [SkillLabel("move", start, start + 10**9, hand="left")])
    _refused_everywhere(capsys, rec, tmp_path, "left hand, which the recording lacks")


def test_label_refuses_labels_for_a_missing_hand(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    """Given to ``lfd label``: in place and with -o, the recording unchanged, nothing written;
    a two-hand recording refuses a label that names no hand."""
    rec = tmp_path / "exp1.mcap"
    shutil.copyfile(EXP1, rec)
    before = _digest(rec)
    labels = tmp_path / "left.json"
    labels.write_text(json.dumps([{"skill": "move", "start_s": 0, "end_s": 1, "hand": "left"}]))
    expected = "is for the left hand, which the recording lacks (it has the right hand)"
    _one_line(capsys, "label", rec, "--from", labels, expected=expected)
    _one_line(capsys, "label", rec, "--from", labels, "-o", tmp_path / "o.mcap", expected=expected)
    csv = tmp_path / "left.csv"
    csv.write_text("skill,start_s,end_s,object,hand\nmove,0,1,,left\n")
    _one_line(capsys, "label", rec, "--from", csv, expected=expected)
    assert _digest(rec) == before and not (tmp_path / "o.mcap").exists()
    two = tmp_path / "two.mcap"
    save_two_hands(two)
    before = _digest(two)
    bare = tmp_path / "bare.json"
    bare.write_text(json.dumps([{"skill": "move", "start_s": 0, "end_s": 1}]))
    _one_line(capsys, "label", two, "--from", bare, expected="names no hand")
    assert _digest(two) == before


def test_label_writes_labels_per_hand_and_handovers(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    """A two-hand ``lfd segment --json`` report, with its handovers, into a two-hand recording;
    the lanes overlap each other (each is checked alone)."""
    two = tmp_path / "two.mcap"
    demo = save_two_hands(two)
    origin = demo.start_ns + 500_000_000
    report = {
        "hands": {
            "right": {
                "origin_ns": origin,
                "segments": [
                    {"skill": "pick_up", "start_s": 0.0, "end_s": 1.0, "object": "box_1"},
                    {"skill": "move_with", "start_s": 1.0, "end_s": 3.0, "object": "box_1"},
                ],
            },
            "left": {
                "origin_ns": origin,
                "segments": [
                    {"skill": "move", "start_s": 0.0, "end_s": 2.0},
                    {"skill": "move_with", "start_s": 2.0, "end_s": 4.0, "object": "box_1"},
                ],
            },
        },
        "handovers": [
            {
                "giver": "right",
                "taker": "left",
                "object": "box_1",
                "start_ns": origin + 2_000_000_000,
                "end_ns": origin + 3_000_000_000,
            }
        ],
    }
    src = tmp_path / "seg.json"
    src.write_text(json.dumps(report))
    out = tmp_path / "labelled.mcap"
    status, text, err = _lfd(capsys, "label", two, "--from", src, "-o", out)
    assert status == 0, err
    assert "right hand: pick_up(box_1)" in text and "left hand: move" in text
    back = lfd.load(out)
    assert [(lab.hand, lab.skill) for lab in back.labels_of("left")] == [
        ("left", "move"),
        ("left", "move_with"),
    ]
    assert [lab.start_ns - origin for lab in back.labels_of("right")] == [0, 1_000_000_000]
    assert [(h.giver, h.taker, h.object, h.end_ns - origin) for h in back.handovers] == [
        ("right", "left", "box_1", 3_000_000_000)
    ]
    # without handovers in the label file, the recording's are kept
    lanes = tmp_path / "lanes.json"
    lanes.write_text(json.dumps({"hands": report["hands"]}))
    status, _, err = _lfd(capsys, "label", out, "--from", lanes)
    assert status == 0, err
    assert lfd.load(out).handovers == back.handovers
    # info shows both hands, each lane's sequence and the handover
    status, text, _ = _lfd(capsys, "info", out)
    assert status == 0
    assert "hands: right 73 @ 4.9 Hz, left 73 @ 4.9 Hz" in text
    assert "left hand: move -> move_with" in text and "handovers" in text


@pytest.mark.parametrize("obj", [None, "", "-"], ids=["missing", "empty", "dash"])
def test_label_refuses_a_handover_without_its_object(
    obj: str | None, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    """A handover names the object handed over: without it the task program's handover had
    no object (``handover of -``) and ``lfd reproduce --robot aloha`` failed (exit 1). Refused
    in one line, the recording unchanged, nothing written."""
    two = tmp_path / "two.mcap"
    save_two_hands(two)
    before = _digest(two)
    handover = {"giver": "right", "taker": "left", "start_s": 2.0, "end_s": 3.0}
    if obj is not None:
        handover["object"] = obj
    labels = tmp_path / "labels.json"
    segments = [
        {"skill": "pick_up", "start_s": 0.0, "end_s": 1.0, "object": "box_1", "hand": "right"},
        {"skill": "move", "start_s": 0.0, "end_s": 2.0, "hand": "left"},
    ]
    labels.write_text(json.dumps({"segments": segments, "handovers": [handover]}))
    out = tmp_path / "out.mcap"
    expected = "handover 0 (right to left) names no object; give the object handed over (one of"
    _one_line(capsys, "label", two, "--from", labels, "-o", out, expected=expected)
    _one_line(capsys, "label", two, "--from", labels, expected=expected)
    assert _digest(two) == before and not out.exists()


def test_label_refuses_a_handover_without_its_end(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    """A handover with ``start_s`` and no ``end_s`` is one line (was a KeyError traceback)."""
    two = tmp_path / "two.mcap"
    save_two_hands(two)
    handover = {"giver": "right", "taker": "left", "object": "box_1", "start_s": 2.0}
    labels = tmp_path / "labels.json"
    segments = [
        {"skill": "move", "start_s": 0.0, "end_s": 2.0, "hand": h} for h in ("right", "left")
    ]
    labels.write_text(json.dumps({"segments": segments, "handovers": [handover]}))
    _one_line(
        capsys, "label", two, "--from", labels, expected="needs giver, taker, start_s and end_s"
    )
