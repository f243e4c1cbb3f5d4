"""A robot is a value (:mod:`lfd.reproduce.robots`): the registry, the KUKA LWR 4+ as it was, and
the Franka Panda built from robosuite's MJCF (skipped where robosuite is not installed; CI
installs it)."""

from __future__ import annotations

import importlib.util
import subprocess
import sys

import _paths
import numpy as np
import pytest

pytest.importorskip("mujoco")
pytest.importorskip("mink")

from lfd.errors import MissingExtraError, UsageError
from lfd.reproduce import ROBOTS, reproduce, robot_names
from lfd.reproduce.ik import ArmIK, gripper_rotation, rotation_angle
from lfd.reproduce.robot import KUKA_LWR4
from lfd.reproduce.robots import robot
from lfd.reproduce.timescale import LIMITS

needs_robosuite = pytest.mark.skipif(
    importlib.util.find_spec("robosuite") is None,
    reason="robosuite not installed (the robots extra: pip install --no-deps robosuite==1.5.2)",
)
EXP1 = _paths.RECORDINGS / "exp1.mcap"


def test_registry() -> None:
    assert robot_names()[0] == "kuka_lwr4" and set(robot_names()) == set(ROBOTS)
    assert "panda" in ROBOTS
    assert robot() is robot("kuka_lwr4") is KUKA_LWR4
    with pytest.raises(UsageError, match=r"unknown robot 'ur5'; known robots: kuka_lwr4, panda"):
        robot("ur5")


def _arms() -> list[object]:
    arms: list[object] = ["kuka_lwr4"]
    arms.append(pytest.param("panda", marks=needs_robosuite))
    return arms


@pytest.mark.parametrize("name", _arms())
def test_every_robot_follows_the_conventions(name: str) -> None:
    """What the reproduction relies on (:mod:`lfd.reproduce.robots`): the servos drive the arm
    joints, then the two fingers, within the joint limits; a ``tcp`` site, a ``gripper`` body and
    the base body; the home pose within the limits."""
    import mujoco

    arm = robot(name)
    model = mujoco.MjModel.from_xml_string(arm.model_xml())
    driven = [model.joint(model.actuator(i).trnid[0]).name for i in range(model.nu)]
    assert driven == [*arm.arm_joints, *arm.finger_joints]
    assert model.nq == arm.dof + 2  # nothing else moves
    for i, (lo, hi) in enumerate(arm.joint_range):
        assert model.jnt_range[model.joint(arm.arm_joints[i]).id] == pytest.approx(
            [lo, hi], abs=1e-4
        )
        assert model.actuator_ctrlrange[i] == pytest.approx([lo, hi], abs=1e-4)
        assert lo < arm.home_q[i] < hi
    assert model.site("tcp").id >= 0 and model.body("gripper").id >= 0
    assert model.body("robot_base").id >= 0
    assert arm.reach[0] < arm.reach[1] and arm.max_opening > 0


def test_kuka_limits_are_the_time_scalings_default() -> None:
    assert KUKA_LWR4.limits is LIMITS and robot().limits is LIMITS


@pytest.mark.parametrize("name", _arms())
def test_seed_points_the_closing_axis(name: str) -> None:
    """``seed_towards`` (the robot's ``wrist_yaw``) turns the closing axis to the asked yaw, and
    the IK then reaches top-down poses in front of the base with any yaw."""
    arm = robot(name)
    ik = ArmIK(np.zeros(3), robot=arm)
    for x, y, yaw in [(0.5, 0.0, 0.3), (0.45, -0.25, -1.0), (0.4, 0.3, 2.0)]:
        p, R = np.array([x, y, 0.05]), gripper_rotation(yaw)
        ik.seed_towards(p, R)
        _, R0 = ik.tcp_pose()
        assert abs(np.angle(np.exp(1j * (np.arctan2(R0[1, 1], R0[0, 1]) - yaw)))) < 0.05
        ik.solve(p, R)
        pp, RR = ik.tcp_pose()
        assert np.linalg.norm(pp - p) < 1e-3 and rotation_angle(RR, R) < 0.01


@needs_robosuite
def test_panda_mjcf_tcp_between_the_pads() -> None:
    """robosuite's Panda compiles with position servos on 7 arm joints and two fingers, and the
    ``tcp`` site is midway between the finger pads, its y axis across them, its z axis the
    approach (towards the fingertips), whatever the opening."""
    import mujoco

    arm = robot("panda")
    model = mujoco.MjModel.from_xml_string(arm.model_xml((0.1, -0.2, 0.0)))
    data = mujoco.MjData(model)
    assert (model.nq, model.nu) == (9, 9)
    assert [model.actuator(i).trntype for i in range(9)] == [mujoco.mjtTrn.mjTRN_JOINT] * 9
    assert all(model.actuator(i).gainprm[0] > 0 for i in range(9))  # position servos
    fingers = [model.joint(f).qposadr[0] for f in arm.finger_joints]
    rng = np.random.default_rng(0)
    for _ in range(4):
        lo, hi = np.array(arm.joint_range).T
        data.qpos[:7] = rng.uniform(lo, hi)
        w = rng.uniform(0.0, arm.max_opening / 2)
        data.qpos[fingers] = w
        mujoco.mj_forward(model, data)
        tcp, R = data.site("tcp").xpos, data.site("tcp").xmat.reshape(3, 3)
        pads = [data.geom(g).xpos for g in ("finger1_pad_collision", "finger2_pad_collision")]
        assert np.linalg.norm((pads[0] + pads[1]) / 2 - tcp) < 1e-4
        across = pads[1] - pads[0]
        assert abs(abs(across @ R[:, 1]) - np.linalg.norm(across)) < 1e-4  # along the y axis
        assert np.linalg.norm(across) == pytest.approx(2 * w + 0.007, abs=1e-4)  # pad centres
        hand = data.xpos[model.body("gripper").id]
        assert (tcp - hand) @ R[:, 2] == pytest.approx(0.0934, abs=1e-4)  # z: out of the hand
    assert arm.joint_range[3][1] < 0  # robosuite's limits (joint 4 always bent)
    # the hand's collision mesh in the TCP frame: what the planner keeps clear of the objects
    g = model.geom("hand_collision").id
    mesh = model.geom_dataid[g]
    verts = model.mesh_vert[
        model.mesh_vertadr[mesh] : model.mesh_vertadr[mesh] + model.mesh_vertnum[mesh]
    ]
    local = (verts @ data.geom_xmat[g].reshape(3, 3).T + data.geom_xpos[g] - tcp) @ R
    assert -local[:, 2].max() == pytest.approx(arm.palm_above_tcp, abs=1e-3)  # its underside
    assert arm.palm_half is not None  # its outline from above: across and along the closing axis
    assert np.abs(local[:, 0]).max() == pytest.approx(arm.palm_half[0], abs=1e-3)
    assert np.abs(local[:, 1]).max() == pytest.approx(arm.palm_half[1], abs=1e-3)
    assert arm.hand_radius >= arm.max_opening / 2


@needs_robosuite
def test_panda_missing_robosuite_is_one_line(tmp_path: object) -> None:
    """Without robosuite, ``--robot panda`` says how to install it: one line, exit 2, no file."""
    code = (
        "import sys\nsys.modules['robosuite'] = None\nfrom lfd.cli import main\n"
        f"sys.exit(main(['reproduce', {str(EXP1)!r}, '--robot', 'panda', '--json', 'r.json']))\n"
    )
    proc = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path, timeout=120
    )
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert proc.returncode == 2 and len(lines) == 1, proc.stderr
    assert lines[0] == (
        "lfd reproduce: error: the panda robot needs robosuite's robot models: "
        "pip install --no-deps robosuite==1.5.2"
    )
    assert list(tmp_path.iterdir()) == []  # type: ignore[attr-defined]


def test_library_missing_robosuite(monkeypatch: pytest.MonkeyPatch) -> None:
    from lfd.reproduce.panda import panda

    monkeypatch.setitem(sys.modules, "robosuite", None)
    robot.cache_clear()
    panda.cache_clear()  # built once per prefix
    try:
        with pytest.raises(MissingExtraError, match=r"pip install --no-deps robosuite==1\.5\.2"):
            robot("panda")
    finally:
        robot.cache_clear()
        panda.cache_clear()


@needs_robosuite
@pytest.mark.slow  # a whole demonstration on the Panda (~10 s)
def test_panda_reproduces_exp1() -> None:
    """The shipped exp1 (two picks, a place and a stack) on the Panda with skill knowledge: every
    object where the demonstration left it, the TCP within a centimetre of the plan."""
    from lfd import load, preprocess
    from lfd.reproduce import PREPROCESSING, from_labels

    demo = load(EXP1)
    traj = preprocess(demo, **PREPROCESSING)
    program = from_labels(demo.labels, int(traj.t_ns[0]))
    r = reproduce(traj, program, "skills", robot="panda")
    assert r.robot == "panda" and r.to_json()["robot"] == "panda"
    assert r.success, r.failures
    assert np.linalg.norm(r.executed_tcp - r.planned_tcp, axis=1).max() < 0.01


@pytest.mark.parametrize("name", _arms())
def test_grasp_and_push_keep_the_palm_off_the_top(name: str) -> None:
    """A grasp or push of a 7 cm tall box: the KUKA's palm (70 mm above its TCP) is far above,
    the grasp stays at the box's centre; the Panda's (27 mm) would press on the top, so the grasp
    rises until the palm clears it by 5 mm, and a push rises at most to the centre (higher, the
    tall box toppled)."""
    from lfd.reproduce.goals import PALM_CLEARANCE, grasp_goal, pose, push_goal

    arm = robot(name)
    size = np.array([0.04, 0.04, 0.07])
    T = pose(np.array([0.5, 0.0, 0.035]), 0.0)
    p, _ = grasp_goal(T, size, 0.0, robot=arm)
    palm = p[2] + arm.palm_above_tcp
    assert palm >= 0.07 + PALM_CLEARANCE - 1e-9
    assert p[2] == pytest.approx(max(0.035, 0.07 + PALM_CLEARANCE - arm.palm_above_tcp))
    q, _ = push_goal(T, size, np.array([1.0, 0.0, 0.0]), 0.0, arm)
    assert q[2] <= 0.035 + 1e-9 and q[0] < 0.5 - 0.02 - arm.finger_half_x
