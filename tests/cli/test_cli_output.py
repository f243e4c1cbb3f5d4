"""What the commands write where a newcomer first looks: tables piped to a file keep every name
whole, and an output directory's missing parents are created."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import _paths
import pytest
from lfd.cli import main
from lfd.cli._options import UNBOUNDED_WIDTH, make_console
from lfd.errors import UsageError
from lfd.outputs import check_output_dir, created_parents

ROOT = _paths.ROOT
EXP1 = ROOT / "recordings" / "exp1.mcap"
TOPICS = (
    "/camera/color/camera_info",
    "/hand/right/confidence",
    "/hand/right/keypoints",
    "/objects/box_1/pose",
    "foxglove.CameraCalibration",
    "foxglove.FrameTransforms",
)


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env.pop("COLUMNS", None)
    return env


def test_info_into_a_file_keeps_every_topic_name(tmp_path: Path) -> None:
    """``lfd info REC > file``: the channel table at its natural width, nothing cut to ``…``."""
    out = tmp_path / "info.txt"
    with out.open("w") as fh:
        proc = subprocess.run(
            [sys.executable, "-m", "lfd.cli", "info", str(EXP1), "--check"],
            stdout=fh,
            stderr=subprocess.PIPE,
            text=True,
            env=_env(),
            timeout=120,
            check=False,
        )
    assert proc.returncode == 0, proc.stderr
    text = out.read_text(encoding="utf-8")
    assert "…" not in text
    rows = [ln for ln in text.splitlines() if ln.startswith("│ /")]
    for name in TOPICS:
        assert any(name in row for row in rows), f"{name} not whole in:\n{text}"
    # one row per channel: nothing folded onto a second line either
    assert sum("/hand/right/keypoints" in row for row in rows) == 1


def test_batch_table_into_a_pipe_keeps_long_paths_on_one_line(tmp_path: Path) -> None:
    """``lfd segment A B`` piped: every recording's path whole on its row (it was folded over
    several lines at 80 columns)."""
    import shutil

    deep = tmp_path / ("recordings_of_the_first_session_" * 3)
    deep.mkdir()
    paths = [str(shutil.copy(ROOT / "recordings" / f"exp{k}.mcap", deep)) for k in (1, 2)]
    proc = subprocess.run(
        [sys.executable, "-m", "lfd.cli", "segment", *paths, "--jobs", "1"],
        capture_output=True,
        text=True,
        env=_env(),
        timeout=300,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr
    assert "…" not in proc.stdout
    for path in paths:
        assert any(path in line for line in proc.stdout.splitlines()), proc.stdout


def test_the_shared_console_is_unbounded_off_a_terminal(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("COLUMNS", raising=False)
    for stderr in (False, True):
        con = make_console(stderr=stderr)
        assert not con.is_terminal  # pytest captures both streams
        assert con.width == UNBOUNDED_WIDTH
    monkeypatch.setenv("COLUMNS", "100")  # a width the user asked for is kept
    assert make_console().width == 100


def test_long_names_in_a_table_are_not_cut(capsys: pytest.CaptureFixture[str]) -> None:
    from rich.table import Table

    name = "/hand/right/" + "very_long_segment_" * 12 + "keypoints"
    table = Table(title="channels")
    for col in ("topic", "schema"):
        table.add_column(col)
    table.add_row(name, "foxglove.PosesInFrame")
    make_console().print(table)
    out = capsys.readouterr().out
    assert name in out and "…" not in out


# --- output directories ---------------------------------------------------------------------
def test_output_dir_parents_allowed_and_made_then_removed_on_failure(tmp_path: Path) -> None:
    dest = tmp_path / "a" / "b" / "ds"
    with pytest.raises(UsageError, match="does not exist"):
        check_output_dir(dest)
    assert check_output_dir(dest, parents=True) == dest
    with pytest.raises(RuntimeError), created_parents(dest):
        assert (tmp_path / "a" / "b").is_dir() and not dest.exists()
        raise RuntimeError("the export failed")
    assert list(tmp_path.iterdir()) == []  # what it created, and nothing else, is gone
    with created_parents(dest):
        dest.mkdir()
    assert dest.is_dir()
    (tmp_path / "file").write_text("x")
    with pytest.raises(UsageError, match="is not a directory"):
        check_output_dir(tmp_path / "file" / "b" / "ds", parents=True)


def test_export_creates_the_parents_of_its_output(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """``lfd export lerobot REC -o a/b/ds`` where ``a/`` does not exist: written, parents made."""
    monkeypatch.setenv("HF_HUB_OFFLINE", "1")  # lerobot asks the Hub nothing for a local dataset
    pytest.importorskip("lerobot")
    monkeypatch.chdir(tmp_path)
    assert main(["export", "lerobot", str(EXP1), "-o", "a/b/ds", "--no-video"]) == 0
    assert (tmp_path / "a" / "b" / "ds" / "meta" / "info.json").is_file()
    assert "1 episode(s)" in capsys.readouterr().out
    # every input broken: one error line per recording and no directory left behind
    (tmp_path / "bad.mcap").write_bytes(b"not an mcap")
    assert main(["export", "lerobot", "bad.mcap", "-o", "c/d/ds"]) == 2
    assert not (tmp_path / "c").exists()


def test_an_output_that_is_a_pipe_is_refused_and_kept(tmp_path: Path) -> None:
    """``--json`` onto a FIFO (as onto /dev/null): a rename would replace the device or pipe with
    a regular file (as root, /dev/null itself); it is refused in one line, the pipe kept."""
    fifo = tmp_path / "seg.json"
    os.mkfifo(fifo)
    proc = subprocess.run(
        [sys.executable, "-m", "lfd.cli", "segment", str(EXP1), "--json", str(fifo)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 2, proc.stderr
    assert "not a regular file" in proc.stderr and len(proc.stderr.strip().splitlines()) == 1
    assert fifo.is_fifo()


def test_atomic_writes_never_replace_a_pipe(tmp_path: Path) -> None:
    from lfd.outputs import atomic_write_bytes

    fifo = tmp_path / "out.bin"
    os.mkfifo(fifo)
    with pytest.raises(UsageError, match="not a regular file"):
        atomic_write_bytes(fifo, b"x")
    assert fifo.is_fifo() and [p.name for p in tmp_path.iterdir()] == ["out.bin"]


# --- an output where nothing can be created: refused before any work, naming the user's path --
NO_FILES = Path("/proc")
"""A directory whose permissions allow writing (for root) but where no file can be created."""


@pytest.mark.skipif(not NO_FILES.is_dir(), reason="no /proc here")
@pytest.mark.parametrize(
    "argv",
    [
        ["reproduce", EXP1, "--mode", "skills", "--json", NO_FILES / "x.json"],
        ["reproduce", EXP1, "--mode", "skills", "--video", NO_FILES / "x.mp4"],
        ["reproduce", EXP1, "--mode", "skills", "--rerun-save", NO_FILES / "x.rrd"],
        ["export", "robot-data", EXP1, "-o", NO_FILES / "x", "--layouts", 1],
    ],
    ids=["json", "video", "rerun-save", "robot-data"],
)
def test_an_output_where_nothing_can_be_created_is_refused_up_front(
    argv: list[object], capsys: pytest.CaptureFixture[str]
) -> None:
    """``--json /proc/x.json`` as root: the permissions allow it, yet no file can be created
    there; refused at once (it was found only after the whole simulation, naming the hidden
    temporary file ``/proc/.x.json.*.partial``)."""
    import time

    t = time.perf_counter()
    assert main([str(a) for a in argv]) == 2
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and "Traceback" not in err, err
    assert f"{NO_FILES / 'x'}" in lines[0] and "is not writable" in lines[0], lines[0]
    assert ".partial" not in lines[0] and ".robot-data" not in lines[0], lines[0]
    assert time.perf_counter() - t < 10  # before the simulation


@pytest.mark.skipif(not NO_FILES.is_dir(), reason="no /proc here")
def test_a_failing_atomic_write_names_the_destination_not_the_temporary_file() -> None:
    from lfd.outputs import atomic_write_text, writable_dir

    assert not writable_dir(NO_FILES)
    with pytest.raises(OSError) as failed:
        atomic_write_text(NO_FILES / "x.json", "{}")
    assert failed.value.filename == str(NO_FILES / "x.json")
