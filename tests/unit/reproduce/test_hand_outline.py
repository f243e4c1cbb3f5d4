"""The planner keeps the robot's hand outline (:attr:`lfd.reproduce.arm.Robot.palm_half`, from
:attr:`~lfd.reproduce.arm.Robot.palm_above_tcp` up) clear of the objects, at the gripper's yaw:
the Panda's hand (63 x 208 mm, 27 mm above its TCP) reaches a tall neighbour the open fingers
do not; the KUKA's palm (40 x 130 mm, 70 mm up) does not."""

from __future__ import annotations

import importlib.util
from dataclasses import replace

import numpy as np
import pytest
from lfd.reproduce import reproduce
from lfd.reproduce.arm import Robot
from lfd.reproduce.goals import DemoFrames, grasp_goal, palm_near, pose, wrap_near
from lfd.reproduce.motion import clear, required_height
from lfd.reproduce.program import TaskProgram
from lfd.reproduce.robot import KUKA_LWR4
from lfd.trajectory import Trajectory
from reproduce_synth import synthetic_demo

needs_robosuite = pytest.mark.skipif(
    importlib.util.find_spec("robosuite") is None,
    reason="robosuite not installed (the robots extra: pip install --no-deps robosuite==1.5.2)",
)

PANDA_HAND = replace(
    KUKA_LWR4,
    name="panda_hand",
    max_opening=0.08,
    finger_below_tcp=0.013,
    finger_half_x=0.011,
    hand_radius=0.05,
    palm_above_tcp=0.027,
    palm_half=(0.032, 0.104),
)
"""The KUKA with the Panda's hand (lfd.reproduce.panda's numbers; test_robots checks them
against robosuite's mesh): no robosuite needed."""
TALL = np.array([0.04, 0.04, 0.08])


def _frames(robot: Robot) -> DemoFrames:
    """A demonstration's frames whose box_2 is the tall box."""
    traj, _ = synthetic_demo("pick_place")
    frames = DemoFrames(traj, np.array([-0.4, 0.0, 0.0]), robot)
    frames.size = frames.size.copy()
    frames.size[frames.object_index("box_2")] = TALL
    return frames


def test_palm_near_turns_with_the_yaw() -> None:
    T = pose(np.array([0.0, 0.09, 0.04]), 0.0)  # 9 cm beside the TCP along y
    half = (0.032, 0.104)
    along_y, along_x = np.pi / 2, 0.0  # the closing axis (the hand's long side)
    assert palm_near(np.zeros((1, 2)), np.array([along_y]), half, T, TALL)[0]
    assert not palm_near(np.zeros((1, 2)), np.array([along_x]), half, T, TALL)[0]
    # the room is along the axes: 10 mm
    far = np.array([[0.0, 0.09 - 0.02 - 0.104 - 0.011]])
    assert not palm_near(far, np.array([along_y]), half, T, TALL)[0]
    assert palm_near(far + np.array([0.0, 0.002]), np.array([along_y]), half, T, TALL)[0]


@pytest.mark.parametrize("robot", [PANDA_HAND, KUKA_LWR4], ids=lambda r: r.name)
def test_a_pass_beside_a_tall_box_keeps_the_hand_clear(robot: Robot) -> None:
    """A move 9 cm beside an 8 cm tall box, 5 cm above the table: the open fingers pass it (their
    reach is 5 cm), the Panda's hand does not when its long side points at the box (yaw along
    the closing axis), and does turned across; the KUKA's palm passes above at any yaw."""
    frames = _frames(robot)
    objects = {"box_2": pose(np.array([0.1, 0.09, 0.04]), 0.0)}
    for yaw in (np.pi / 2, 0.0):
        a, b = np.array([0.0, 0.0, 0.05, yaw]), np.array([0.2, 0.0, 0.05, yaw])
        ok = clear(a, b, frames, objects, skip=())
        assert ok == (robot is KUKA_LWR4 or yaw == 0.0), (robot.name, yaw)
        need = required_height(
            np.array([[0.1, 0.0]]), frames, objects, skip=(), below=0.013, extra=0.05, yaw=[yaw]
        )[0]
        # the top plus 1 cm, less how far the hand is above the TCP; nothing where it is clear
        if yaw == 0.0:
            assert need == -np.inf
        else:
            assert need == pytest.approx(0.08 + 0.01 - robot.palm_above_tcp)
    # above the hand's reach the pass is clear whatever the yaw
    up = np.array([0.0, 0.0, 0.0631, np.pi / 2])
    assert clear(up, up + np.array([0.2, 0.0, 0.0, 0.0]), frames, objects, skip=())


@pytest.mark.parametrize("robot", [PANDA_HAND, KUKA_LWR4], ids=lambda r: r.name)
def test_grasp_turns_the_hand_away_from_a_tall_neighbour(robot: Robot) -> None:
    """A 4 cm cube 9 cm from an 8 cm tall box, grasped as demonstrated with the closing axis
    towards the box: the open fingers have room either way, the KUKA keeps the demonstrated
    yaw; the Panda's hand (104 mm along the closing axis, 47 mm above the table) would hit the
    tall box, so the Panda closes across the other face."""
    cube = np.array([0.04, 0.04, 0.04])
    T = pose(np.array([0.0, 0.0, 0.02]), 0.0)
    neighbour = [(pose(np.array([0.09, 0.0, 0.04]), 0.0), TALL)]
    p, yaw = grasp_goal(T, cube, 0.0, neighbour, robot=robot)
    assert np.allclose(p[:2], 0.0)
    turned = abs(float(wrap_near(yaw, 0.0))) == pytest.approx(np.pi / 2)
    assert turned == (robot is PANDA_HAND)


def _tall_push() -> tuple[Trajectory, TaskProgram]:
    """The synthetic push (8 cm along x) of a 4 x 4 x 7 cm box."""
    traj, program = synthetic_demo("push")
    size = traj.object_size.copy()
    pos = traj.object_position.copy()
    size[0], pos[0, :, 2] = TALL_PUSHED, TALL_PUSHED[2] / 2
    return replace(traj, object_size=size, object_position=pos), program


TALL_PUSHED = np.array([0.04, 0.04, 0.07])


@pytest.mark.parametrize("robot", [PANDA_HAND, KUKA_LWR4], ids=lambda r: r.name)
def test_a_push_the_hand_would_press_on_grasps_the_box(robot: Robot) -> None:
    """Pushing a 7 cm box, the Panda's hand (27 mm above the TCP, 21 mm ahead of the fingers)
    would press on its top edge: it grasps the box instead (fingers open on the way down,
    closed while it moves, opened after) and moves it 3 mm above the table to the same pushed
    pose; the KUKA's palm (70 mm up) is clear, it pushes with closed fingers."""
    from lfd.reproduce.displacement import plan_layout
    from lfd.reproduce.motion import SLIDE_LIFT

    traj, program = _tall_push()
    _, _, res = plan_layout(traj, program, "skills", {}, robot=robot)
    plan = res.plan
    push = np.flatnonzero(plan.segment == 1)
    opening = plan.opening[push]
    assert res.expected["box_1"][0, 3] == pytest.approx(0.10 + 0.08, abs=0.005)
    if robot is KUKA_LWR4:
        assert np.all(opening == 0.0)
        return
    assert opening[0] == pytest.approx(0.04 + 0.03) and opening[-1] == 0.0
    moving = push[opening == 0.0]
    z = plan.position[moving, 2]
    assert z.min() >= z[0] - 1e-9 and z.max() == pytest.approx(z[0] + SLIDE_LIFT)
    assert z[0] + robot.palm_above_tcp >= TALL_PUSHED[2]  # the hand above the top
    after = plan.opening[push[-1] + 1 : push[-1] + 5]
    assert np.all(after > 0.04)  # released


@needs_robosuite
@pytest.mark.slow  # the Panda in physics (~10 s)
def test_panda_moves_a_tall_box_it_cannot_push() -> None:
    traj, program = _tall_push()
    r = reproduce(traj, program, "skills", robot="panda")
    ex = r.execution
    assert ex is not None
    moved = ex.final_position[0, 0] - ex.object_position[0, 0, 0]
    assert moved == pytest.approx(0.08, abs=0.005)
    assert r.success, r.failures
