"""A two-hand program on the two-arm ALOHA (lfd.reproduce.aloha, lfd.reproduce.two_arms): the
model from gym-aloha's MJCF, top-down IK per arm, a simulated two-hand demonstration achieved
on both arms, and what is refused in one line."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest
from _two_arm_programs import program

pytest.importorskip("mujoco")
pytest.importorskip("mink")
pytestmark = pytest.mark.skipif(
    importlib.util.find_spec("gym_aloha") is None,
    reason="gym-aloha is not installed (pip install --no-deps gym-aloha==0.1.5)",
)

BASES = {"right": np.array([0.42, 0.2, 0.0]), "left": np.array([-0.46, 0.14, 0.0])}
YAWS = {"right": np.pi, "left": 0.0}


def test_the_model_compiles_with_both_tcp_sites() -> None:
    import mujoco
    from lfd.reproduce.aloha import FINGER_RANGE, aloha
    from lfd.reproduce.two_arms import scene_xml

    robot = aloha()
    assert robot.sides == ("right", "left") and robot.ik.dof == 6
    model = mujoco.MjModel.from_xml_string(scene_xml(BASES, [], robot, YAWS))
    data = mujoco.MjData(model)
    assert model.nu == 16 and model.nq == 16  # 6 joints and 2 fingers per arm
    for side in BASES:
        for j, q in zip(robot.arms[side].arm_joints, robot.ik.home_q, strict=True):
            data.qpos[model.joint(j).qposadr[0]] = q
    mujoco.mj_forward(model, data)
    for side, base in BASES.items():
        tcp = data.site(f"{side}/tcp").xpos
        # the base turned towards the workspace: the home TCP in front of it, above the table
        ahead = np.array([np.cos(YAWS[side]), np.sin(YAWS[side])])
        assert 0.1 < float((tcp[:2] - base[:2]) @ ahead) < 0.4 and tcp[2] > 0.05
        for f in robot.arms[side].finger_joints:
            assert tuple(model.jnt_range[model.joint(f).id]) == pytest.approx((0, FINGER_RANGE))


@pytest.mark.parametrize("side", ["right", "left"])
def test_ik_reaches_top_down_poses_over_the_table(side: str) -> None:
    from lfd.reproduce.aloha import aloha
    from lfd.reproduce.ik import gripper_rotation, rotation_angle
    from lfd.reproduce.two_arms import MountedIK

    ik = MountedIK(BASES[side], YAWS[side], aloha().ik)
    ahead = np.array([np.cos(YAWS[side]), np.sin(YAWS[side]), 0.0])
    across = np.array([-ahead[1], ahead[0], 0.0])
    for dist, off, z in ((0.3, 0.0, 0.03), (0.2, 0.1, 0.02), (0.42, -0.12, 0.05)):
        p = BASES[side] + dist * ahead + off * across + np.array([0.0, 0.0, z])
        for yaw in (0.0, 0.8, -1.3):
            R = gripper_rotation(yaw)
            ik.seed_towards(p, R)
            ik.solve(p, R)
            got, Rg = ik.tcp_pose()
            assert np.linalg.norm(got - p) < 0.003, (side, p, yaw)
            assert np.degrees(rotation_angle(Rg, R)) < 1.0


@pytest.mark.slow
def test_a_simulated_hold_push_is_achieved_on_two_arms() -> None:
    """One hand holds a box still while the other pushes another: both arms in one scene, the
    holder releasing only after the push has ended."""
    from lfd.reproduce.two_arms import _start, reproduce_two_arms

    trajs, hands = program("hold_push", 101)
    (hold,) = [p for p in hands.sync if p.kind == "hold_until"]
    r = reproduce_two_arms(trajs, hands, "skills")
    assert r.success, r.failures
    assert r.failures == []
    assert all(k.ok for ks in r.skills.values() for k in ks)
    assert r.bases["right"][0] > r.bases["left"][0]  # each arm on its hand's side
    holder, other = r.plans[hold.hand], r.plans[hold.other]
    assert _start(holder, hold.step + 1) >= _start(other, hold.other_step + 1)
    assert {r.owners[n] for n in ("box_2", "box_3")} == {"right", "left"}


@pytest.mark.slow
def test_a_simulated_handover_is_achieved_on_two_arms() -> None:
    """The giver brings the bar to the meeting point and lets go only once the taker holds it;
    the taker puts it where the demonstration did."""
    from lfd.reproduce.outcome import _tilt_deg
    from lfd.reproduce.two_arms import _end, _release, reproduce_two_arms

    trajs, hands = program("handover", 4)
    (point,) = [p for p in hands.sync if p.kind == "handover"]
    r = reproduce_two_arms(trajs, hands, "skills")
    assert r.success, r.failures
    assert r.owners[point.object] == point.other  # the taker places it last
    giver, taker = r.plans[point.hand], r.plans[point.other]
    assert _release(giver, point.step) >= _end(taker, point.other_step)
    # the bar stays upright from the handover on (held by the taker as the giver lets go)
    ex = r.executions[point.other]
    j = ex.object_names.index(point.object)
    assert _tilt_deg(ex.object_quaternion[j, _end(taker, point.other_step) :]).max() < 10.0


def test_a_carry_and_a_handover_run_on_two_arms() -> None:
    """A two-handed carry runs (lfd.reproduce.two_arm_carry; what it refuses:
    tests/unit/reproduce/test_two_arm_carry.py), and so does a handover."""
    from lfd.reproduce.two_arms import check_runs

    _, hands = program("carry", 3)
    assert [p.kind for p in hands.sync] == ["carry"]
    check_runs(hands)
    _, hands = program("handover", 3)
    check_runs(hands)  # a handover runs


def _lane(steps: list[tuple[int, int]]):  # type: ignore[no-untyped-def]
    """A plan of ``(segment, ticks)`` runs (-1: a dwell), the TCP moving 1 mm a tick."""
    from lfd.reproduce.controller import Plan

    seg = np.concatenate([np.full(n, k) for k, n in steps])
    pos = np.zeros((len(seg), 3))
    pos[:, 0] = np.arange(len(seg)) * 1e-3
    return Plan(pos, np.zeros(len(seg)), np.full(len(seg), 0.05), seg)


def test_a_handover_on_one_clock() -> None:
    """The taker's move to the meeting point and its pick_up start once the giver's place has
    ended; the giver opens (its dwell) only once the taker has grasped (its closing dwell); the
    taker carries off only once the giver has moved away."""
    from lfd.reproduce.program import HandsProgram, Segment, SyncPoint
    from lfd.reproduce.two_arms import _end, _release, _start, synchronise

    lanes = {
        "right": [Segment("pick_up", 0, 1, "bar"), Segment("move_with", 1, 2, "bar"),
                  Segment("place", 2, 3, "bar"), Segment("move", 3, 4)],
        "left": [Segment("move", 0, 2.5, "bar"), Segment("pick_up", 2.5, 3, "bar"),
                 Segment("move_with", 3, 4, "bar")],
    }  # fmt: skip
    point = SyncPoint("handover", "right", 2, "left", 1, "bar", 3.0)
    hands = HandsProgram(lanes, [point])
    giver = _lane([(0, 100), (-1, 50), (1, 100), (2, 100), (-1, 50), (3, 100)])
    giver.opening[_end(giver, 2) :] = 0.06  # opens after its place
    taker = _lane([(0, 50), (1, 80), (-1, 50), (2, 100)])
    out = synchronise({"right": giver, "left": taker}, hands)
    g, t = out["right"], out["left"]
    assert _start(t, 0) >= _end(g, 2) == 350  # the taker stays away until the giver is there
    assert np.allclose(t.position[:350], taker.position[0])  # holding still meanwhile
    assert _release(g, 2) >= _end(t, 1) + 50  # the giver holds until the taker has grasped
    assert np.all(g.opening[: _release(g, 2)] == 0.05) and g.opening[_release(g, 2)] == 0.06
    assert len(g) - len(giver) == _release(g, 2) - 350 > 0  # the giver's wait: a dwell
    assert np.all(g.segment[350 : _release(g, 2)] == -1)
    assert _start(t, 2) >= _end(g, 3)  # carried off once the giver has moved away


def test_cli_two_hand_program_on_one_arm_refuses_and_aloha_options(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from lfd.cli import main

    rec = tmp_path / "hold_push.mcap"
    assert main(["simulate", "hold_push", "--seed", "7", "--style", "careful", "-o", str(rec)]) == 0
    capsys.readouterr()
    out = tmp_path / "r.json"
    assert main(["reproduce", str(rec), "--robot", "kuka_lwr4", "--json", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "both hands handle objects" in err[0] and "one arm" in err[0]
    assert main(["reproduce", str(rec), "--robot", "aloha", "--hand", "left"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["lfd reproduce: error: --robot aloha cannot be combined with --hand yet"]
    assert not out.exists()
