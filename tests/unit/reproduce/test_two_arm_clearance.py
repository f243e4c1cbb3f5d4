"""The two arms kept apart at a hold (lfd.reproduce.two_arm_clearance): the arms' kinematic
distance (lfd.reproduce.two_arm_distance) and the holder waiting while the other arm fetches
across it."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

pytest.importorskip("mujoco")
pytest.importorskip("mink")
pytestmark = pytest.mark.skipif(
    importlib.util.find_spec("gym_aloha") is None,
    reason="gym-aloha is not installed (pip install --no-deps gym-aloha==0.1.5)",
)


def _still(p: np.ndarray, n: int):  # type: ignore[no-untyped-def]
    from lfd.reproduce.controller import Plan

    return Plan(np.repeat(p[None], n, 0), np.zeros(n), np.zeros(n), np.zeros(n, dtype=int))


def test_arm_distances_are_negative_for_overlapping_grippers_and_capped_far_apart() -> None:
    """Two arms facing each other: their grippers at one point overlap (a negative distance),
    40 cm apart they are beyond the measured 10 cm (FAR); the hold's clearance
    (two_arm_holds.arm_clearance) is the same measurement's least value and its time."""
    from lfd.reproduce.aloha import aloha
    from lfd.reproduce.controller import TICK
    from lfd.reproduce.two_arm_distance import FAR, arm_distances
    from lfd.reproduce.two_arm_holds import EVERY, arm_clearance
    from lfd.reproduce.two_arms import MountedIK, scene_xml

    robot = aloha()
    bases = {"right": np.array([0.35, 0.0, 0.0]), "left": np.array([-0.35, 0.0, 0.0])}
    yaws = {"right": np.pi, "left": 0.0}
    xml = scene_xml(bases, [], robot, yaws)

    def ik(side: str) -> MountedIK:
        return MountedIK(bases[side], yaws[side], robot.ik)

    at = np.array([0.0, 0.0, 0.12])
    meet = {"right": _still(at, 8), "left": _still(at, 8)}
    d = arm_distances(meet, xml, ik, robot, every=EVERY)
    assert d.shape == (4,) and d.max() < 0.0
    least, when = arm_clearance(meet, xml, ik, robot)
    assert least == d.min() and when == int(np.argmin(d)) * EVERY * TICK
    dx = np.array([0.2, 0.0, 0.0])
    apart = {"right": _still(at + dx, 8), "left": _still(at - dx, 8)}
    assert np.all(arm_distances(apart, xml, ik, robot, every=4) == FAR)
    assert arm_clearance(apart, xml, ik, robot) == (FAR, 0.0)


def test_the_least_distance_is_that_of_every_pair_of_the_two_arms_geoms() -> None:
    """The least distance of two_arm_distance (pairs taken nearest bounding spheres first,
    none farther than the least so far) is the least of every pair of the two arms' colliding
    geoms, measured one by one: two Pandas in random poses, near enough to meet."""
    import mujoco
    from lfd.reproduce.panda import two_pandas
    from lfd.reproduce.two_arm_distance import FAR, _geoms, _least
    from lfd.reproduce.two_arms import scene_xml

    robot = two_pandas()
    bases = {"right": np.array([0.3, 0.0, 0.0]), "left": np.array([-0.3, 0.0, 0.0])}
    model = mujoco.MjModel.from_xml_string(
        scene_xml(bases, [], robot, {"right": np.pi, "left": 0.0})
    )
    data = mujoco.MjData(model)
    geoms = _geoms(model, ["right", "left"])
    ga, gb = np.array(geoms["right"]), np.array(geoms["left"])
    rab = model.geom_rbound[ga][:, None] + model.geom_rbound[gb][None, :]
    joints = [j for s in ("right", "left") for j in robot.arms[s].arm_joints]
    rng, fromto, seen = np.random.default_rng(7), np.zeros(6), []
    for _ in range(40):
        for j in joints:
            lo, hi = model.joint(j).range
            data.qpos[model.joint(j).qposadr[0]] = rng.uniform(lo, hi)
        mujoco.mj_kinematics(model, data)
        every = [
            mujoco.mj_geomDistance(model, data, int(a), int(b), FAR, fromto) for a in ga for b in gb
        ]
        seen.append(min(FAR, *every))
        assert _least(model, data, ga, gb, rab, fromto) == pytest.approx(seen[-1], abs=1e-9)
    assert min(seen) < 0.0 < max(seen)  # poses that overlap and poses apart


def test_hold_later_waits_the_holder_until_the_other_arm_is_at_its_step() -> None:
    """The holder's approach (its move to the held object) starts once the other arm's
    synchronised step would start; that step then waits until the holder holds."""
    from lfd.reproduce.controller import Plan
    from lfd.reproduce.program import HandsProgram, Segment, SyncPoint
    from lfd.reproduce.two_arm_clearance import hold_later
    from lfd.reproduce.two_arm_clock import _start
    from lfd.reproduce.two_arms import synchronise

    holder = [
        Segment("move", 0, 1, "plank"),
        Segment("pick_up", 1, 2, "plank"),
        Segment("move_with", 2, 6, "plank"),
        Segment("place", 6, 7, "plank"),
    ]
    other = [
        Segment("move", 0, 2, "box"),
        Segment("pick_up", 2, 3, "box"),
        Segment("move_with", 3, 4, "box"),
        Segment("stack", 4, 5, "box"),
    ]
    p = SyncPoint("hold_until", "left", 2, "right", 3, "plank", 5.0)
    hands = HandsProgram({"right": other, "left": holder}, [p])

    def plan(steps: list[int]) -> Plan:
        seg = np.concatenate([np.full(n, k) for k, n in enumerate(steps)])
        n = len(seg)
        return Plan(np.linspace([0, 0, 0.1], [0.1, 0, 0.1], n), np.zeros(n), np.zeros(n), seg)

    plans = {"left": plan([100, 100, 400, 100]), "right": plan([200, 100, 100, 100])}
    out = hold_later(plans, hands, p, synchronise)
    a, b = out["left"], out["right"]
    assert _start(a, 0) == _start(plans["right"], 3) == 400  # waited at its start
    assert np.all(a.position[:400] == plans["left"].position[0])
    assert _start(b, 3) >= _start(a, 2)  # the stack once the holder holds
    assert _start(a, 3) >= _start(b, 4)  # and the holder keeps holding until it is done


def test_a_hold_stack_whose_hands_cross_is_achieved_without_the_arms_touching() -> None:
    """hold_stack seed 304 (careful): the left hand fetches a box right of the plank the right
    hand holds; the arms that follow the hands met at 1.6 s. The holder now waits until the
    box is fetched: achieved, no collision, the arms kept apart."""
    from lfd.reproduce.aloha import aloha
    from lfd.reproduce.two_arm_clearance import CLEARANCE, EVERY
    from lfd.reproduce.two_arm_distance import arm_distances
    from lfd.reproduce.two_arms import MountedIK, plan_two_arms, run_two_arm_plan, scene_xml

    from tests.unit.reproduce.test_two_arm_carry import _program

    trajs, hands = _program("hold_stack", 304)
    robot = aloha()
    plan = plan_two_arms(trajs, hands, "skills", robot=robot)
    xml = scene_xml(plan.bases, [], robot, plan.yaws)

    def ik(side: str) -> MountedIK:
        return MountedIK(plan.bases[side], plan.yaws[side], robot.ik)

    assert arm_distances(plan.plans, xml, ik, robot, every=EVERY).min() >= CLEARANCE
    r = run_two_arm_plan(plan, robot)
    assert r.success and not r.collisions, r.failures


def test_a_grasp_asked_along_an_axis_closes_along_it_when_it_fits() -> None:
    """grasp_goal's ``close_along``: a cube closed along its y axis when asked (along x by
    default, the person's yaw 0); a 60 x 40 mm box along its 60 mm side (up to the 61 mm the
    gripper takes), a 65 mm side asked is not taken."""
    from lfd.reproduce.aloha import aloha
    from lfd.reproduce.goals import grasp_goal

    arm = aloha().ik
    T = np.eye(4)
    T[2, 3] = 0.025
    cube = np.array([0.05, 0.05, 0.05])

    def axis(yaw: float) -> int:
        return 0 if abs(np.cos(yaw)) > abs(np.sin(yaw)) else 1

    assert axis(grasp_goal(T, cube, 0.0, robot=arm)[1]) == 0
    assert axis(grasp_goal(T, cube, 0.0, robot=arm, close_along=1)[1]) == 1
    box = np.array([0.06, 0.04, 0.04])
    assert axis(grasp_goal(T, box, 0.0, robot=arm)[1]) == 1  # across its narrow side
    assert axis(grasp_goal(T, box, 0.0, robot=arm, close_along=0)[1]) == 0
    wide = np.array([0.065, 0.04, 0.04])
    assert axis(grasp_goal(T, wide, 0.0, robot=arm, close_along=0)[1]) == 1


def test_a_stack_beside_a_press_closes_across_the_line_to_the_press() -> None:
    """The box stacked 10 cm left of where the other arm presses (along x): its gripper
    closes along y (its bar not reaching towards the press), on a box turned by 90 deg along
    the box's x."""
    from types import SimpleNamespace

    from lfd.reproduce.controller import Plan
    from lfd.reproduce.program import Segment, SyncPoint, TaskProgram
    from lfd.reproduce.two_arm_clearance import stack_across

    seg = np.array([0, 0, 1, 2, 2, 2, 3])
    n = len(seg)
    press = Plan(np.tile([0.1, 0.0, 0.05], (n, 1)), np.zeros(n), np.zeros(n), seg)
    point = SyncPoint("hold_until", "right", 2, "left", 3, "plank", 5.0)
    stack = TaskProgram([Segment("pick_up", 0, 1, "box"), Segment("stack", 1, 2, "box")])
    for turn, want in ((0.0, 1), (np.pi / 2, 0)):
        T = np.eye(4)
        T[:2, :2] = [[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]]
        planned = {
            "right": (None, None, SimpleNamespace(plan=press)),
            "left": (None, None, SimpleNamespace(program=stack, expected={"box": T})),
        }
        assert stack_across(planned, {"right": point}) == {"left": {"box": want}}


def test_a_stack_beside_a_press_is_asked_at_the_objects_end_away_from_the_press() -> None:
    """stack_away: the box stacked 10 cm left of the press (along x) is taken at its -x end
    (in its own frame: at its -y end when the box is turned by 90 deg), and grasp_goal
    moves the grasp there only as far as the fingers stay on the box, across the closing
    axis (along it the grasp stays centred)."""
    from types import SimpleNamespace

    from lfd.reproduce.controller import Plan
    from lfd.reproduce.goals import GRASP_EDGE, grasp_goal
    from lfd.reproduce.panda import panda
    from lfd.reproduce.program import Segment, SyncPoint, TaskProgram
    from lfd.reproduce.two_arm_clearance import stack_away

    seg = np.array([0, 0, 1, 2, 2, 2, 3])
    n = len(seg)
    press = Plan(np.tile([0.1, 0.0, 0.05], (n, 1)), np.zeros(n), np.zeros(n), seg)
    point = SyncPoint("hold_until", "right", 2, "left", 3, "plank", 5.0)
    stack = TaskProgram([Segment("pick_up", 0, 1, "box"), Segment("stack", 1, 2, "box")])
    arm, box = panda(), np.array([0.066, 0.066, 0.066])
    for turn in (0.0, np.pi / 2):
        T = np.eye(4)
        T[:2, :2] = [[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]]
        planned = {
            "right": (None, None, SimpleNamespace(plan=press)),
            "left": (None, None, SimpleNamespace(program=stack, expected={"box": T})),
        }
        at = stack_away(planned, {"right": point})["left"]["box"]
        assert T[:2, :2] @ at / np.linalg.norm(at) == pytest.approx([-1.0, 0.0], abs=1e-9)
        p, _ = grasp_goal(T, box, np.pi / 2, demo_offset=at, robot=arm)  # closing along y
        free = box[0] / 2 - arm.finger_half_x - GRASP_EDGE
        assert p[:2] == pytest.approx([-free, 0.0], abs=1e-9)
    planned["right"] = (None, None, SimpleNamespace(plan=replace_segments(press, 9)))
    assert stack_away(planned, {"right": point}) == {}  # no press step planned: nothing asked


def replace_segments(plan, k):  # type: ignore[no-untyped-def]
    """``plan`` with every tick in step ``k``."""
    from dataclasses import replace

    return replace(plan, segment=np.full(len(plan), k))


def test_a_hold_stack_stacking_beside_the_press_is_achieved() -> None:
    """hold_stack seed 308 (careful): box_2 (60 x 40 mm) is stacked 10 cm from the press; the
    stacking gripper closed along the plank (across the 40 mm side), its wrist touched the
    pressing gripper at 7.1 s. Now it closes across the line to the press: achieved."""
    from lfd.reproduce.aloha import aloha
    from lfd.reproduce.two_arms import reproduce_two_arms

    from tests.unit.reproduce.test_two_arm_carry import _program

    trajs, hands = _program("hold_stack", 308)
    r = reproduce_two_arms(trajs, hands, "skills", robot=aloha())
    assert r.success and not r.collisions, r.failures
