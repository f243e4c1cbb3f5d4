"""``lfd export lerobot``: recordings written through lerobot's API load back with its loader,
with the skill labels of the ground truth frame by frame and the trajectory's values."""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import _paths
import lfd
import numpy as np
import pytest
from _signals import ctrl_c_as_from_a_terminal
from lfd.errors import LfdError, UsageError
from lfd.export import export_lerobot
from lfd.export.lerobot import NO_SKILL
from lfd.skills import SKILLS

ROOT = _paths.ROOT
RECORDINGS = [ROOT / "recordings" / "exp1.mcap", ROOT / "recordings" / "exp4.mcap"]
RENDERED = ROOT / "recordings" / "rendered" / "exp1_short.mcap"


@pytest.fixture(autouse=True)
def _offline(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """lerobot must touch neither the network nor the user's Hugging Face cache."""
    monkeypatch.setenv("HF_HUB_OFFLINE", "1")
    monkeypatch.setenv("HF_HOME", str(tmp_path / "hf"))


needs_lerobot = pytest.mark.skipif(
    importlib.util.find_spec("lerobot") is None, reason="lerobot not installed (the lerobot extra)"
)


def LeRobotDataset(repo_id: str, **kwargs: Any) -> Any:
    """lerobot's dataset loader, imported when a test reads a dataset back."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset as Loader

    return Loader(repo_id, **kwargs)


def _gt_at(labels: list[lfd.SkillLabel], t: int) -> lfd.SkillLabel | None:
    for n, lab in enumerate(labels):
        if lab.start_ns <= t < lab.end_ns or (n == len(labels) - 1 and t == lab.end_ns):
            return lab
    return None


@pytest.fixture(scope="module")
def exported(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("lerobot") / "demos"
    os.environ.setdefault("HF_HUB_OFFLINE", "1")
    report = export_lerobot(RECORDINGS, out)
    assert [r.error for r in report.results] == [None, None]
    return out


@needs_lerobot
def test_loads_back_with_labels_and_values(exported: Path) -> None:
    ds = LeRobotDataset("lfd/demos", root=exported, video_backend="pyav")
    assert ds.num_episodes == 2
    program = json.loads((exported / "meta" / "lfd_program.json").read_text())
    table = ds.hf_dataset.with_format("numpy")[:]
    start = 0
    for ep, path in enumerate(RECORDINGS):
        demo = lfd.load(path)
        traj = lfd.preprocess(demo, **lfd.Method.default().preprocessing)
        n = len(traj)
        rows = slice(start, start + n)
        assert (table["episode_index"][rows] == ep).all()
        assert ds.meta.episodes[ep]["length"] == n
        # values: the preprocessed trajectory at 30 Hz, in float32
        state = np.stack(table["observation.state"][rows])
        np.testing.assert_allclose(state[:, :3], traj.tcp, rtol=1e-6, atol=1e-7)
        np.testing.assert_allclose(state[:, 7], traj.opening, rtol=1e-6, atol=1e-7)
        np.testing.assert_allclose(np.stack(table["action"][rows])[:-1], state[1:])
        keypoints = np.stack(table["observation.hand_keypoints"][rows]).reshape(n, 21, 3)
        np.testing.assert_allclose(keypoints, traj.keypoints, rtol=1e-6, atol=1e-7)
        objects = np.stack(table["observation.objects"][rows]).reshape(n, -1, 7)
        k = traj.object_names.index("box_2")
        np.testing.assert_allclose(objects[:, k, :3], traj.object_position[k], atol=1e-7)
        np.testing.assert_allclose(objects[:, k, 3:], traj.object_quaternion[k], atol=1e-7)
        # labels: the ground truth at each frame's time
        names = program["episodes"][ep]["objects"]
        for i in range(0, n, 7):
            gt = _gt_at(demo.labels, int(traj.t_ns[i]))
            item = ds[start + i]
            want = (
                NO_SKILL if gt is None else (f"{gt.skill} {gt.object}" if gt.object else gt.skill)
            )
            assert item["subtask"] == want
            assert int(item["skill_index"]) == (SKILLS.index(gt.skill) if gt else -1)
            obj = int(item["object_index"])
            assert (names[obj] if obj >= 0 else None) == (gt.object if gt else None)
        assert {int(s) for s in table["skill_index"][rows]} == {
            SKILLS.index(lab.skill) for lab in demo.labels
        }
        # the segments as lerobot's per-episode subtask annotation (SARM layout)
        meta = ds.meta.episodes[ep]
        texts = [f"{lab.skill} {lab.object}" if lab.object else lab.skill for lab in demo.labels]
        assert list(meta["subtask_names"]) == texts == list(meta["sparse_subtask_names"])
        subtasks = [ds.meta.subtasks.index[int(v)] for v in table["subtask_index"][rows]]
        for name, first, last in zip(
            texts, meta["subtask_start_frames"], meta["subtask_end_frames"], strict=True
        ):
            assert set(subtasks[first : last + 1]) == {name}
        assert meta["subtask_start_frames"][0] == 0 and meta["subtask_end_frames"][-1] == n - 1
        # the task program in the metadata, lerobot's task the program as a sentence
        entry = program["episodes"][ep]
        assert entry["recording"] == str(path) and entry["labels"] == "ground-truth"
        assert [s["skill"] for s in entry["program"]["segments"]] == demo.skill_sequence
        assert ds[start]["task"] == entry["task"]
        assert entry["task"].split(", ")[0].split()[0] == demo.labels[0].skill
        start += n
    assert ds.num_frames == start


@needs_lerobot
def test_segmentation_labels_without_ground_truth(tmp_path: Path) -> None:
    """--labels segment: the labels are lfd.segment's, frame by frame."""
    out = tmp_path / "seg"
    report = export_lerobot([RECORDINGS[0]], out, labels="segment")
    assert report.results[0].labels == "segment"
    demo = lfd.load(RECORDINGS[0])
    seg = lfd.segment(demo)
    ds = LeRobotDataset("lfd/seg", root=out, video_backend="pyav")
    t = lfd.preprocess(demo, **lfd.Method.default().preprocessing).t_ns
    labels = [s.to_label() for s in seg.segments]
    for i in range(0, len(t), 11):
        gt = _gt_at(labels, int(t[i]))
        assert int(ds[i]["skill_index"]) == (SKILLS.index(gt.skill) if gt else -1)


@pytest.mark.slow  # encodes and decodes a video (AV1)
@needs_lerobot
def test_video_from_rendered_recording(tmp_path: Path, capfd: pytest.CaptureFixture[str]) -> None:
    import av

    out = tmp_path / "video"
    export_lerobot([RENDERED], out)
    assert capfd.readouterr().err == ""  # no encoder banner, no progress bar
    ds = LeRobotDataset("lfd/video", root=out, video_backend="pyav")
    assert "observation.images.color" in ds.meta.video_keys
    files = list((out / "videos").rglob("*.mp4"))
    assert len(files) == 1
    with av.open(str(files[0])) as c:
        frames = [f.to_ndarray(format="rgb24") for f in c.decode(video=0)]
    assert (
        len(frames)
        == ds.num_frames
        == len(lfd.preprocess(lfd.load(RENDERED), **lfd.Method.default().preprocessing))
    )
    demo = lfd.load(RENDERED)
    assert demo.color is not None
    assert frames[0].shape == demo.color.frames[0].shape
    # frame 0 shows the first image (lossy codec: close, not equal)
    err = np.abs(frames[0].astype(float) - demo.color.frames[0].astype(float)).mean()
    assert err < 8.0


@needs_lerobot
def test_refuses_non_empty_directory_and_overwrites_on_request(tmp_path: Path) -> None:
    out = tmp_path / "ds"
    out.mkdir()
    (out / "keep.txt").write_text("mine")
    with pytest.raises(UsageError, match="not empty"):
        export_lerobot([RECORDINGS[0]], out)
    assert (out / "keep.txt").read_text() == "mine"
    # --overwrite replaces a dataset only, never a directory of the user's (issue 30)
    with pytest.raises(UsageError, match="not a LeRobot dataset"):
        export_lerobot([RECORDINGS[0]], out, overwrite=True)
    assert (out / "keep.txt").read_text() == "mine"
    (out / "keep.txt").unlink()
    (out / "meta").mkdir()
    (out / "meta" / "info.json").write_text("{}")
    export_lerobot([RECORDINGS[0]], out, overwrite=True)
    assert (out / "meta" / "info.json").read_text() != "{}"
    assert [p.name for p in tmp_path.iterdir()] == ["ds"]  # no temporary directory left


@needs_lerobot
def test_bad_file_skipped_others_exported(tmp_path: Path) -> None:
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(b"\x00\xff not an mcap file")
    out = tmp_path / "ds"
    report = export_lerobot([bad, RECORDINGS[0]], out)
    assert report.results[0].error and "bad.mcap" in report.results[0].error
    assert report.results[1].episode_index == 0
    assert LeRobotDataset("lfd/ds", root=out, video_backend="pyav").num_episodes == 1


@needs_lerobot
def test_nothing_exported_leaves_nothing(tmp_path: Path) -> None:
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(b"\x00\xff not an mcap file")
    with pytest.raises(LfdError, match="no recording could be exported"):
        export_lerobot([bad], tmp_path / "ds")
    assert [p.name for p in tmp_path.iterdir()] == ["bad.mcap"]


@needs_lerobot
def test_ground_truth_asked_without_labels(tmp_path: Path) -> None:
    report = export_lerobot(
        [ROOT / "recordings" / "perceived" / "exp1.mcap", RECORDINGS[0]],
        tmp_path / "ds",
        labels="ground-truth",
    )
    assert "no ground-truth labels" in (report.results[0].error or "")
    assert report.results[1].error is None


@needs_lerobot
def test_cli_reports_skipped_file(tmp_path: Path, lfd_main: Callable[..., Any]) -> None:
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(b"\x00\xff not an mcap file")
    out = tmp_path / "ds"
    proc = lfd_main(["export", "lerobot", bad, RECORDINGS[0], "-o", out, "--jobs", "1"])
    assert proc.returncode == 1, proc.stderr
    errors = proc.stderr.strip().splitlines()
    assert len(errors) == 1 and "bad.mcap" in errors[0] and errors[0].endswith("(skipped)")
    assert errors[0].startswith("lfd export: error: ")
    assert "1 episode(s)" in proc.stdout


def test_without_lerobot_says_how_to_install(tmp_path: Path) -> None:
    """lerobot missing: one line with the install command, before any output is made."""
    code = (
        "import sys\n"
        "class Block:\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name.split('.')[0] == 'lerobot':\n"
        "            raise ModuleNotFoundError(f'blocked: {name}', name=name)\n"
        "sys.meta_path.insert(0, Block())\n"
        "from lfd.cli import main\n"
        f"sys.exit(main(['export', 'lerobot', {str(RECORDINGS[0])!r}, '-o', "
        f"{str(tmp_path / 'ds')!r}]))\n"
    )
    env = {**os.environ, "PYTHONPATH": str(ROOT / "python")}
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.strip().splitlines() == [
        "lfd export: error: the LeRobot export needs lerobot (lerobot is missing): "
        "pip install 'lfd[lerobot]' && pip install --no-deps lerobot==0.4.4"
    ]
    assert list(tmp_path.iterdir()) == []


@needs_lerobot
def test_tracking_gap_marked_invalid_and_values_finite(tmp_path: Path) -> None:
    """A 1.5 s hand gap: ``observation.valid`` False there, values interpolated, so lerobot's
    normalisation statistics stay finite."""
    from lfd.export import LeRobotWriter, prepare_episode

    demo = lfd.load(RECORDINGS[0])
    t = (demo.hand.t_ns - demo.hand.t_ns[0]) * 1e-9
    gap = (t > 5.0) & (t < 6.5)
    demo.hand.keypoints[gap] = np.nan
    demo.hand.confidence[gap] = 0.0
    demo.hand.visible[gap] = False
    ep = prepare_episode(demo, name="gap")
    traj = lfd.preprocess(demo, **lfd.Method.default().preprocessing)
    assert (ep.valid[:, 0] == traj.hand_valid).all() and not ep.valid[:, 0].all()
    writer = LeRobotWriter(tmp_path / "ds", "lfd/gap")
    writer.add(ep)
    writer.close()
    ds = LeRobotDataset("lfd/gap", root=tmp_path / "ds", video_backend="pyav")
    for key in ("observation.state", "observation.hand_keypoints", "action"):
        assert np.isfinite(ds.meta.stats[key]["mean"]).all(), key
    inside = int(np.flatnonzero(~traj.hand_valid)[0])
    item = ds[inside]
    assert not bool(item["observation.valid"][0]) and bool(item["observation.valid"][1])
    assert np.isfinite(item["observation.state"].numpy()).all()
    q = item["observation.state"].numpy()[3:7]
    assert abs(np.linalg.norm(q) - 1.0) < 1e-5
    # tracked frames keep the trajectory's values
    ok = np.flatnonzero(traj.hand_valid)[::25]
    table = ds.hf_dataset.with_format("numpy")[:]
    np.testing.assert_allclose(
        np.stack(table["observation.state"])[ok, :3], traj.tcp[ok], rtol=1e-6, atol=1e-7
    )


def test_atomic_directory_keeps_the_old_one_on_failure(tmp_path: Path) -> None:
    from lfd.outputs import atomic_directory

    dest = tmp_path / "ds"
    dest.mkdir()
    (dest / "old.txt").write_text("old")
    with pytest.raises(KeyboardInterrupt), atomic_directory(dest) as new:
        new.mkdir()
        (new / "half.txt").write_text("half")
        raise KeyboardInterrupt
    assert [p.name for p in tmp_path.iterdir()] == ["ds"]
    assert [p.name for p in dest.iterdir()] == ["old.txt"]
    with atomic_directory(dest) as new:
        new.mkdir()
        (new / "new.txt").write_text("new")
        assert not (dest / "new.txt").exists()  # nothing under the name until the end
    assert [p.name for p in tmp_path.iterdir()] == ["ds"]
    assert [p.name for p in dest.iterdir()] == ["new.txt"]


@needs_lerobot
def test_parallel_preparation_writes_the_same_dataset(exported: Path, tmp_path: Path) -> None:
    """``--jobs 2``: the recordings are read and labelled in two worker processes, the episodes
    written in input order; a broken file among them is skipped at its place."""
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(b"\x00\xff not an mcap file")
    out = tmp_path / "demos"
    report = export_lerobot([RECORDINGS[0], bad, RECORDINGS[1]], out, jobs=2)
    errors = [r.error for r in report.results]
    assert errors[0] is None and errors[2] is None and errors[1] and "bad.mcap" in errors[1]
    assert [r.episode_index for r in report.exported] == [0, 1]
    one = LeRobotDataset("lfd/demos", root=exported, video_backend="pyav")
    two = LeRobotDataset("lfd/demos", root=out, video_backend="pyav")
    a, b = one.hf_dataset.with_format("numpy")[:], two.hf_dataset.with_format("numpy")[:]
    for key in ("observation.state", "observation.objects", "skill_index", "subtask_index"):
        np.testing.assert_array_equal(a[key], b[key])


def test_an_interrupt_inside_an_engine_call_is_not_a_failed_recording(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Ctrl+C inside a binding call (the engine's panic that carries the KeyboardInterrupt, as
    rust-numpy's lazy import gave once in 31 runs) propagates out of the per-recording
    handlers (the export's, the batch runner's) instead of skipping the recording as bad."""
    from lfd import _hmmseg
    from lfd.batch import run_batch
    from lfd.export import LeRobotWriter, export_recording, prepare_episode

    def interrupted(*args: Any, **kwargs: Any) -> Any:
        _hmmseg._panic("Failed to access NumPy array API capsule: KeyboardInterrupt")

    monkeypatch.setattr("lfd.preprocessing.preprocess", interrupted)
    writer = LeRobotWriter(tmp_path / "ds", "lfd/ds")  # lerobot is imported at the first add
    with pytest.raises(KeyboardInterrupt):
        export_recording(writer, RECORDINGS[0], video=False)
    with pytest.raises(KeyboardInterrupt):
        run_batch(prepare_episode, [str(RECORDINGS[0])], jobs=1)
    assert writer.episodes == [] and not (tmp_path / "ds").exists()


@needs_lerobot
@pytest.mark.slow  # lerobot's import and a first episode: about 10 s
def test_ctrl_c_stops_a_running_export_with_130(tmp_path: Path) -> None:
    """SIGINT to a running ``lfd export lerobot`` once it has written an episode: exit 130, one
    line, no dataset and no temporary directory left."""
    import signal
    import time

    out = tmp_path / "ds"
    argv = ["export", "lerobot", *map(str, RECORDINGS * 3), "-o", str(out), "--no-video"]
    proc = subprocess.Popen(
        [sys.executable, "-m", "lfd.cli", *argv, "--jobs", "1"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=ctrl_c_as_from_a_terminal,
    )
    assert proc.stdout is not None
    first = proc.stdout.readline()  # "<recording>: episode 0, ..." once one is written
    assert "episode 0" in first, proc.communicate()[1]
    time.sleep(0.5)  # into the next recording's preparation
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert err.strip().splitlines()[-1] == "lfd export: interrupted"
    assert "Traceback" not in err
    assert not out.exists() and not list(tmp_path.glob(".ds*"))


@needs_lerobot
def test_two_hand_recording_has_a_subtask_column_per_hand(tmp_path: Path) -> None:
    """A two-hand recording (exp1 given a left hand with labels of its own, lfd's writer):
    the unsuffixed columns are the right hand's, ``*.right`` and ``*.left`` each hand's lane,
    frame by frame; a one-hand recording beside it is refused (other columns)."""
    from _two_hands import save_two_hands

    rec = tmp_path / "two.mcap"
    demo = save_two_hands(rec)
    out = tmp_path / "two"
    report = export_lerobot([rec, RECORDINGS[1]], out)
    assert report.results[0].error is None
    assert "hand" in (report.results[1].error or "")  # one-hand beside two: another dataset
    ds = LeRobotDataset("lfd/two", root=out, video_backend="pyav")
    assert ds.num_episodes == 1
    table = ds.hf_dataset.with_format("numpy")[:]
    names = json.loads((out / "meta" / "lfd_program.json").read_text())["episodes"][0]["objects"]
    t = lfd.preprocess(demo, **lfd.Method.default().preprocessing).t_ns
    subtasks = ds.meta.subtasks.index
    for side in ("right", "left"):
        lane = demo.labels_of(side)
        for i in range(0, len(t), 5):
            gt = _gt_at(lane, int(t[i]))
            want = NO_SKILL if gt is None else f"{gt.skill} {gt.object}" if gt.object else gt.skill
            assert subtasks[int(table[f"subtask_index.{side}"][i])] == want
            assert int(table[f"skill_index.{side}"][i]) == (SKILLS.index(gt.skill) if gt else -1)
            obj = int(table[f"object_index.{side}"][i])
            assert (names[obj] if obj >= 0 else None) == (gt.object if gt else None)
    np.testing.assert_array_equal(table["subtask_index"], table["subtask_index.right"])
    assert (table["skill_index.left"] != table["skill_index.right"]).any()
    # each hand's pose: the right's is the unsuffixed one; the left hand (the right one moved
    # 0.3 m along x, 7 ms later) is its own, preprocessed on its own and sampled at the frames
    for key in ("observation.state", "observation.hand_keypoints", "action"):
        np.testing.assert_array_equal(table[key], table[f"{key}.right"])
    right, left = table["observation.state.right"], table["observation.state.left"]
    ok = table["observation.valid.left"].reshape(-1) & table["observation.valid.right"].reshape(-1)
    assert ok.mean() > 0.9
    shift = left[ok, :3] - right[ok, :3]
    np.testing.assert_allclose(np.median(shift, axis=0), [0.3, 0.0, 0.0], atol=0.005)
    assert not np.allclose(table["action.left"], table["action.right"])


@needs_lerobot
def test_two_hand_segment_labels_are_segment_hands(tmp_path: Path) -> None:
    """--labels segment of a two-hand recording: each hand's column is its lane of
    lfd.segment_hands."""
    from _two_hands import save_two_hands

    rec = tmp_path / "two.mcap"
    demo = save_two_hands(rec)
    out = tmp_path / "seg2"
    report = export_lerobot([rec], out, labels="segment")
    assert report.results[0].error is None and report.results[0].labels == "segment"
    both = lfd.segment_hands(lfd.load(rec))
    ds = LeRobotDataset("lfd/seg2", root=out, video_backend="pyav")
    table = ds.hf_dataset.with_format("numpy")[:]
    t = lfd.preprocess(demo, **lfd.Method.default().preprocessing).t_ns
    for side in ("right", "left"):
        labels = [s.to_label() for s in both.lanes[side].segments]
        got = [int(v) for v in table[f"skill_index.{side}"]]
        want = [SKILLS.index(g.skill) if (g := _gt_at(labels, int(x))) else -1 for x in t]
        assert got == want


def test_an_emptied_images_directory_is_removed_and_a_frame_kept(tmp_path: Path) -> None:
    """lerobot deletes each episode's PNG frames once encoded but keeps
    ``images/<camera>/``: a finished dataset does not keep that empty tree; one holding a
    frame (not lfd's to delete) is kept."""
    from lfd.export.writer import remove_empty_images

    empty = tmp_path / "a" / "images" / "observation.images.table"
    empty.mkdir(parents=True)
    remove_empty_images(tmp_path / "a")
    assert list((tmp_path / "a").iterdir()) == []
    frame = tmp_path / "b" / "images" / "observation.images.table" / "episode-000000"
    frame.mkdir(parents=True)
    (frame / "frame-000000.png").write_bytes(b"png")
    remove_empty_images(tmp_path / "b")
    assert (frame / "frame-000000.png").is_file()
    remove_empty_images(tmp_path / "none")  # no images directory: nothing to do
