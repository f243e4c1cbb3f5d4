"""``lfd label``: ground truth written into a recording, everything else copied unchanged.

The error cases (overlap, past the end, unknown skill or object, ...) are in the one table of
tests/cli/test_cli_errors.py.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

import _paths
import pytest
from lfd.cli import main
from lfd.io import load
from lfd.io.topics import GROUND_TRUTH_TOPIC
from mcap.reader import make_reader

ROOT = _paths.ROOT
EXP1 = ROOT / "recordings" / "exp1.mcap"


def _contents(path: Path) -> dict[str, Any]:
    """Everything an MCAP file holds apart from the ground truth, as comparable values."""
    with open(path, "rb") as f:
        r = make_reader(f)
        messages = [
            (
                ch.topic,
                ch.message_encoding,
                dict(ch.metadata),
                None if s is None else (s.name, s.encoding, s.data),
                m.log_time,
                m.publish_time,
                m.sequence,
                m.data,
            )
            for s, ch, m in r.iter_messages(log_time_order=False)
            if ch.topic != GROUND_TRUTH_TOPIC
        ]
        metadata = [(m.name, dict(m.metadata)) for m in r.iter_metadata()]
        header = r.get_header()
    return {"messages": messages, "metadata": metadata, "header": (header.profile, header.library)}


def test_segment_json_round_trip(tmp_path: Path) -> None:
    rec = tmp_path / "exp1.mcap"
    shutil.copy(EXP1, rec)
    seg = tmp_path / "seg.json"
    assert main(["segment", str(rec), "--json", str(seg)]) == 0
    doc = json.loads(seg.read_text())
    out = tmp_path / "labelled.mcap"
    assert main(["label", str(rec), "--from", str(seg), "-o", str(out)]) == 0
    assert rec.read_bytes() == EXP1.read_bytes()  # -o leaves the recording alone
    got = load(out, images=False).labels
    want = [(s["skill"], s["start_ns"], s["end_ns"], s["object"]) for s in doc["segments"]]
    assert [(g.skill, g.start_ns, g.end_ns, g.object) for g in got] == want
    assert want != [(g.skill, g.start_ns, g.end_ns, g.object) for g in load(EXP1).labels]
    assert _contents(out) == _contents(EXP1)
    assert len(_contents(out)["messages"]) > 2000


def test_csv_in_place_replaces_the_ground_truth(tmp_path: Path) -> None:
    rec = tmp_path / "exp1.mcap"
    shutil.copy(EXP1, rec)
    labels = tmp_path / "labels.csv"
    labels.write_text(
        "# seconds from the recording's first sample\n"
        "skill,start_s,end_s,object\n"
        "pick_up,0,1.5,box_2\n"
        "move_with,1.5,3.25,box_2\n"
        "place,3.25,5,box_2\n"
        "move,5,14.7,\n",
        encoding="utf-8",
    )
    assert main(["label", str(rec), "--from", str(labels)]) == 0
    demo = load(rec, images=False)
    t0 = demo.start_ns
    got = [(g.skill, g.start_ns - t0, g.end_ns - t0, g.object) for g in demo.labels]
    assert got == [
        ("pick_up", 0, 1_500_000_000, "box_2"),
        ("move_with", 1_500_000_000, 3_250_000_000, "box_2"),
        ("place", 3_250_000_000, 5_000_000_000, "box_2"),
        ("move", 5_000_000_000, 14_700_000_000, None),
    ]
    assert _contents(rec) == _contents(EXP1)
    assert not list(tmp_path.glob(".*partial"))


def test_json_list_and_edited_segmentation(tmp_path: Path) -> None:
    """A corrected segmentation: the edited seconds count, from the file's origin_ns."""
    from lfd.io.labels import read_labels

    demo = load(EXP1, images=False)
    origin = demo.start_ns + 33_333_333
    doc = {
        "origin_ns": origin,
        "segments": [
            {"skill": "pick_up", "start_s": 0.0, "end_s": 1.6, "object": "box_2", "start_ns": 1},
            {"skill": "move_with", "start_s": 1.6, "end_s": 3.0, "object": "box_2"},
        ],
    }
    path = tmp_path / "seg.json"
    path.write_text(json.dumps(doc), encoding="utf-8")
    labels = read_labels(path, demo)
    assert [(lab.start_ns - origin, lab.end_ns - origin) for lab in labels] == [
        (0, 1_600_000_000),
        (1_600_000_000, 3_000_000_000),
    ]
    path.write_text(json.dumps(doc["segments"]), encoding="utf-8")  # no origin: recording start
    assert read_labels(path, demo)[1].start_ns == demo.start_ns + 1_600_000_000


def test_incomplete_recording_is_refused(tmp_path: Path) -> None:
    from lfd.errors import RecordingFormatError
    from lfd.io.labels import write_labels

    rec = tmp_path / "cut.mcap"
    data = EXP1.read_bytes()
    rec.write_bytes(data[: len(data) * 2 // 3])
    before = rec.read_bytes()
    with pytest.raises(RecordingFormatError, match="incomplete"):
        write_labels(rec, load(EXP1, images=False).labels)
    assert rec.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cut.mcap"]
