"""``lfd export robot-data``: robot episodes from one human demonstration (exp1) over randomised
layouts, written as a LeRobot dataset that loads back offline with lerobot, with the simulation's
commanded joints as the actions and the program's skill of every frame as the subtask;
an interrupted export, run again, gives the same dataset as one run."""

from __future__ import annotations

import importlib.util
import json
import os
from pathlib import Path
from typing import Any

import _paths
import lfd
import numpy as np
import pytest
from _far import far_recording
from lfd.errors import UsageError
from lfd.export.robot_data import LAYOUTS_PATH, LayoutResult, export_robot_data, work_dir
from lfd.skills import SKILLS

EXP1 = _paths.ROOT / "recordings" / "exp1.mcap"
LAYOUTS = 2

needs_lerobot = pytest.mark.skipif(
    importlib.util.find_spec("lerobot") is None, reason="lerobot not installed (the lerobot extra)"
)


@pytest.fixture(autouse=True)
def _offline(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """lerobot must touch neither the network nor the user's Hugging Face cache."""
    monkeypatch.setenv("HF_HUB_OFFLINE", "1")
    monkeypatch.setenv("HF_HOME", str(tmp_path / "hf"))


@pytest.fixture(scope="module")
def exported(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[LayoutResult]]:
    out = tmp_path_factory.mktemp("robot") / "exp1"
    os.environ.setdefault("HF_HUB_OFFLINE", "1")
    seen: list[LayoutResult] = []
    report = export_robot_data(EXP1, out, layouts=LAYOUTS, progress=lambda r, n: seen.append(r))
    assert [r.index for r in report.layouts] == list(range(LAYOUTS))
    assert not work_dir(out).exists()  # the work directory goes once the dataset is written
    return out, seen


def _table(root: Path) -> dict[str, np.ndarray]:
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset(f"lfd/{root.name}", root=root, video_backend="pyav")
    return {k: np.asarray(v) for k, v in ds.hf_dataset.with_format("numpy")[:].items()}


def _simulated(layout: int) -> Any:
    """Layout ``layout`` of seed 0 reproduced again through the public API, as the export
    drew and ran it."""
    from lfd.reproduce import PREPROCESSING, from_labels, random_layouts, reproduce

    demo = lfd.load(EXP1, images=False)
    traj = lfd.preprocess(demo, **PREPROCESSING)
    program = from_labels(demo.labels, int(traj.t_ns[0]))
    lay = random_layouts(traj, program, layout + 1, seed=0, modes=("skills",))[layout]
    return lay, reproduce(traj, program, "skills", displace=lay.displace)


@pytest.mark.slow  # simulates, renders and encodes two runs (~30 s), then one again
@needs_lerobot
def test_loads_back_with_the_simulated_commands_and_skills(
    exported: tuple[Path, list[LayoutResult]],
) -> None:
    import pandas as pd

    root, _ = exported
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset("lfd/exp1", root=root, video_backend="pyav")
    doc = json.loads((root / LAYOUTS_PATH).read_text())
    assert ds.num_episodes == doc["succeeded"] == len(doc["episodes"]) >= 1
    assert ds.fps == 10 and "observation.images.table" in ds.meta.video_keys
    table = _table(root)
    first = doc["episodes"][0]
    lay, run = _simulated(first)
    assert doc["layouts"][first]["displace"] == {
        k: [float(x) for x in v] for k, v in lay.displace.items()
    }
    ex = run.execution
    rows = np.flatnonzero(table["episode_index"] == 0)
    ticks = 10 * table["frame_index"][rows]
    assert len(rows) == len(range(0, ex.ctrl.shape[0], 10))
    # the action of a frame: the 7 joint set points and the two fingers' (half openings)
    # commanded at that tick, as the simulation recorded them
    want = np.concatenate([ex.ctrl[ticks, :7], ex.ctrl[ticks, 7:9].sum(1, keepdims=True)], 1)
    np.testing.assert_allclose(table["action"][rows], want, rtol=0, atol=1e-6)
    state = np.concatenate([ex.qpos[ticks, :7], ex.qpos[ticks, 7:9].sum(1, keepdims=True)], 1)
    np.testing.assert_allclose(table["observation.state"][rows], state, rtol=0, atol=1e-6)
    assert np.abs(np.diff(table["action"][rows][:, :7], axis=0)).max() > 0.01  # it moves
    # the subtask of a frame: the program's skill at that tick
    names = pd.read_parquet(root / "meta" / "subtasks.parquet").index.tolist()
    segs = run.program.segments
    # every tick in a skill: a dwell (-1: the gripper closing or opening) in the one before it
    seg = [run.segment[t] for t in range(len(run.segment))]
    for t in range(len(seg)):
        seg[t] = seg[t] if seg[t] >= 0 else (seg[t - 1] if t else 0)
    seg = [seg[t] for t in ticks]
    assert (run.segment[ticks] < 0).any()  # the plan has dwell ticks at some frames
    want_sub = [f"{segs[s].skill} {segs[s].object or ''}".strip() for s in seg]
    assert [names[i] for i in table["subtask_index"][rows]] == want_sub
    want_skill = [SKILLS.index(segs[s].skill) for s in seg]
    assert table["skill_index"][rows].tolist() == want_skill
    assert len(set(want_skill)) >= 4  # pick_up, move_with, place, move, stack
    assert ds.meta.tasks.index[0].startswith("exp1: pick_up box_")


@pytest.mark.slow  # decodes the video written above
@needs_lerobot
def test_video_has_one_image_per_frame(exported: tuple[Path, list[LayoutResult]]) -> None:
    import av

    root, _ = exported
    files = sorted((root / "videos").rglob("*.mp4"))
    assert files
    with av.open(str(files[0])) as c:
        frames = [f.to_ndarray(format="rgb24") for f in c.decode(video=0)]
    assert len(frames) == len(_table(root)["index"])
    assert frames[0].shape == (120, 160, 3)
    assert np.abs(frames[-1].astype(float) - frames[0].astype(float)).mean() > 0.5  # moved


@pytest.mark.slow
@needs_lerobot
def test_yield_file_lists_every_tried_layout(exported: tuple[Path, list[LayoutResult]]) -> None:
    root, seen = exported
    doc = json.loads((root / LAYOUTS_PATH).read_text())
    assert [r["index"] for r in doc["layouts"]] == list(range(LAYOUTS))
    assert doc["tried"] == LAYOUTS
    assert doc["succeeded"] == sum(r["success"] for r in doc["layouts"])
    assert doc["yield"] == doc["succeeded"] / LAYOUTS
    assert doc["episodes"] == [r["index"] for r in doc["layouts"] if r["success"]]
    for r in doc["layouts"]:
        assert r["success"] or r["failures"]  # a failed layout says why
        assert set(r["displace"]) == {"box_1", "box_2", "box_3"}
    assert [r.index for r in seen] == list(range(LAYOUTS))
    assert not any(r.resumed for r in seen)


@pytest.mark.slow  # runs the two layouts again, interrupted after the first
@needs_lerobot
def test_interrupted_export_resumes_to_the_same_dataset(
    exported: tuple[Path, list[LayoutResult]], tmp_path: Path
) -> None:
    once, _ = exported
    out = tmp_path / "exp1"

    def stop(r: LayoutResult, n: int) -> None:
        raise KeyboardInterrupt  # Ctrl+C once the first layout is finished

    with pytest.raises(KeyboardInterrupt):
        export_robot_data(EXP1, out, layouts=LAYOUTS, progress=stop)
    assert not out.exists()  # no dataset yet: it is written at the end
    state = json.loads((work_dir(out) / "state.json").read_text())
    assert [r["index"] for r in state["layouts"]] == [0]
    with pytest.raises(UsageError, match="other settings"):  # another seed: refused
        export_robot_data(EXP1, out, layouts=LAYOUTS, seed=1)
    seen: list[LayoutResult] = []
    export_robot_data(EXP1, out, layouts=LAYOUTS, progress=lambda r, n: seen.append(r))
    assert [(r.index, r.resumed) for r in seen] == [(0, True), (1, False)]
    assert not work_dir(out).exists()
    a, b = _table(once), _table(out)
    assert a.keys() == b.keys()
    for key in a:
        np.testing.assert_array_equal(a[key], b[key], err_msg=key)

    def layouts(root: Path) -> list[dict[str, Any]]:
        doc = json.loads((root / LAYOUTS_PATH).read_text())
        return [{k: v for k, v in r.items() if k != "seconds"} for r in doc["layouts"]]

    assert layouts(once) == layouts(out)


def test_bad_settings_are_refused_before_anything_is_written(tmp_path: Path) -> None:
    out = tmp_path / "ds"
    for kwargs, message in [
        ({"layouts": 0}, "--layouts 0"),
        ({"layouts": 2, "fps": 7}, "--fps 7"),
        ({"layouts": 2, "mode": "replay"}, "--mode replay"),
        ({"layouts": 2, "image_size": (8, 8)}, "--image-size"),
    ]:
        with pytest.raises(UsageError, match=message):
            export_robot_data(EXP1, out, **kwargs)
    with pytest.raises(UsageError, match="does not exist"):
        export_robot_data(tmp_path / "missing.mcap", out, layouts=2)
    with pytest.raises(UsageError, match="also an input"):
        export_robot_data(EXP1, EXP1, layouts=2)
    assert sorted(tmp_path.iterdir()) == []


def test_two_hand_recording_is_refused(tmp_path: Path) -> None:
    from _two_hands import save_two_hands

    two = tmp_path / "two.mcap"
    save_two_hands(two)
    with pytest.raises(UsageError, match="two-hand"):
        export_robot_data(two, tmp_path / "ds", layouts=2)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["two.mcap"]


def test_object_out_of_reach_is_refused(tmp_path: Path) -> None:
    rec = far_recording(tmp_path / "far.mcap")
    with pytest.raises(UsageError, match="out of the arm's reach") as refused:
        export_robot_data(rec, tmp_path / "ds", layouts=2)
    # named where the demonstration shows it, not as a --displace nobody gave
    assert "where the demonstration shows it" in str(refused.value), refused.value
    assert "--displace" not in str(refused.value) and "displacement" not in str(refused.value)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["far.mcap"]


def _tiny_episode(path: Path) -> None:
    from lfd.export.robot_episode import RobotEpisode

    n = 2
    RobotEpisode(
        fps=10,
        task="t",
        joint_names=["j1"],
        object_names=["box_1"],
        state=np.zeros((n, 1), np.float32),
        action=np.zeros((n, 1), np.float32),
        environment=np.zeros((n, 7), np.float32),
        images=np.zeros((n, 16, 16, 3), np.uint8),
        labels={"skill_index": np.zeros(n, np.int64)},
        subtasks={"subtask_index": ["move"] * n},
        segment=np.zeros(n, np.int64),
        ticks=np.arange(n) * 10,
    ).save(path)


def _state(layouts: list[dict[str, Any]]) -> str:
    """A ``state.json`` with the settings of ``export robot-data EXP1 --layouts 2``."""
    from lfd.export.robot_data import STATE_FORMAT
    from lfd.reproduce import MAX_SHIFT, MAX_TURN_DEG

    settings = {
        "recording": str(EXP1.resolve()),
        "recording_bytes": EXP1.stat().st_size,
        "seed": 0,
        "mode": "skills",
        "labels": "ground-truth",
        "fps": 10,
        "image_size": [160, 120],
        "max_shift_m": MAX_SHIFT,
        "max_turn_deg": MAX_TURN_DEG,
        "robot": "kuka_lwr4",
    }
    return json.dumps({"format": STATE_FORMAT, "settings": settings, "layouts": layouts})


def _layout(index: int, **changes: Any) -> dict[str, Any]:
    return {
        "index": index,
        "displace": {"box_1": [0.01, 0.0, 5.0]},
        "success": True,
        "failures": [],
        "error": None,
        "frames": 2,
        "seconds": 1.0,
    } | changes


@pytest.mark.parametrize(
    ("state", "episode", "expected"),
    [
        ("{garbage", b"", "state.json is not readable JSON"),
        ("[]", b"", "state.json is not an export state"),
        ('{"format": 2}', b"", "state.json is not an export state"),
        (_state([_layout(0), _layout(1, frames="many")]), b"", "layouts[1] is malformed"),
        (_state([_layout(0), {"index": 1}]), b"", "layouts[1] is malformed"),
        (_state([_layout(0), _layout(1)]), b"PK\x03\x04 cut", "layout_000001.npz: not a readable"),
        (_state([_layout(0), _layout(1)]), os.urandom(5000), "layout_000001.npz: not a readable"),
        (_state([_layout(0), _layout(1)]), b"\x93NUMPY", "layout_000001.npz: not a readable"),
    ],
    ids=["garbage", "list", "no-layouts", "frames-many", "no-keys", "cut-npz", "random-npz", "npy"],
)
def test_a_damaged_resume_state_is_refused_up_front_and_kept(
    state: str,
    episode: bytes,
    expected: str,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """A damaged ``.DIR.robot-data`` (state.json not what an export writes, a finished layout's
    episode unreadable) is one line, exit status 2, naming the directory and saying to remove
    it, before any layout runs (the episodes were read only after every other layout was
    simulated); nothing in it is deleted."""
    from lfd.cli import main

    out = tmp_path / "ds"
    work = work_dir(out)
    work.mkdir()
    (work / "state.json").write_text(state)
    _tiny_episode(work / "layout_000000.npz")
    if episode:
        (work / "layout_000001.npz").write_bytes(episode)
    before = {p.name: p.read_bytes() for p in work.iterdir()}
    status = main(["export", "robot-data", str(EXP1), "-o", str(out), "--layouts", "2"])
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert status == 2 and len(lines) == 1 and "Traceback" not in err, err
    assert f"{work} holds a damaged interrupted export" in lines[0], lines[0]
    assert expected in lines[0] and "remove that directory to start again" in lines[0], lines[0]
    assert {p.name: p.read_bytes() for p in work.iterdir()} == before
    assert sorted(p.name for p in tmp_path.iterdir()) == [work.name]


def test_the_work_directory_is_made_in_missing_parents(tmp_path: Path) -> None:
    """``-o a/b/ds`` where ``a/`` does not exist (allowed, as for ``export lerobot``): the first
    finished layout's work directory is made with its parents (it failed after the first
    layout's simulation, naming the hidden ``a/b/.ds.robot-data``)."""
    from lfd.export.robot_data import _Work

    work = _Work(work_dir(tmp_path / "a" / "b" / "ds"), {"seed": 0})
    work.finish(LayoutResult(0, {"box_1": [0.0, 0.0, 0.0]}, False, ["knocked"], 1.0), None)
    state = json.loads((tmp_path / "a" / "b" / ".ds.robot-data" / "state.json").read_text())
    assert [r["index"] for r in state["layouts"]] == [0]
