"""``lfd export robot-data REC -o DIR --layouts N``: bad input is one line and exit status 2 with
nothing written; a run prints a line per layout and the yield, and loads back with lerobot."""

from __future__ import annotations

import importlib.util
import json
import shutil
from pathlib import Path
from typing import Any

import pytest
from _far import far_recording
from _paths import EXP1


def _lfd(capsys: pytest.CaptureFixture[str], *argv: Any) -> tuple[int, str, str]:
    from lfd.cli import main

    try:
        status = main([str(a) for a in argv])
    except SystemExit as stop:  # a usage error, reported by argparse
        status = stop.code  # type: ignore[assignment]
    out = capsys.readouterr()
    return int(status or 0), out.out, out.err


def _refused(capsys: pytest.CaptureFixture[str], *argv: Any, expected: str) -> None:
    status, _, err = _lfd(capsys, "export", "robot-data", *argv)
    lines = [line for line in err.splitlines() if line.strip()]
    assert status == 2, err
    assert len(lines) == 1 and "Traceback" not in err, err
    assert lines[0].startswith("lfd export") and ": error: " in lines[0], lines[0]
    assert expected in lines[0], lines[0]


def test_bad_input_is_one_line_and_nothing_written(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    from _two_hands import save_two_hands

    rec = tmp_path / "exp1.mcap"
    shutil.copyfile(EXP1, rec)
    out = tmp_path / "ds"
    _refused(capsys, tmp_path / "none.mcap", "-o", out, "--layouts", 2, expected="does not exist")
    _refused(capsys, rec, "-o", out, "--layouts", 0, expected="--layouts")
    _refused(capsys, rec, "-o", out, "--layouts", -3, expected="--layouts")
    _refused(capsys, rec, "-o", rec, "--layouts", 2, expected="input")
    _refused(capsys, rec, "-o", out, "--layouts", 2, "--image-size", "big", expected="WIDTHxHEIGHT")
    _refused(capsys, rec, "-o", out, "--layouts", 2, "--robot", "ur9", expected="known robots")
    _refused(capsys, rec, "-o", out, "--layouts", 2, "--robot", "aloha", expected="two arms")
    save_two_hands(tmp_path / "two.mcap")
    _refused(capsys, tmp_path / "two.mcap", "-o", out, "--layouts", 2, expected="two-hand")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["exp1.mcap", "two.mcap"]
    assert rec.read_bytes() == EXP1.read_bytes()


def test_every_error_has_the_command_prefix(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    """An option argparse refuses and a file lfd refuses: both ``lfd export: error: ...`` (the
    first was ``lfd export robot-data: error: ...``), as every command's errors."""
    out = tmp_path / "ds"
    for argv in [
        (EXP1, "-o", out, "--layouts", 0),  # argparse
        (EXP1, "-o", out),  # argparse: a required option missing
        (tmp_path / "none.mcap", "-o", out, "--layouts", 2),  # lfd
    ]:
        status, _, err = _lfd(capsys, "export", "robot-data", *argv)
        assert status == 2 and err.startswith("lfd export: error: "), err
        assert len(err.strip().splitlines()) == 1, err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow  # plans the demonstration (~3-8 s here)
def test_object_out_of_reach_is_one_line(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    far = far_recording(tmp_path / "far.mcap")
    _refused(capsys, far, "-o", tmp_path / "ds", "--layouts", 2, expected="out of the arm's reach")
    _refused(capsys, far, "-o", tmp_path / "ds", "--layouts", 2, expected="is at (")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["far.mcap"]


@pytest.mark.slow  # simulates, renders and encodes one layout (~20 s)
@pytest.mark.skipif(importlib.util.find_spec("lerobot") is None, reason="lerobot not installed")
def test_one_layout_prints_progress_and_the_yield(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("HF_HUB_OFFLINE", "1")
    monkeypatch.setenv("HF_HOME", str(tmp_path / "hf"))
    out = tmp_path / "ds"
    status, stdout, err = _lfd(capsys, "export", "robot-data", EXP1, "-o", out, "--layouts", 1)
    assert status == 0 and err == "", err
    lines = stdout.splitlines()
    assert lines[0].startswith("layout 1/1: ok, "), stdout
    assert "1 episode(s) of 1 layouts (yield 100 %)" in lines[-1], stdout
    doc = json.loads((out / "meta" / "lfd_layouts.json").read_text())
    assert doc["tried"] == 1 and doc["settings"]["fps"] == 10
    assert not (out / "images").exists()  # lerobot's emptied frame directory is not left over
    # the same command again: the dataset is there, refused (one line) and kept
    _refused(capsys, EXP1, "-o", out, "--layouts", 1, expected="not empty")
    assert (out / "meta" / "lfd_layouts.json").is_file()


@pytest.mark.slow  # simulates a two-hand demonstration, runs, renders and encodes one layout
@pytest.mark.skipif(importlib.util.find_spec("lerobot") is None, reason="lerobot not installed")
@pytest.mark.skipif(importlib.util.find_spec("gym_aloha") is None, reason="gym-aloha missing")
def test_two_arms_print_progress_and_the_yield(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("HF_HUB_OFFLINE", "1")
    monkeypatch.setenv("HF_HOME", str(tmp_path / "hf"))
    rec, out = tmp_path / "hold_push.mcap", tmp_path / "ds"
    assert _lfd(capsys, "simulate", "hold_push", "--seed", 9501, "-o", rec)[0] == 0
    argv = ("export", "robot-data", rec, "--robot", "aloha", "-o", out, "--layouts", 1)
    status, stdout, err = _lfd(capsys, *argv)
    assert status == 0 and err == "", err
    lines = stdout.splitlines()
    assert lines[0].startswith("layout 1/1: ok, "), stdout
    assert "1 episode(s) of 1 layouts (yield 100 %)" in lines[-1], stdout
    doc = json.loads((out / "meta" / "lfd_layouts.json").read_text())
    assert doc["settings"]["robot"] == "aloha"
    info = json.loads((out / "meta" / "info.json").read_text())
    assert info["robot_type"] == "lfd_aloha"
    assert info["features"]["action"]["shape"] == [14]
