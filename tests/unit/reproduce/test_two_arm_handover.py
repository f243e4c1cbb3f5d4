"""A handover on two arms (lfd.reproduce.two_arm_handover): the two grasps on the bar kept a
gripper's width apart, each arm's towards its base, the taker arriving above its grasp; on a
simulated natural-style handover whose two hands held the bar 4 cm apart (seed 306: before,
the taker's gripper touched the giver's wrist)."""

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


def _plan(seed: int, mode: str = "skills"):  # type: ignore[no-untyped-def]
    from lfd.preprocessing import preprocess
    from lfd.reproduce import PREPROCESSING, from_hand_labels
    from lfd.reproduce.aloha import aloha
    from lfd.reproduce.two_arms import plan_two_arms
    from lfd.sim import Variability, simulate

    demo = simulate("handover", seed=seed, variability=Variability(style="natural")).demo
    hands = from_hand_labels(
        demo.labels, demo.start_ns, sides=demo.sides, handovers=demo.handovers, objects=demo.objects
    )
    trajs = {s: preprocess(demo.one_hand(s), **PREPROCESSING) for s in demo.sides}
    robot = aloha()
    (point,) = [p for p in hands.sync if p.kind == "handover"]
    return plan_two_arms(trajs, hands, mode, robot=robot), point, robot


def _along(T: np.ndarray, p: np.ndarray) -> float:
    return float((T[:3, :3].T @ (np.asarray(p) - T[:3, 3]))[0])  # the bar lies along its x


@pytest.mark.slow
def test_the_two_grasps_of_a_handover_are_a_gripper_apart_and_it_runs() -> None:
    from lfd.reproduce.two_arm_handover import HANDOVER_GAP, SLACK
    from lfd.reproduce.two_arms import _end, run_two_arm_plan

    plan, p, robot = _plan(306)
    giver, taker = p.hand, p.other
    frames = plan.planned[giver][0]
    assert frames.size[frames.object_index("bar")][0] > 0.1  # a bar, along its x
    # the hands held it 4 cm apart at the handover
    t_frames = plan.planned[taker][0]
    i, j = frames.index(p.t_s), t_frames.index(p.t_s)
    T_demo = frames.object_pose("bar", i)
    demo_gap = abs(
        _along(T_demo, frames.tcp_pose(i)[:3, 3]) - _along(T_demo, t_frames.tcp_pose(j)[:3, 3])
    )
    assert demo_gap < 0.06
    # the grippers hold it HANDOVER_GAP apart, the taker's end towards its base
    T = plan.planned[giver][2].expected["bar"]  # where the giver puts it down
    g_plan, t_plan = plan.plans[giver], plan.plans[taker]
    a_g = _along(T, g_plan.position[_end(g_plan, p.step) - 1])
    grasp = t_plan.position[_end(t_plan, p.other_step) - 1]
    a_t = _along(T, grasp)
    towards = float((plan.bases[taker][:2] - plan.bases[giver][:2]) @ T[:2, 0])
    assert np.sign(a_t - a_g) == np.sign(towards)
    assert abs(a_t - a_g) >= HANDOVER_GAP - SLACK
    # the taker arrives above its grasp and comes down onto it
    above = t_plan.position[_end(t_plan, p.other_step - 1) - 1]
    assert np.linalg.norm(above[:2] - grasp[:2]) < 0.01 and above[2] > grasp[2] + 0.01
    r = run_two_arm_plan(plan, robot)
    assert r.success and not r.collisions, r.failures
