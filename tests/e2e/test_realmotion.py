"""Real motion capture (``../shared/realmotion``, CC-BY-NC: read there, never copied here) and
the excluded spans of bimanual recordings: ``lfd eval`` leaves them out and says so, ``lfd label``
writes corrected labels into a copy, ``benches/segment_real.py`` runs (or skips without the
data). The tests that read the real recordings skip when the folder is absent."""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
from pathlib import Path

import _paths
import lfd
import pytest

ROOT = _paths.ROOT
REAL = ROOT.parent / "shared" / "realmotion"
EXP1 = ROOT / "recordings" / "exp1.mcap"
BENCH = ROOT / "benches" / "segment_real.py"
CROP = "manip_mug1_19.3-27.0s"
WHOLE = "manip_mug1"


@pytest.fixture
def realmotion() -> Path:
    if not REAL.is_dir():
        pytest.skip(f"{REAL} not found (the real motion-capture set)")
    return REAL


def _run(*argv: str | Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, *map(str, argv)], capture_output=True, text=True, timeout=600
    )


def test_eval_leaves_the_other_hands_spans_out(tmp_path: Path) -> None:
    """A synthetic bimanual recording: the spans of its metadata are excluded, and said so."""
    demo = lfd.load(EXP1, images=False)
    spans = {"other_hand_spans": [[5.0, 6.0]], "shared_spans": [[9.0, 9.5]]}
    path = tmp_path / "bimanual.mcap"
    lfd.save(dataclasses.replace(demo, metadata={**demo.metadata, **spans}), path)
    out = tmp_path / "eval.json"
    proc = _run("-m", "lfd.cli", "eval", path, "--methods", "dp", "--json", out)
    assert proc.returncode == 0, proc.stderr
    length = demo.duration_s
    assert f"bimanual.mcap: scored outside 2 spans (1.5 s of {length:.1f} s)" in proc.stdout
    rec = json.loads(out.read_text())["recordings"][0]
    assert rec["excluded_s"] == [[5.0, 6.0], [9.0, 9.5]]
    plain = _run("-m", "lfd.cli", "eval", EXP1, "--methods", "dp", "--json", "-")
    assert "scored outside" not in plain.stdout + plain.stderr
    assert "excluded_s" not in json.loads(plain.stdout)["recordings"][0]
    # the truth's boundary at 5.07 s (place -> move) lies inside a span: not scored
    assert rec["metrics"]["dp"]["boundary_error_s"] != pytest.approx(
        json.loads(plain.stdout)["recordings"][0]["metrics"]["dp"]["boundary_error_s"]
    )


def test_bench_skips_without_the_data(tmp_path: Path) -> None:
    proc = _run(BENCH, tmp_path / "absent")
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.startswith("segment_real: skipped: ") and "not found" in proc.stdout


@pytest.mark.slow
def test_bench_on_the_real_recordings(realmotion: Path, tmp_path: Path) -> None:
    out = tmp_path / "real.json"
    proc = _run(BENCH, realmotion, "--json", out)
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(out.read_text())
    groups = {g: int(next(iter(v.values()))["n"]) for g, v in doc["groups"].items()}
    assert groups == {"crops": 8, "whole": 6}
    assert set(doc["groups"]["crops"]) == {"lfd default", "--paper", "change points"}
    for r in doc["recordings"]:
        assert bool(r["excluded_s"]) == (r["group"] == "whole"), r["file"]
    crops = doc["groups"]["crops"]["lfd default"]
    assert 0.5 < crops["frame_accuracy"] <= 1.0 and crops["true_segments"] == 45
    assert "| lfd default | " in proc.stdout


@pytest.mark.slow
def test_eval_on_the_real_recordings(realmotion: Path) -> None:
    proc = _run("-m", "lfd.cli", "eval", realmotion, "--methods", "dp,changepoint", "--json", "-")
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(proc.stdout)
    names = {r["name"]: r for r in doc["recordings"]}
    assert len(names) == 14
    assert names[f"{WHOLE}.mcap"]["excluded_s"][0] == pytest.approx([13.4, 17.0333], abs=1e-3)
    assert "excluded_s" not in names[f"{CROP}.mcap"]
    assert f"{WHOLE}.mcap: scored outside 4 spans" in proc.stderr  # the tables go to stderr


@pytest.mark.slow  # segments and relabels a real motion-capture recording
def test_label_writes_corrected_labels_into_a_copy(realmotion: Path, tmp_path: Path) -> None:
    """Labels of the labels.json file (seconds from the first sample, no object) and a
    corrected ``lfd segment --json`` document, each written into a copy; the original stays."""
    src = realmotion / f"{WHOLE}.mcap"
    before = src.read_bytes()
    copy = tmp_path / "labelled.mcap"
    proc = _run("-m", "lfd.cli", "label", src, "--from", realmotion / f"{WHOLE}.labels.json",
                "-o", copy)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    orig, got = lfd.load(src, images=False), lfd.load(copy, images=False)
    assert [(x.skill, x.start_ns) for x in got.labels] == [
        (x.skill, x.start_ns) for x in orig.labels
    ]
    assert got.metadata["other_hand_spans"] == orig.metadata["other_hand_spans"]
    # correct the segmentation of a crop: drop its first segment, write it into a copy
    seg = tmp_path / "seg.json"
    crop = realmotion / f"{CROP}.mcap"
    assert _run("-m", "lfd.cli", "segment", crop, "--json", seg).returncode == 0
    doc = json.loads(seg.read_text())
    doc["segments"] = doc["segments"][1:]
    seg.write_text(json.dumps(doc))
    proc = _run("-m", "lfd.cli", "label", crop, "--from", seg, "-o", copy)
    assert proc.returncode == 0, proc.stderr
    assert [x.skill for x in lfd.load(copy, images=False).labels] == [
        s["skill"] for s in doc["segments"]
    ]
    assert src.read_bytes() == before
