"""The change-point + contact-rule baseline (``lfd eval --methods changepoint``)."""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys

import _paths
import numpy as np
import pytest
from lfd.errors import UsageError
from lfd.io import load
from lfd.segmentation import changepoint_segmentation
from lfd.segmentation.changepoint import FINGERTIPS
from lfd.segmentation.evaluate import DEFAULT_METHODS, METHODS, run_method
from lfd.segmentation.metrics import frame_accuracy
from lfd.segmentation.pipeline import as_trajectory

ROOT = _paths.ROOT
EXP1 = ROOT / "recordings" / "exp1.mcap"
EXP2 = ROOT / "recordings" / "exp2.mcap"


def test_exp1_cycles_found_and_mostly_right() -> None:
    demo = load(EXP1)
    seg = changepoint_segmentation(demo)
    assert seg.method == "changepoint"
    assert frame_accuracy(seg.segments, demo.labels) >= 0.7
    seq = seg.skill_sequence
    i = seq.index("pick_up")
    assert seq[i : i + 3] == ["pick_up", "move_with", "place"]
    assert "stack" in seq
    # the segments tile the recording and name real objects for the object skills
    assert all(a.end == b.start for a, b in zip(seg.segments, seg.segments[1:], strict=False))
    assert all(s.object in seg.object_names for s in seg.segments if s.skill != "move")


def test_exp2_pushes_are_pushes() -> None:
    demo = load(EXP2)
    seg = changepoint_segmentation(demo)
    truth = [(label.skill, label.object) for label in demo.labels if label.skill == "push"]
    assert [(s.skill, s.object) for s in seg.segments if s.skill == "push"] == truth


def test_thumb_middle_grasp_is_seen() -> None:
    """A grasp with the thumb and middle finger (index held away) is still a pick up."""
    demo = load(EXP1)
    traj = as_trajectory(demo)
    kp = traj.keypoints.copy()
    kp[:, 8] += np.array([0.0, 0.0, 0.12])  # index tip far up, 12 cm from the thumb
    moved = dataclasses.replace(traj, keypoints=kp)
    a = changepoint_segmentation(traj)
    b = changepoint_segmentation(moved)
    assert 8 in FINGERTIPS and 12 in FINGERTIPS
    assert a.skill_sequence.count("pick_up") == b.skill_sequence.count("pick_up") == 2


@pytest.mark.parametrize("penalty", [0, -1.0, float("nan"), float("inf"), "1"])
def test_bad_penalty_is_a_usage_error(penalty: object) -> None:
    with pytest.raises(UsageError, match="penalty"):
        changepoint_segmentation(load(EXP1), penalty=penalty)  # type: ignore[arg-type]


def test_penalty_coarsens() -> None:
    traj = as_trajectory(load(EXP1))
    fine = changepoint_segmentation(traj, penalty=0.1)
    coarse = changepoint_segmentation(traj, penalty=50.0)
    assert len(coarse) < len(fine)


def test_in_eval_methods() -> None:
    assert "changepoint" in METHODS
    assert DEFAULT_METHODS[:3] == ("dp", "paper", "changepoint")
    assert run_method("changepoint", load(EXP1)).method == "changepoint"


def test_cli_eval_prints_a_changepoint_row() -> None:
    proc = subprocess.run(
        [sys.executable, "-m", "lfd.cli", "eval", str(EXP1), "--methods", "changepoint"],
        capture_output=True,
        text=True,
        check=False,
        cwd=ROOT,
        env={**os.environ, "COLUMNS": "200"},
    )
    assert proc.returncode == 0, proc.stderr
    rows = [line for line in proc.stdout.splitlines() if "changepoint" in line]
    assert len(rows) == 2  # the exp1 table and the overall table
    assert "(1 recordings)" in proc.stdout
