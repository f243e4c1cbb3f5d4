"""``lfd segment`` and ``lfd eval`` on a two-hand recording: each hand's lane and the handovers,
the --json document's shape (docs/skills.md "Two hands"). The recording is the handover scene
of tests/_hands.py, given to the command as ``lfd.load``'s result (the
two-hand file format is lfd.io's)."""

from __future__ import annotations

import json
from pathlib import Path

import _paths
import pytest
from _hands import handover_demo


@pytest.fixture
def two_hand_load(monkeypatch: pytest.MonkeyPatch) -> None:
    import lfd.io

    monkeypatch.setattr(lfd.io, "load", lambda *args, **kwargs: handover_demo())


def test_segment_json_has_both_hands_and_the_handover(
    lfd_main, two_hand_load: None, tmp_path: Path
) -> None:
    out = tmp_path / "seg.json"
    got = lfd_main(["segment", _paths.EXP1, "--json", out])
    assert got.returncode == 0, got.stderr
    doc = json.loads(out.read_text())
    assert set(doc["hands"]) == {"right", "left"}
    for side in ("right", "left"):
        lane = doc["hands"][side]
        assert [s["skill"] for s in lane["segments"]] == [
            "move", "pick_up", "move_with", "place", "move",
        ]  # fmt: skip
        assert set(lane["metrics"]) >= {"frame_accuracy", "sequence_match", "boundary_error_s"}
    (h,) = doc["handovers"]
    assert (h["giver"], h["taker"], h["object"]) == ("right", "left", "box")
    assert set(doc["metrics"]) == {"right", "left", "handovers"}
    assert doc["metrics"]["handovers"]["found"] == 1.0
    assert doc["metrics"]["handovers"]["false"] == 0.0


def test_segment_prints_each_lane_and_the_handovers(lfd_main, two_hand_load: None) -> None:
    got = lfd_main(["segment", _paths.EXP1])
    assert got.returncode == 0, got.stderr
    assert "right hand" in got.stdout and "left hand" in got.stdout
    assert "handovers: 1/1 found within 0.3 s, 0 false" in got.stdout


def test_eval_scores_each_hand_and_the_handovers(
    lfd_main, two_hand_load: None, tmp_path: Path
) -> None:
    out = tmp_path / "eval.json"
    got = lfd_main(["eval", _paths.EXP1, "--methods", "dp,changepoint", "--json", out])
    assert got.returncode == 0, got.stderr
    doc = json.loads(out.read_text())
    assert set(doc["hands"]) == {"right", "left"}
    assert set(doc["hands"]["left"]) == {"dp", "changepoint"}
    assert doc["handovers"]["dp"]["found"] == 1.0
    assert [r["hand"] for r in doc["recordings"]] == ["right", "left"]
    assert "handovers, dp: 1/1 found within 0.3 s, 0 false" in got.stdout
