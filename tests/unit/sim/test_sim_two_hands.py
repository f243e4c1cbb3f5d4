"""The two-hand demonstrator: per-hand ground truth that covers the take and follows the
grammar, handovers that agree with both lanes, objects held only by a hand at them, the left
hand rendered as the mirrored right one, and both hands perceived from a depth image."""

from __future__ import annotations

import itertools
import os

import numpy as np
import pytest

pytest.importorskip("mujoco")
pytest.importorskip("cv2")
os.environ.setdefault("MUJOCO_GL", "egl")

from lfd.geometry import box_distance
from lfd.sim import BIMANUAL_TASKS, TASK_NAMES, Variability, check_grammar, simulate
from lfd.sim.sampling import yaw_quat

HOLDING = ("move_with", "place", "stack")
CASES = [(task, style) for task in BIMANUAL_TASKS for style in ("careful", "natural")]


@pytest.fixture(scope="module")
def results() -> dict[tuple[str, str], object]:
    return {(t, s): simulate(t, seed=11, variability=Variability(style=s)) for t, s in CASES}


def test_two_hand_tasks_are_tasks() -> None:
    assert set(BIMANUAL_TASKS) <= set(TASK_NAMES)
    assert BIMANUAL_TASKS == ("handover", "carry", "hold_stack", "hold_push")


@pytest.mark.parametrize(("task", "style"), CASES)
def test_each_lane_covers_the_take_and_follows_the_grammar(results, task, style) -> None:  # type: ignore[no-untyped-def]
    result = results[(task, style)]
    demo, truth = result.demo, result.truth
    assert demo.sides == ("right", "left")
    assert demo.other_hand is not None and demo.other_hand.side == "left"
    demo.check_hands()  # every label names one of the two hands
    for side in demo.sides:
        lane = demo.labels_of(side)
        assert all(lab.hand == side for lab in lane)
        assert lane[0].start_ns == truth.t_ns[0] and lane[-1].end_ns == truth.t_ns[-1]
        for a, b in itertools.pairwise(lane):
            assert a.end_ns == b.start_ns and a.start_ns < a.end_ns
        check_grammar([lab.skill for lab in lane])
        assert len(demo.hands[side]) > 10


@pytest.mark.parametrize(("task", "style"), CASES)
def test_handovers_agree_with_both_lanes(results, task, style) -> None:  # type: ignore[no-untyped-def]
    demo = results[(task, style)].demo
    assert len(demo.handovers) == (1 if task == "handover" else 0)
    for h in demo.handovers:
        taker = demo.labels_of(h.taker)
        giver = demo.labels_of(h.giver)
        k = next(i for i, lab in enumerate(taker) if lab.end_ns == h.start_ns)
        assert (taker[k].skill, taker[k].object) == ("pick_up", h.object)
        assert (taker[k + 1].skill, taker[k + 1].object) == ("move_with", h.object)
        g = next(i for i, lab in enumerate(giver) if lab.skill == "place")
        assert (giver[g].start_ns, giver[g].end_ns, giver[g].object) == (
            h.start_ns,
            h.end_ns,
            h.object,
        )
        assert giver[g - 1].skill == "move_with" and giver[g - 1].end_ns == h.start_ns
        assert giver[g + 1].skill == "move"
        assert 0 < h.end_ns - h.start_ns < 1_500_000_000


def _at(truth, name: str) -> tuple[np.ndarray, np.ndarray]:  # type: ignore[no-untyped-def]
    return truth.object_pos[name], yaw_quat(truth.object_yaw[name])


@pytest.mark.parametrize(("task", "style"), CASES)
def test_an_object_is_held_only_by_a_hand_at_it(results, task, style) -> None:  # type: ignore[no-untyped-def]
    """While a lane carries an object a fingertip of its hand is at the object (within 1.5 cm
    of its box), and it puts down only what it touches; an object moves only while a lane holds
    (or pushes) it."""
    result = results[(task, style)]
    demo, truth = result.demo, result.truth
    sizes = {o.name: np.asarray(o.size) for o in result.scene.objects}
    tips = {"right": truth.keypoints, "left": truth.other.keypoints}
    t = truth.t_ns
    busy = {name: np.zeros(t.size, bool) for name in sizes}
    for lab in demo.labels:
        sel = (t >= lab.start_ns) & (t <= lab.end_ns)
        if lab.skill in (*HOLDING, "pick_up", "push") and lab.object:
            busy[lab.object] |= sel
        if lab.skill in HOLDING:
            pos, quat = _at(truth, lab.object)
            kp = tips[lab.hand][sel][:, [4, 8, 12, 16, 20]]  # the fingertips
            d = np.min(
                [
                    box_distance(kp[:, k], pos[sel], quat[sel], sizes[lab.object])
                    for k in range(kp.shape[1])
                ],
                axis=0,
            )
            # carried: at it all along; put down: at it until the fingers open
            assert (d.max() if lab.skill == "move_with" else d.min()) < 0.015, (lab, d.max())
    for name, pos in truth.object_pos.items():
        step = np.linalg.norm(np.diff(pos, axis=0), axis=1)
        moving = np.concatenate([[False], step > 2e-4])
        assert not np.any(moving & ~busy[name]), name


def test_two_handed_carry_and_holding_still(results) -> None:  # type: ignore[no-untyped-def]
    for style in ("careful", "natural"):
        demo = results[("carry", style)].demo
        for side in demo.sides:
            lane = [(lab.skill, lab.object) for lab in demo.labels_of(side)]
            assert lane == [
                ("move", "big_box"),
                ("pick_up", "big_box"),
                ("move_with", "big_box"),
                ("place", "big_box"),
                ("move", None),
            ]
        a, b = (demo.labels_of(s)[1] for s in demo.sides)
        assert a.end_ns != b.end_ns  # each hand grasps at its own time
        for task in ("hold_stack", "hold_push"):
            result = results[(task, style)]
            roles = result.demo.metadata["roles"]
            hold = next(
                lab for lab in result.demo.labels_of(roles["holder"]) if lab.skill == "move_with"
            )
            assert hold.object == roles["held"]
            t = result.truth.t_ns
            sel = (t >= hold.start_ns) & (t <= hold.end_ns)
            pos = result.truth.object_pos[roles["held"]][sel]
            assert np.ptp(pos, axis=0).max() < 0.004  # held still (up to the hand's tremor)
            acted = [lab for lab in result.demo.labels_of(roles["actor"]) if lab.skill != "move"]
            assert acted[-1].object == roles["other"]
            assert hold.start_ns < acted[-1].end_ns < hold.end_ns  # hold until the other is done


def test_two_hand_simulation_is_reproducible() -> None:
    a = simulate("handover", seed=4, variability=Variability(style="natural")).demo
    b = simulate("handover", seed=4, variability=Variability(style="natural")).demo
    np.testing.assert_array_equal(a.other_hand.keypoints, b.other_hand.keypoints)
    assert a.labels == b.labels and a.handovers == b.handovers
    c = simulate("handover", seed=5, variability=Variability(style="natural")).demo
    assert c.labels != a.labels


def test_left_hand_renders_as_the_mirrored_right_one() -> None:
    import mujoco
    from lfd.sim.hand import (
        JOINT_NAMES,
        POSTURES,
        HandKinematics,
        MirroredKinematics,
        hand_mjcf,
    )

    xml = f"<mujoco><worldbody>{hand_mjcf(1.0)}{hand_mjcf(1.0, 'left')}</worldbody></mujoco>"
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    kin = MirroredKinematics(model)
    q = POSTURES["pinch"] + np.random.default_rng(0).normal(0.0, 0.2, len(JOINT_NAMES))
    data.qpos[[model.jnt_qposadr[model.joint("left_" + n).id] for n in JOINT_NAMES]] = q
    mujoco.mj_kinematics(model, data)
    left = np.array([data.site(f"left_kp_{i}").xpos for i in range(21)])
    np.testing.assert_allclose(left, kin.local_keypoints(q), atol=1e-9)
    right = HandKinematics(model).local_keypoints(q)
    np.testing.assert_allclose(left[:, 1], -right[:, 1], atol=1e-9)
    assert np.abs(right[:, 1]).max() > 0.02  # a real mirror, not a symmetric hand


def test_both_hands_found_in_a_rendered_depth_image() -> None:
    pytest.importorskip("torch")
    from lfd.perception.hand.infer import HandEstimator
    from lfd.perception.hand.sides import DepthHands
    from lfd.sim.render import render_frames

    result = simulate("handover", seed=2)
    truth, demo = result.truth, result.demo
    i = int(np.searchsorted(truth.t_ns, demo.handovers[0].start_ns))
    _, depth = render_frames(result.scene, truth, np.array([i]))
    assert depth is not None
    boxes = []
    for o in result.scene.objects:
        c, s = np.cos(truth.object_yaw[o.name][i]), np.sin(truth.object_yaw[o.name][i])
        R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        boxes.append((truth.object_pos[o.name][i], R, np.asarray(o.size)))
    hands = DepthHands(HandEstimator(threads=1))
    for side, true in (("right", truth), ("left", truth.other)):
        found = hands.side(side).estimate_with_spread(
            depth.frames[0], demo.camera.K, demo.camera.world_T_camera, boxes
        )
        assert found is not None, side
        err = np.linalg.norm(found[0] - true.keypoints[i], axis=1).mean()
        assert err < 0.015, (side, err)


def test_lfd_simulate_writes_a_two_hand_recording(tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    from lfd.cli import main
    from lfd.io import load

    out = tmp_path / "handover.mcap"
    assert main(["simulate", "handover", "--seed", "3", "--style", "natural", "-o", str(out)]) == 0
    assert "1 handovers" in capsys.readouterr().out
    demo = load(out)
    sim = simulate("handover", seed=3, variability=Variability(style="natural")).demo
    assert demo.sides == ("right", "left")
    assert demo.handovers == sim.handovers
    for side in demo.sides:
        assert [(x.skill, x.object) for x in demo.labels_of(side)] == [
            (x.skill, x.object) for x in sim.labels_of(side)
        ]
        np.testing.assert_allclose(demo.hands[side].keypoints, sim.hands[side].keypoints)


def test_the_hands_set() -> None:
    from pathlib import Path

    from lfd.sim.sets import EVAL_SEEDS, set_jobs

    jobs = set_jobs("hands", Path("out"))
    assert len(jobs) == len(BIMANUAL_TASKS) * len(EVAL_SEEDS)
    assert {j["task"] for j in jobs} == set(BIMANUAL_TASKS)
