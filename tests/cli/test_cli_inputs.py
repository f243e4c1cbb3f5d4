"""No output onto an input (issue 30): every file a command reads counts as one.

An input is the recording, its object-size sidecar (``REC.sizes.toml``), the ``--map`` TOML,
every file of a ROS bag and the bag directory itself, ``--templates`` and label files; an
existing recording is not replaced without ``--overwrite``; ``export --overwrite`` deletes only a
LeRobot dataset; an export never replaces a dataset that appeared while it ran, and leaves no
temporary directory when interrupted (Ctrl+C or SIGTERM); ``--follow`` does not follow a stale
partial file beside a complete recording.

The commands run in this process (:func:`lfd.cli.main`) where they can; each refusal must be
exit status 2, one line on stderr, and leave every input byte-identical and no file behind.
"""

from __future__ import annotations

import gc
import hashlib
import os
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import _paths
import pytest

ROOT = _paths.ROOT
RECORDINGS = ROOT / "recordings"
EXP1 = RECORDINGS / "exp1.mcap"
SIDECAR_TEXT = "[sizes]\nbox_1 = [0.05, 0.05, 0.05]\nbox_2 = [0.06, 0.04, 0.04]\n"


def _main(argv: list[Any], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    from lfd.cli import main

    status = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return status, out, err


def _tree(root: Path) -> dict[str, str]:
    """Every file under ``root`` (hidden ones included) -> a hash of its content."""
    return {
        str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(root.rglob("*"))
        if p.is_file()
    }


def _refused(argv: list[Any], capsys: pytest.CaptureFixture[str], root: Path, expected: str) -> str:
    """Run ``argv``: exit 2, one error line with ``expected``, nothing under ``root`` changed."""
    before = _tree(root)
    status, _, err = _main(argv, capsys)
    lines = [line for line in err.splitlines() if line.strip()]
    assert status == 2, err
    assert len(lines) == 1, err
    assert lines[0].startswith("lfd ") and ": error: " in lines[0], lines[0]
    assert expected in lines[0], lines[0]
    assert _tree(root) == before  # every input byte-identical, no output nor temporary file
    return lines[0]


@pytest.fixture
def rec(tmp_path: Path) -> Path:
    """A copy of exp1 with an object-size sidecar beside it."""
    path = tmp_path / "e1.mcap"
    shutil.copyfile(EXP1, path)
    (tmp_path / "e1.mcap.sizes.toml").write_text(SIDECAR_TEXT, encoding="utf-8")
    return path


# --- 1. every file a command reads is an input -------------------------------------------------
def test_segment_json_onto_the_sidecar(rec: Path, tmp_path: Path, capsys: Any) -> None:
    side = tmp_path / "e1.mcap.sizes.toml"
    line = _refused(["segment", rec, "--json", side], capsys, tmp_path, "also an input")
    assert "object sizes of" in line


def test_info_json_onto_the_sidecar(rec: Path, tmp_path: Path, capsys: Any) -> None:
    side = tmp_path / "e1.mcap.sizes.toml"
    _refused(["info", rec, "--json", side], capsys, tmp_path, "also an input")


def test_segment_batch_json_onto_a_sidecar_of_another_spelling(
    rec: Path, tmp_path: Path, capsys: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    other = tmp_path / "e2.mcap"
    shutil.copyfile(EXP1, other)
    monkeypatch.chdir(tmp_path)
    argv = ["segment", rec, other, "--jobs", "1", "--json", "./sub/../e1.mcap.sizes.toml"]
    (tmp_path / "sub").mkdir()
    _refused(argv, capsys, tmp_path, "also an input")


def test_templates_train_output_onto_the_sidecar(rec: Path, tmp_path: Path, capsys: Any) -> None:
    side = tmp_path / "e1.mcap.sizes.toml"
    argv = ["templates", "train", rec, "-o", side, "--jobs", "1"]
    _refused(argv, capsys, tmp_path, "also an input")


@pytest.fixture
def ros1(tmp_path: Path) -> tuple[Path, Path]:
    """The shipped ROS 1 bag and its mapping, copied."""
    bag, mapping = tmp_path / "exp1.bag", tmp_path / "exp1.toml"
    shutil.copyfile(RECORDINGS / "ros" / "exp1.bag", bag)
    shutil.copyfile(RECORDINGS / "ros" / "exp1.toml", mapping)
    return bag, mapping


def test_batch_json_onto_the_map(ros1: tuple[Path, Path], tmp_path: Path, capsys: Any) -> None:
    pytest.importorskip("rosbags")
    bag, mapping = ros1
    second = tmp_path / "again.bag"
    shutil.copyfile(bag, second)
    argv = ["segment", bag, second, "--map", mapping, "--jobs", "1", "--json", mapping]
    _refused(argv, capsys, tmp_path, "also an input")


def test_info_json_onto_the_map(ros1: tuple[Path, Path], tmp_path: Path, capsys: Any) -> None:
    pytest.importorskip("rosbags")
    bag, mapping = ros1
    _refused(["info", bag, "--map", mapping, "--json", mapping], capsys, tmp_path, "also an input")


@pytest.fixture(scope="module")
def ros2_bags(tmp_path_factory: pytest.TempPathFactory) -> dict[str, tuple[Path, str]]:
    """ROS 2 bag directories of exp1 (tests/_rosbags.py), mcap and sqlite3 storage, with
    their mapping text."""
    pytest.importorskip("rosbags")
    import lfd
    from _rosbags import write_ros2

    d = tmp_path_factory.mktemp("ros2")
    demo = lfd.load(EXP1, images=False)
    return {
        storage: (d / storage, write_ros2(demo, d / storage, storage))
        for storage in ("mcap", "sqlite3")
    }


@pytest.fixture(params=["mcap", "sqlite3"])
def ros2(
    request: pytest.FixtureRequest, ros2_bags: dict[str, tuple[Path, str]], tmp_path: Path
) -> tuple[Path, Path]:
    """A copy of a ROS 2 bag directory in ``tmp_path`` and its mapping file."""
    src, text = ros2_bags[request.param]
    bag = tmp_path / "bag"
    shutil.copytree(src, bag)
    mapping = tmp_path / "map.toml"
    mapping.write_text(text, encoding="utf-8")
    return bag, mapping


def test_json_onto_a_bags_metadata(ros2: tuple[Path, Path], tmp_path: Path, capsys: Any) -> None:
    """The bag named by its directory or by its storage file (.mcap, .db3)."""
    bag, mapping = ros2
    argv = ["info", bag, "--map", mapping, "--json", bag / "metadata.yaml"]
    _refused(argv, capsys, tmp_path, "a ROS bag directory being read")
    storage = next(p for p in bag.iterdir() if p.suffix in (".mcap", ".db3"))
    argv = ["segment", storage, "--map", mapping, "--json", bag / "metadata.yaml"]
    _refused(argv, capsys, tmp_path, "a ROS bag directory being read")


def test_import_onto_the_bags_own_storage_file(
    ros2: tuple[Path, Path], tmp_path: Path, capsys: Any
) -> None:
    bag, mapping = ros2
    storage = next(p for p in bag.iterdir() if p.suffix in (".mcap", ".db3"))
    out = storage if storage.suffix == ".mcap" else bag / "bag_0.mcap"
    argv = ["import", "ros", bag, "--map", mapping, "-o", out]
    _refused(argv, capsys, tmp_path, "a ROS bag directory being read")


def test_import_nothing_written_inside_the_bag(
    ros2: tuple[Path, Path], tmp_path: Path, capsys: Any
) -> None:
    """Neither a new file inside the bag directory, nor when the bag is named by its .db3."""
    bag, mapping = ros2
    storage = next(p for p in bag.iterdir() if p.suffix in (".mcap", ".db3"))
    for given in (bag, storage):
        argv = ["import", "ros", given, "--map", mapping, "-o", bag / "new.mcap"]
        _refused(argv, capsys, tmp_path, "a ROS bag directory being read")


def test_import_beside_the_bag_still_works(
    ros2: tuple[Path, Path], tmp_path: Path, capsys: Any
) -> None:
    bag, mapping = ros2
    before = _tree(bag)
    status, _, err = _main(
        ["import", "ros", bag, "--map", mapping, "-o", tmp_path / "out.mcap"], capsys
    )
    assert status == 0, err
    assert (tmp_path / "out.mcap").is_file() and _tree(bag) == before


def test_label_output_onto_the_recording_spelled_otherwise_is_in_place(
    rec: Path, tmp_path: Path, capsys: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``-o ./sub/../e1.mcap`` is the recording: rewritten in place; the label file and the
    sidecar are untouched."""
    labels = tmp_path / "labels.csv"
    labels.write_text("pick_up,0.5,2.0,box_2\n", encoding="utf-8")
    (tmp_path / "sub").mkdir()
    monkeypatch.chdir(tmp_path)
    kept = {p: p.read_bytes() for p in (labels, tmp_path / "e1.mcap.sizes.toml")}
    status, _, err = _main(["label", "e1.mcap", "--from", labels, "-o", "sub/../e1.mcap"], capsys)
    assert status == 0, err
    assert {p: p.read_bytes() for p in kept} == kept
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "e1.mcap",
        "e1.mcap.sizes.toml",
        "labels.csv",
        "sub",
    ]
    import lfd

    assert [lab.skill for lab in lfd.load(rec).labels] == ["pick_up"]


def test_label_recording_rewritten_in_place_cannot_be_the_label_file(
    tmp_path: Path, capsys: Any
) -> None:
    """Labels read from the recording they are written into: refused (an input)."""
    labels = tmp_path / "labels.mcap"
    shutil.copyfile(EXP1, labels)
    _refused(["label", labels, "--from", labels], capsys, tmp_path, "also an input")


# --- 2. simulate does not replace a recording without --overwrite -----------------------------
def test_simulate_refuses_an_existing_recording(
    rec: Path, tmp_path: Path, capsys: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    pytest.importorskip("mujoco")
    monkeypatch.setenv("MUJOCO_GL", os.environ.get("MUJOCO_GL", "egl"))
    _refused(["simulate", "exp1", "-o", rec], capsys, tmp_path, "pass --overwrite")


def test_simulate_overwrite_replaces_it(
    tmp_path: Path, capsys: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    pytest.importorskip("mujoco")
    monkeypatch.setenv("MUJOCO_GL", os.environ.get("MUJOCO_GL", "egl"))
    out = tmp_path / "d.mcap"
    out.write_bytes(EXP1.read_bytes())
    argv = ["simulate", "pick_up", "--seed", "1", "--duration", "3", "-o", out, "--overwrite"]
    status, _, err = _main(argv, capsys)
    assert status == 0, err
    assert out.read_bytes() != EXP1.read_bytes()


def test_record_refuses_an_existing_recording(rec: Path, tmp_path: Path, capsys: Any) -> None:
    # refused before the source opens: no camera or simulator is needed to see it
    argv = ["record", "--source", "camera:0", "-o", rec]
    _refused(argv, capsys, tmp_path, "pass --overwrite")


def test_simulate_set_says_which_recordings_it_replaces(tmp_path: Path) -> None:
    pytest.importorskip("mujoco")
    out = tmp_path / "set"
    out.mkdir()
    # another recording under the name the set writes: replaced by the set's exp1 (the
    # simulation is deterministic, so the replacement may equal the shipped exp1 bit for bit)
    other = (RECORDINGS / "exp2.mcap").read_bytes()
    (out / "exp1.mcap").write_bytes(other)
    # in a subprocess: the set renders a sample, and Mesa's EGL (with its LLVM) loaded into this
    # process makes a later import of triton (torch, in the export tests) crash
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    proc = subprocess.run(
        [sys.executable, "-m", "lfd.cli", "simulate", "--set", "samples", "-o", str(out)],
        capture_output=True,
        text=True,
        timeout=300,
        env=env,
    )
    err = proc.stderr
    assert proc.returncode == 0, err
    assert "warning: replacing 1 existing recordings of the samples set" in err, err
    assert (out / "exp1.mcap").read_bytes() != other
    from lfd.io import load

    assert load(out / "exp1.mcap").metadata.get("task") == load(EXP1).metadata.get("task")


# --- 3-5. export: only a dataset is replaced, never one that appeared, nothing left -----------
@pytest.fixture
def offline(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """lerobot must touch neither the network nor the user's Hugging Face cache."""
    pytest.importorskip("lerobot")
    monkeypatch.setenv("HF_HUB_OFFLINE", "1")
    monkeypatch.setenv("HF_HOME", str(tmp_path / "hf"))


def test_export_overwrite_keeps_a_directory_that_is_not_a_dataset(
    offline: None, rec: Path, tmp_path: Path, capsys: Any
) -> None:
    ds = tmp_path / "ds"
    ds.mkdir()
    (ds / "notes.txt").write_text("mine", encoding="utf-8")
    argv = ["export", "lerobot", rec, "-o", ds, "--overwrite", "--no-video", "--jobs", "1"]
    _refused(argv, capsys, tmp_path, "not a LeRobot dataset")


def test_export_overwrite_keeps_the_templates_it_reads(
    offline: None, rec: Path, tmp_path: Path, capsys: Any
) -> None:
    """A dataset directory that holds the --templates file: replacing it would delete an
    input (and the file is not part of a dataset either)."""
    ds = tmp_path / "ds"
    (ds / "meta").mkdir(parents=True)
    (ds / "meta" / "info.json").write_text("{}", encoding="utf-8")
    templates = ds / "templates.json"
    from lfd.segmentation import Templates

    Templates.default().save(templates)
    argv = ["export", "lerobot", rec, "-o", ds, "--overwrite", "--templates", templates]
    _refused([*argv, "--labels", "segment", "--jobs", "1"], capsys, tmp_path, "templates.json")


def test_export_overwrite_replaces_a_dataset(
    offline: None, rec: Path, tmp_path: Path, capsys: Any
) -> None:
    ds = tmp_path / "ds"
    for part in ("meta", "data/chunk-000"):
        (ds / part).mkdir(parents=True)
    (ds / "meta" / "info.json").write_text("{}", encoding="utf-8")
    (ds / "data" / "chunk-000" / "old.parquet").write_bytes(b"old")
    argv = ["export", "lerobot", rec, "-o", ds, "--overwrite", "--no-video", "--jobs", "1"]
    status, _, err = _main(argv, capsys)
    assert status == 0, err
    assert not (ds / "data" / "chunk-000" / "old.parquet").exists()
    assert (ds / "meta" / "lfd_program.json").is_file()
    assert not list(tmp_path.glob(".ds.*"))


def test_export_does_not_replace_a_dataset_that_appeared_meanwhile(
    offline: None, rec: Path, tmp_path: Path, capsys: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Another export finishes ``ds`` while this one writes (neither with --overwrite): the
    rename refuses to replace it; its dataset is kept, this one's discarded."""
    from lfd.export import lerobot

    ds = tmp_path / "ds"
    close = lerobot.LeRobotWriter.close

    def other_export_finishes_first(self: Any) -> None:
        (ds / "meta").mkdir(parents=True)
        (ds / "meta" / "info.json").write_text('{"other": 1}', encoding="utf-8")
        close(self)

    monkeypatch.setattr(lerobot.LeRobotWriter, "close", other_export_finishes_first)
    argv = ["export", "lerobot", rec, "-o", ds, "--no-video", "--jobs", "1"]
    status, _, err = _main(argv, capsys)
    lines = [line for line in err.splitlines() if line.strip()]
    assert status == 2 and len(lines) == 1, err
    assert "appeared while" in lines[0] and "--overwrite" in lines[0]
    assert _tree(ds) == {"meta/info.json": hashlib.sha256(b'{"other": 1}').hexdigest()}
    assert sorted(p.name for p in tmp_path.iterdir() if p.name != "hf") == [
        "ds",
        "e1.mcap",
        "e1.mcap.sizes.toml",
    ]


def test_atomic_directory_without_overwrite_refuses_at_the_rename(tmp_path: Path) -> None:
    from lfd.errors import UsageError
    from lfd.outputs import atomic_directory

    dest = tmp_path / "ds"
    with pytest.raises(UsageError, match="appeared while"):
        with atomic_directory(dest, overwrite=False) as new:
            new.mkdir()
            (new / "mine").write_text("this run")
            dest.mkdir()
            (dest / "theirs").write_text("other run")
    assert [p.name for p in tmp_path.iterdir()] == ["ds"]
    assert [p.name for p in dest.iterdir()] == ["theirs"]
    with atomic_directory(tmp_path / "empty", overwrite=False) as new:  # onto an empty one: ok
        (tmp_path / "empty").mkdir()
        new.mkdir()
        (new / "mine").write_text("this run")
    assert [p.name for p in (tmp_path / "empty").iterdir()] == ["mine"]


def test_export_interrupted_leaves_no_partial_directory(
    offline: None, rec: Path, tmp_path: Path, capsys: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Ctrl+C after an episode was written: lerobot's buffered metadata must not recreate the
    temporary directory when its dataset object is collected after the cleanup."""
    from lfd.export import lerobot

    add = lerobot.LeRobotWriter.add

    def add_then_interrupt(self: Any, ep: Any) -> int:
        add(self, ep)
        raise KeyboardInterrupt

    monkeypatch.setattr(lerobot.LeRobotWriter, "add", add_then_interrupt)
    argv = ["export", "lerobot", rec, rec, "-o", tmp_path / "ds", "--no-video", "--jobs", "1"]
    status, _, err = _main(argv, capsys)
    gc.collect()
    assert status == 130, err
    assert err.strip() == "lfd export: interrupted"
    left = sorted(p.name for p in tmp_path.iterdir() if p.name != "hf")
    assert left == ["e1.mcap", "e1.mcap.sizes.toml"]


def _wait_for(check: Callable[[], bool], timeout: float) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if check():
            return True
        time.sleep(0.05)
    return False


@pytest.mark.slow  # a subprocess that imports lerobot: 15-50 s on 2 busy cores
def test_export_sigterm_is_handled_like_ctrl_c(offline: None, tmp_path: Path) -> None:
    """SIGTERM once the first episode is written: exit 130, no temporary directory, no
    dataset."""
    recs = [RECORDINGS / f"exp{i}.mcap" for i in (1, 2, 3, 4)] * 3
    ds = tmp_path / "ds"
    argv = [sys.executable, "-m", "lfd.cli", "export", "lerobot", *map(str, recs), "-o", str(ds)]
    proc = subprocess.Popen(
        [*argv, "--no-video", "--jobs", "1"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        written = _wait_for(lambda: any(tmp_path.glob(".ds.*.partial/ds/data/*")), 240)
        assert written, "the export wrote no episode"
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 130, err
    assert [line for line in err.splitlines() if line.strip()] == ["lfd export: interrupted"]
    assert sorted(p.name for p in tmp_path.iterdir() if p.name != "hf") == []


# --- 6. --follow: a stale partial beside a complete recording is not followed -----------------
def _stale_partial(rec: Path, age_s: float) -> Path:
    """A partial file of an earlier recorder that died, beside ``rec``: half of exp2."""
    partial = rec.parent / f".{rec.name}.k3j4h5g6.partial"
    data = (RECORDINGS / "exp2.mcap").read_bytes()
    partial.write_bytes(data[: len(data) // 2])
    t = time.time() - age_s
    os.utime(partial, (t, t))
    return partial


def test_follow_prefers_the_complete_recording(rec: Path, tmp_path: Path, capsys: Any) -> None:
    partial = _stale_partial(rec, 2 * 24 * 3600)
    kept = partial.read_bytes()
    out = tmp_path / "out.json"
    argv = ["segment", rec, "--follow", "--idle-timeout", "1", "--json", out]
    status, stdout, err = _main(argv, capsys)
    assert status == 0, err
    assert f"followed {rec}:" in " ".join(stdout.split())
    import json

    import lfd

    doc = json.loads(out.read_text(encoding="utf-8"))
    assert doc["live"]["stopped"] == "end"
    truth = [lab.skill for lab in lfd.load(rec).labels]
    assert [s["skill"] for s in doc["segments"]] == truth
    assert partial.read_bytes() == kept


def test_live_partial_only_while_a_recorder_writes_it(rec: Path) -> None:
    from lfd.io.follow import live_partial

    assert live_partial(rec) is None
    partial = _stale_partial(rec, 60.0)  # older than the complete file: left by a dead recorder
    os.utime(rec, (time.time() - 30, time.time() - 30))
    assert live_partial(rec) is None
    now = time.time()
    os.utime(partial, (now, now))  # a new take being written over the recording
    assert live_partial(rec, idle_timeout_s=10.0) == str(partial)
    os.utime(partial, (now - 20, now - 20))  # newer than the file, but stopped growing
    assert live_partial(rec, idle_timeout_s=10.0) is None
    assert live_partial(rec) == str(partial)
    rec.unlink()  # no complete recording: whatever a recorder left is followed
    os.utime(partial, (now - 3600, now - 3600))
    assert live_partial(rec, idle_timeout_s=10.0) == str(partial)
