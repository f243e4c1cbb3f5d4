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


def test_label_count_is_limited_before_labels_are_built(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """More than MAX_LABELS labels and handovers are refused in one line; a CSV is not read past
    them (the row after the limit would be a CSV error if it were read)."""
    import lfd.io.labels as L
    from lfd.errors import UsageError

    demo = load(EXP1, images=False)
    monkeypatch.setattr(L, "MAX_LABELS", 3)
    rows = [f"move,{i},{i + 1}\n" for i in range(3)]
    csv_file = tmp_path / "labels.csv"
    csv_file.write_text("skill,start_s,end_s\n" + "".join(rows), encoding="utf-8")
    assert len(L.read_labels(csv_file, demo)) == 3  # the header is not a label
    csv_file.write_text("".join(rows) + "move,3,4\nmove,4," + "1" * 200_000 + "\n")
    with pytest.raises(UsageError, match="more than 3 labels and handovers") as err:
        L.read_labels(csv_file, demo)
    assert "\n" not in str(err.value)
    doc = [{"skill": "move", "start_s": i, "end_s": i + 1} for i in range(4)]
    json_file = tmp_path / "labels.json"
    json_file.write_text(json.dumps(doc), encoding="utf-8")
    with pytest.raises(UsageError, match="more than 3 labels and handovers"):
        L.read_labels(json_file, demo)


def test_label_limit_keeps_the_label_channels_readable() -> None:
    """MAX_LABELS of the largest label or handover messages fill at most half of what lfd info
    reads of a recording's label channels (LABEL_BYTES), so a labelled recording stays
    readable."""
    from lfd.demo import Handover, SkillLabel
    from lfd.io import messages as M
    from lfd.io.labels import LABEL_MESSAGE_BYTES, MAX_LABELS
    from lfd.io.summary import LABEL_BYTES
    from lfd.io.writer import MAX_OBJECT_NAME
    from lfd.skills import SKILLS

    obj = "\U0001f4e6" * MAX_OBJECT_NAME  # 4 UTF-8 bytes a character
    t = 2**63 - 1
    skill = max(SKILLS, key=len)
    sizes = [
        M.event(SkillLabel(skill, t - 1, t, obj, "right")).ByteSize(),
        M.handover_event(Handover(t - 1, t, "right", "left", obj)).ByteSize(),
    ]
    assert max(sizes) <= LABEL_MESSAGE_BYTES
    assert MAX_LABELS * LABEL_MESSAGE_BYTES <= LABEL_BYTES // 2
    assert MAX_LABELS >= 10_000  # generous: hours of one-second skills
    assert f"at most {MAX_LABELS} labels" in (ROOT / "docs" / "own-recordings.md").read_text()


@pytest.mark.parametrize("suffix", [".csv", ".json"])
def test_label_file_with_byte_order_mark(tmp_path: Path, suffix: str) -> None:
    """A UTF-8 byte order mark (Excel writes one before a CSV) is not part of the text: it was
    "unknown skill '\\ufeffskill'"."""
    from lfd.io.labels import read_labels

    demo = load(EXP1, images=False)
    path = tmp_path / f"labels{suffix}"
    text = (
        "skill,start_s,end_s,object\npick_up,0,1.5,box_2\n"
        if suffix == ".csv"
        else '[{"skill": "pick_up", "start_s": 0, "end_s": 1.5, "object": "box_2"}]'
    )
    path.write_bytes(b"\xef\xbb\xbf" + text.encode("utf-8"))
    labels = read_labels(path, demo)
    assert [(lab.skill, lab.end_ns - lab.start_ns, lab.object) for lab in labels] == [
        ("pick_up", 1_500_000_000, "box_2")
    ]
