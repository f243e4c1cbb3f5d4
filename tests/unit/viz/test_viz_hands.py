"""Rerun views of two hands: a skill lane per hand (result and ground truth), both hands in 3-D
(skeletons, TCP paths), the handovers on the timeline and in 3-D; read back from the .rrd."""

from __future__ import annotations

import dataclasses
import warnings
from pathlib import Path

import _paths
import lfd
import numpy as np
import pytest
from _two_hand_tasks import busy_left, handover_labels, idle_left

rr = pytest.importorskip("rerun")

import lfd.viz as viz  # noqa: E402
from _rrd import Rrd  # noqa: E402
from lfd.viz.pipeline import log_recorded_demo, log_result  # noqa: E402


@pytest.fixture(scope="module")
def exp1() -> lfd.Demonstration:
    return lfd.load(_paths.EXP1, images=False)


@pytest.fixture
def session(tmp_path: Path):
    s = viz.open_session("lfd_test", save=tmp_path / "hands.rrd", make_default=False)
    yield s
    s.recording.disconnect()


def _finish(session: viz.Session) -> Rrd:
    assert session.save_path is not None
    session.close()
    return Rrd(session.save_path)


def test_two_hands_lanes_3d_and_handovers(exp1: lfd.Demonstration, session: viz.Session) -> None:
    labels, handovers = handover_labels(exp1.start_ns)
    demo = busy_left(exp1, labels, handovers)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        both = lfd.segment_hands(demo)
    found = lfd.Handover(
        handovers[0].start_ns + 10**8, handovers[0].end_ns, "right", "left", "box_2"
    )
    result = dataclasses.replace(both, handovers=[found])
    rec = session.recording
    log_recorded_demo(demo, trajectory=False, recording=rec)
    log_result(demo, result, ground_truth=False, recording=rec)
    data = _finish(session)
    t0 = demo.start_ns
    for side in ("right", "left"):
        # the hand's skeleton and raw path, every sample, in its own colour
        kp = data.entity(f"/world/hand/{side}/keypoints")
        assert len(kp) == len(demo.hands[side])
        np.testing.assert_allclose(
            np.array(kp[5]["Points3D:positions"]), demo.hands[side].keypoints[5], atol=1e-6
        )
        assert f"/world/hand/{side}/path" in data.static
        # the trajectory that was segmented, per hand
        run = both.lanes[side].run
        assert run is not None
        assert (
            len(data.entity(f"/world/hand/{side}/gripper"))
            == np.isfinite(run.trajectory.tcp).all(1).sum()
        )
        # the hand's lanes: result and ground truth
        states = data.column(f"/segmentation/skills/{side}/result", "StateChange:state")
        want = [s.skill + (f"({s.object})" if s.object else "") for s in both.lanes[side].segments]
        assert [x[0] for x in states if x[0]] == want
        truth = data.column(f"/segmentation/skills/{side}/ground_truth", "StateChange:state")
        want = [
            f"{lab.skill}({lab.object})" if lab.object else lab.skill
            for lab in demo.labels_of(side)
        ]
        assert [x[0] for x in truth if x[0]] == want
    # one-hand paths are not used for two hands
    assert (
        "/world/hand/keypoints" not in data.rows and "/segmentation/skills/result" not in data.rows
    )
    # the handovers: a span from the taker's grasp to the giver's release, and a point in 3-D
    for source, h in (("result", found), ("ground_truth", handovers[0])):
        lane = f"/segmentation/handovers/{source}"
        assert data.column(lane, "StateChange:state") == [["box_2 right→left"], [""]]
        np.testing.assert_array_equal(data.times(lane), [h.start_ns - t0, h.end_ns - t0])
        point = data.static[f"/world/handovers/{source}"]
        box = demo.objects["box_2"]
        i = np.argmin(np.abs(box.t_ns - h.end_ns))
        np.testing.assert_allclose(point["Points3D:positions"][0], box.position[i], atol=1e-6)
        assert point["Points3D:labels"][0].startswith("handover box_2 right→left at")


def test_one_hand_views_unchanged(exp1: lfd.Demonstration, session: viz.Session) -> None:
    """A one-hand demonstration and a one-lane result keep the one-hand paths."""
    rec = session.recording
    log_recorded_demo(exp1, trajectory=False, recording=rec)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        log_result(exp1, lfd.segment_hands(exp1), ground_truth=False, recording=rec)
    data = _finish(session)
    assert "/world/hand/keypoints" in data.rows and "/world/gripper" in data.rows
    assert "/segmentation/skills/result" in data.rows
    assert not [
        p for p in data.rows if p.startswith(("/world/hand/right", "/segmentation/handovers"))
    ]


def test_idle_hand_has_its_lane(exp1: lfd.Demonstration, session: viz.Session) -> None:
    """A two-hand demonstration with a resting left hand: both ground-truth lanes, no handover."""
    log_recorded_demo(idle_left(exp1), trajectory=True, recording=session.recording)
    data = _finish(session)
    assert data.column("/segmentation/skills/left/ground_truth", "StateChange:state") == [
        ["move"],
        [""],
    ]
    assert (
        "/world/hand/left/tcp_path" in data.static and "/world/hand/right/tcp_path" in data.static
    )
    assert not [p for p in data.rows if p.startswith("/segmentation/handovers")]


def test_lfd_segment_rerun_save_of_a_two_hand_file(tmp_path: Path) -> None:
    """``lfd segment two.mcap --rerun-save``: each hand's result and ground-truth lanes, each
    hand's segmented trajectory, the handovers found and the true ones, as lfd.segment_hands
    gives them."""
    from _two_hands import save_two_hands
    from lfd.cli import main

    rec, rrd = tmp_path / "two.mcap", tmp_path / "two.rrd"
    demo = save_two_hands(rec)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main(["segment", str(rec), "--rerun-save", str(rrd)]) == 0
        both = lfd.segment_hands(lfd.load(rec))
    data = Rrd(rrd)
    for side in ("right", "left"):
        states = data.column(f"/segmentation/skills/{side}/result", "StateChange:state")
        want = [s.skill + (f"({s.object})" if s.object else "") for s in both.lanes[side].segments]
        assert [x[0] for x in states if x[0]] == want
        truth = data.column(f"/segmentation/skills/{side}/ground_truth", "StateChange:state")
        assert len([x for x in truth if x[0]]) == len(demo.labels_of(side))
        run = both.lanes[side].run
        assert run is not None
        assert (
            len(data.entity(f"/world/hand/{side}/gripper"))
            == np.isfinite(run.trajectory.tcp).all(1).sum()
        )
    assert data.column("/segmentation/handovers/ground_truth", "StateChange:state")[0] == [
        f"{demo.handovers[0].object} right→left"
    ]
    found = data.rows.get("/segmentation/handovers/result", [])
    assert len([r for r in found if r["StateChange:state"][0]]) == len(both.handovers)
