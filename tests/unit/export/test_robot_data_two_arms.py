"""``lfd export robot-data TWOHAND.mcap --robot aloha``: robot episodes of a simulated two-hand
demonstration on the two-arm ALOHA over randomised layouts, loaded back offline with lerobot,
the 14-dim action (both arms' joints and grippers, the left's first) the simulation's commands,
each arm's skill columns and both arms' subtask; a recording that does not fit the robot is
refused in one line with nothing written (library and command)."""

from __future__ import annotations

import dataclasses
import importlib.util
import json
import os
import shutil
from pathlib import Path
from typing import Any

import lfd
import numpy as np
import pytest
from _paths import EXP1
from lfd.errors import UsageError
from lfd.export.robot_data import LAYOUTS_PATH, LayoutResult, export_robot_data, work_dir
from lfd.skills import SKILLS

pytest.importorskip("mujoco")
needs_aloha = pytest.mark.skipif(
    importlib.util.find_spec("gym_aloha") is None,
    reason="gym-aloha is not installed (pip install --no-deps gym-aloha==0.1.5)",
)
needs_lerobot = pytest.mark.skipif(
    importlib.util.find_spec("lerobot") is None, reason="lerobot not installed (the lerobot extra)"
)
TASK, SEED, LAYOUTS = "hold_push", 9501, 2
JOINTS = ("waist", "shoulder", "elbow", "forearm_roll", "wrist_angle", "wrist_rotate")


@pytest.fixture(autouse=True)
def _offline(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """lerobot must touch neither the network nor the user's Hugging Face cache."""
    monkeypatch.setenv("HF_HUB_OFFLINE", "1")
    monkeypatch.setenv("HF_HOME", str(tmp_path / "hf"))


def _simulated_demo() -> Any:
    from lfd.sim import Variability, simulate

    return simulate(TASK, seed=SEED, variability=Variability(style="careful")).demo


@pytest.fixture(scope="module")
def exported(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[LayoutResult]]:
    root = tmp_path_factory.mktemp("two_arms")
    rec = root / f"{TASK}.mcap"
    lfd.save(_simulated_demo(), rec)
    os.environ.setdefault("HF_HUB_OFFLINE", "1")
    seen: list[LayoutResult] = []
    out = root / "ds"
    report = export_robot_data(
        rec, out, layouts=LAYOUTS, robot="aloha", progress=lambda r, n: seen.append(r)
    )
    assert [r.index for r in report.layouts] == list(range(LAYOUTS))
    assert not work_dir(out).exists()
    return out, seen


def _rerun(layout: int) -> tuple[Any, Any]:
    """Layout ``layout`` of seed 0 drawn and run again through the public API, as the export
    drew and ran it."""
    from lfd.preprocessing import preprocess
    from lfd.reproduce import PREPROCESSING, from_hand_labels
    from lfd.reproduce.aloha import aloha
    from lfd.reproduce.two_arms import reproduce_two_arms
    from lfd.reproduce.two_arms_randomise import iter_two_arm_layouts

    demo = _simulated_demo()
    hands = from_hand_labels(
        demo.labels, demo.start_ns, sides=demo.sides, handovers=demo.handovers, objects=demo.objects
    )
    trajs = {s: preprocess(demo.one_hand(s), **PREPROCESSING) for s in demo.sides}
    draws = iter_two_arm_layouts(trajs, hands, layout + 1, modes=("skills",), robot=aloha())
    lay = list(draws)[layout]
    return lay, reproduce_two_arms(trajs, hands, "skills", robot=aloha(), displace=lay.displace)


@pytest.mark.slow  # plans, simulates, renders and encodes two layouts, then one again (~30 s)
@needs_aloha
@needs_lerobot
def test_loads_back_with_both_arms_commands_and_skills(
    exported: tuple[Path, list[LayoutResult]],
) -> None:
    import mujoco
    import pandas as pd
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    root, seen = exported
    ds = LeRobotDataset("lfd/ds", root=root, video_backend="pyav")
    doc = json.loads((root / LAYOUTS_PATH).read_text())
    assert ds.num_episodes == doc["succeeded"] == len(doc["episodes"]) >= 1
    assert doc["settings"]["robot"] == "aloha" and ds.meta.robot_type == "lfd_aloha"
    names = [f"{side}_{j}" for side in ("left", "right") for j in (*JOINTS, "gripper")]
    assert ds.features["action"]["names"] == names
    assert ds.features["observation.state"]["shape"] == (14,)
    for key in ("skill_index", "object_index", "subtask_index"):
        assert {f"{key}.left", f"{key}.right"} <= set(ds.features)
    assert "observation.images.table" in ds.meta.video_keys
    assert [r.index for r in seen] == list(range(LAYOUTS))
    table = {k: np.asarray(v) for k, v in ds.hf_dataset.with_format("numpy")[:].items()}
    first = doc["episodes"][0]
    lay, run = _rerun(first)
    assert doc["layouts"][first]["displace"] == {
        k: [float(x) for x in v] for k, v in lay.displace.items()
    }
    assert run.success
    ex = run.executions["right"]
    model = mujoco.MjModel.from_xml_string(ex.scene)
    rows = np.flatnonzero(table["episode_index"] == 0)
    ticks = 10 * table["frame_index"][rows]
    assert len(rows) == len(range(0, ex.ctrl.shape[0], 10))

    def act(side: str, name: str) -> np.ndarray:
        return ex.ctrl[ticks, model.actuator(f"{side}/act_{name}").id]

    want = np.stack(
        [
            col
            for side in ("left", "right")
            for col in (
                *(act(side, j) for j in JOINTS),
                act(side, "left_finger") + act(side, "right_finger"),
            )
        ],
        1,
    )
    np.testing.assert_allclose(table["action"][rows], want, rtol=0, atol=1e-6)
    wrist = model.joint("right/wrist_angle").qposadr[0]
    np.testing.assert_allclose(
        table["observation.state"][rows][:, 11], ex.qpos[ticks, wrist], atol=1e-6
    )
    for half in (slice(0, 6), slice(7, 13)):  # both arms move
        assert np.abs(np.diff(table["action"][rows][:, half], axis=0)).max() > 0.01
    # each arm's skill at a frame: its plan's segment at that tick (a dwell: the one before)
    subtasks = pd.read_parquet(root / "meta" / "subtasks.parquet").index.tolist()
    for side in ("left", "right"):
        seg = list(run.plans[side].segment) + [-1] * (ex.ctrl.shape[0] - len(run.plans[side]))
        for t in range(len(seg)):
            seg[t] = seg[t] if seg[t] >= 0 else (seg[t - 1] if t else 0)
        segs = run.programs[side].segments
        want_skill = [SKILLS.index(segs[seg[t]].skill) for t in ticks]
        assert table[f"skill_index.{side}"][rows].tolist() == want_skill
        got = [subtasks[i] for i in table[f"subtask_index.{side}"][rows]]
        assert got == [f"{segs[seg[t]].skill} {segs[seg[t]].object or ''}".strip() for t in ticks]
    both = [subtasks[i] for i in table["subtask_index"][rows]]
    right = [subtasks[i] for i in table["subtask_index.right"][rows]]
    left = [subtasks[i] for i in table["subtask_index.left"][rows]]
    assert both == [f"right: {r} | left: {lft}" for r, lft in zip(right, left, strict=True)]
    assert len(set(both)) >= 4
    assert ds.meta.tasks.index[0].startswith(f"{TASK}: right: ")


@pytest.mark.slow  # runs the two layouts again, interrupted after the first (~15 s)
@needs_aloha
@needs_lerobot
def test_interrupted_two_arm_export_resumes_to_the_same_dataset(
    exported: tuple[Path, list[LayoutResult]], tmp_path: Path
) -> None:
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    once, _ = exported
    rec = once.parent / f"{TASK}.mcap"
    out = tmp_path / "ds"

    def stop(r: LayoutResult, n: int) -> None:
        raise KeyboardInterrupt  # Ctrl+C once the first layout is finished

    with pytest.raises(KeyboardInterrupt):
        export_robot_data(rec, out, layouts=LAYOUTS, robot="aloha", progress=stop)
    assert not out.exists()
    seen: list[LayoutResult] = []
    export_robot_data(
        rec, out, layouts=LAYOUTS, robot="aloha", progress=lambda r, n: seen.append(r)
    )
    assert [(r.index, r.resumed) for r in seen] == [(0, True), (1, False)]

    def table(root: Path) -> dict[str, np.ndarray]:
        ds = LeRobotDataset(f"lfd/{root.name}", root=root, video_backend="pyav")
        return {k: np.asarray(v) for k, v in ds.hf_dataset.with_format("numpy")[:].items()}

    a, b = table(once), table(out)
    assert a.keys() == b.keys()
    for key in a:
        np.testing.assert_array_equal(a[key], b[key], err_msg=key)


def _refused(call: Any, tmp_path: Path, message: str) -> None:
    before = sorted(p.name for p in tmp_path.iterdir())
    with pytest.raises(UsageError, match=message) as err:
        call()
    assert "\n" not in str(err.value)
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # nothing written


@needs_aloha
def test_recordings_that_do_not_fit_the_robot_are_refused(tmp_path: Path) -> None:
    from _two_hand_tasks import idle_left

    two = tmp_path / "two.mcap"
    lfd.save(_simulated_demo(), two)
    idle = tmp_path / "idle.mcap"  # a left hand with no label: the right hand's task
    demo = idle_left(lfd.load(EXP1, images=False))
    lfd.save(dataclasses.replace(demo, labels=[x for x in demo.labels if x.hand == "right"]), idle)
    out = tmp_path / "ds"
    _refused(lambda: export_robot_data(two, out, layouts=2), tmp_path, "two-hand demonstration")
    _refused(
        lambda: export_robot_data(EXP1, out, layouts=2, robot="aloha"),
        tmp_path,
        "one-hand demonstration .* aloha has two arms",
    )
    _refused(lambda: export_robot_data(two, out, layouts=2, robot="ur9"), tmp_path, "known robots")
    _refused(
        lambda: export_robot_data(two, out, layouts=2, robot="aloha", labels="segment"),
        tmp_path,
        "ground-truth labels",
    )
    _refused(
        lambda: export_robot_data(idle, out, layouts=2, robot="aloha"),
        tmp_path,
        "only the right hand has steps",
    )


def _lfd(capsys: pytest.CaptureFixture[str], *argv: Any) -> tuple[int, str]:
    from lfd.cli import main

    try:
        status = main([str(a) for a in argv])
    except SystemExit as stop:
        status = stop.code  # type: ignore[assignment]
    return int(status or 0), capsys.readouterr().err


@needs_aloha
def test_command_refuses_in_one_line_with_nothing_written(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    two = tmp_path / "two.mcap"
    lfd.save(_simulated_demo(), two)
    one = tmp_path / "exp1.mcap"
    shutil.copyfile(EXP1, one)
    out = tmp_path / "ds"
    for argv, expected in [
        ((two, "--robot", "kuka_lwr4"), "two-hand demonstration"),
        ((one, "--robot", "aloha"), "has two arms"),
        ((two, "--robot", "ur9"), "known robots"),
        ((two, "--robot", "aloha", "--labels", "segment"), "ground-truth labels"),
    ]:
        status, err = _lfd(capsys, "export", "robot-data", *argv, "-o", out, "--layouts", 2)
        lines = [line for line in err.splitlines() if line.strip()]
        assert status == 2 and len(lines) == 1 and "Traceback" not in err, err
        assert lines[0].startswith("lfd export") and expected in lines[0], lines[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["exp1.mcap", "two.mcap"]


def test_two_arm_episode_saves_and_loads_its_columns(tmp_path: Path) -> None:
    """A finished layout's episode (kept in the work directory until the dataset is written)
    loads back with each arm's columns and both arms' subtask, as features by name."""
    from lfd.export.robot_episode import RobotEpisode

    n = 3
    sides = {"left": ["move", "push box_1", "push box_1"], "right": ["pick_up box_3"] * n}
    ep = RobotEpisode(
        fps=10,
        task="t",
        joint_names=[f"{s}_{j}" for s in sides for j in (*JOINTS, "gripper")],
        object_names=["box_1", "box_3"],
        state=np.arange(n * 14, dtype=np.float32).reshape(n, 14),
        action=np.ones((n, 14), np.float32),
        environment=np.zeros((n, 14), np.float32),
        images=np.zeros((n, 16, 16, 3), np.uint8),
        labels={f"skill_index.{s}": np.arange(n, dtype=np.int64) for s in sides},
        subtasks={
            **{f"subtask_index.{s}": names for s, names in sides.items()},
            "subtask_index": [
                f"right: {r} | left: {lft}"
                for r, lft in zip(sides["right"], sides["left"], strict=True)
            ],
        },
        segment=np.array([0, 1, 1]),
        ticks=np.arange(n) * 10,
    )
    ep.save(tmp_path / "ep.npz")
    again = RobotEpisode.load(tmp_path / "ep.npz")
    assert again.subtasks == ep.subtasks and again.joint_names == ep.joint_names
    for key in ep.labels:
        np.testing.assert_array_equal(again.labels[key], ep.labels[key])
    np.testing.assert_array_equal(again.state, ep.state)
    assert again.subtask[0] == "right: pick_up box_3 | left: move"
    feats = again.features("table")
    assert feats["action"]["shape"] == (14,)
    assert {"skill_index.left", "subtask_index.right", "subtask_index"} <= set(feats)
    assert again.annotation()["subtask_names"] == [
        "right: pick_up box_3 | left: move",
        "right: pick_up box_3 | left: push box_1",
    ]
