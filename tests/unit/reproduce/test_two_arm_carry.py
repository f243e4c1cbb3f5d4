"""A two-handed carry on the two-arm ALOHA (lfd.reproduce.two_arm_carry): both grippers press
the object between them, one object path, both arms on one clock; lfd.sim's ``carry``."""

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


def _program(task: str, seed: int, style: str = "careful"):  # type: ignore[no-untyped-def]
    from lfd.preprocessing import preprocess
    from lfd.reproduce import PREPROCESSING, from_hand_labels
    from lfd.sim import Variability, simulate

    demo = simulate(task, seed=seed, variability=Variability(style=style)).demo
    hands = from_hand_labels(
        demo.labels, demo.start_ns, sides=demo.sides, handovers=demo.handovers, objects=demo.objects
    )
    return {s: preprocess(demo.one_hand(s), **PREPROCESSING) for s in demo.sides}, hands


def test_retime_together_keeps_two_plans_on_one_clock_within_both_limits() -> None:
    """Two paths of one length, one too fast for its arm: both slowed by the same phase, so they
    stay tick for tick together, each within its limits; the slow one alone is not slowed."""
    from lfd.reproduce.arm import Limits
    from lfd.reproduce.controller import Plan
    from lfd.reproduce.timescale import TOLERANCE, retime, retime_together, slowdown

    n = 200
    s = 0.5 - 0.5 * np.cos(np.linspace(0, np.pi, n))
    fast = np.zeros((n, 3))
    fast[:, 0] = 0.4 * s  # 0.4 m in 2 s: up to 0.31 m/s
    slow = np.zeros((n, 3))
    slow[:, 1] = 0.05 * s
    plans = [Plan(p, np.zeros(n), np.zeros(n), np.zeros(n, dtype=int)) for p in (fast, slow)]
    lim = Limits(speed=0.15, acceleration=2.0, yaw_rate=2.5, yaw_acceleration=12.0)
    a, b = retime_together(plans, [lim, lim])
    assert len(a) == len(b) > n
    for p in (a, b):
        assert slowdown(p.position, p.yaw, lim).max() <= TOLERANCE
    # the same phase: the slow path is where its own fraction of the fast one's progress says
    assert np.allclose(b.position[:, 1] / 0.05, a.position[:, 0] / 0.4, atol=1e-6)
    assert len(retime(plans[1], lim)) == n
    with pytest.raises(ValueError):
        retime_together(
            [plans[0], Plan(fast[:10], np.zeros(10), np.zeros(10), np.zeros(10))], [lim, lim]
        )


def test_press_poses_on_opposite_faces_where_the_hands_held() -> None:
    """Each arm presses the end towards its base, the end its hand held (the big box's ends,
    along its length), from outside, the pads side by side across the box, low on the face and
    above the table."""
    from lfd.reproduce.aloha import aloha
    from lfd.reproduce.goals import DemoFrames, upright
    from lfd.reproduce.two_arm_carry import SQUEEZE_DEPTH, STANDOFF, carry_points, press_poses

    trajs, hands = _program("carry", 3)
    (p,) = carry_points(hands)
    robot = aloha()
    bases = {"right": np.array([0.45, 0.2, 0.0]), "left": np.array([-0.45, 0.2, 0.0])}
    frames = {s: DemoFrames(trajs[s], bases[s], robot.ik) for s in (p.hand, p.other)}
    f = frames[p.hand]
    i = f.index(hands.lanes[p.hand][p.step].start_s + 0.2)
    press = press_poses(frames, "big_box", i, robot)
    size = f.size[f.object_index("big_box")]
    T = upright(f.object_pose("big_box", i))
    xs = {}
    for s, (inside, out) in press.items():
        held = (np.linalg.inv(T) @ frames[s].tcp_pose(i))[:3, 3]
        assert abs(inside[0]) == pytest.approx(size[0] / 2 + robot.ik.finger_half_x - SQUEEZE_DEPTH)
        assert np.sign(inside[0]) == np.sign(held[0])  # the end its hand held
        assert abs(out[0]) - abs(inside[0]) == pytest.approx(SQUEEZE_DEPTH + STANDOFF)
        assert inside[3] == pytest.approx(
            np.pi / 2
        )  # closing axis across the box: pads side by side
        assert inside[2] - robot.ik.finger_below_tcp > -size[2] / 2  # fingertips above the table
        assert inside[2] < 0  # low on the face: pressed high, a tall object tips
        xs[s] = inside[0]
    assert xs[p.hand] * xs[p.other] < 0


def test_press_poses_keep_the_held_faces_on_a_turned_object_and_put_both_pads_at_one_place() -> (
    None
):
    """The faces pressed are those along which the two hands held the object apart, however it
    lies in the robot's scene: the big box turned a quarter turn there is still pressed on its
    ends (its x), each arm on the end nearer its base as the box lies in the scene (pressing
    its long faces, 65 mm apart, the two wrists would touch); both pads at the same place
    along the face, the mean of where the two hands held it."""
    from lfd.reproduce.aloha import aloha
    from lfd.reproduce.goals import DemoFrames, pose, upright, yaw_of
    from lfd.reproduce.two_arm_carry import SQUEEZE_DEPTH, carry_points, press_poses

    trajs, hands = _program("carry", 3)
    (p,) = carry_points(hands)
    robot = aloha()
    bases = {"right": np.array([0.45, 0.2, 0.0]), "left": np.array([-0.45, 0.2, 0.0])}
    frames = {s: DemoFrames(trajs[s], bases[s], robot.ik) for s in (p.hand, p.other)}
    f = frames[p.hand]
    i = f.index(hands.lanes[p.hand][p.step].start_s + 0.2)
    size = f.size[f.object_index("big_box")]
    T = upright(f.object_pose("big_box", i))
    held = {s: (np.linalg.inv(T) @ frames[s].tcp_pose(i))[:3, 3] for s in frames}
    demo = press_poses(frames, "big_box", i, robot)
    mean = float(np.mean([held[s][1] for s in frames]))
    for inside, _ in demo.values():
        assert inside[1] == pytest.approx(np.clip(mean, -size[1] / 2, size[1] / 2), abs=1e-9)
    for turn in (np.pi / 2, -np.pi / 2):
        turned = pose(T[:3, 3], yaw_of(T[:3, :3]) + turn)
        press = press_poses(frames, "big_box", i, robot, turned)
        for s, (inside, _) in press.items():
            assert abs(inside[0]) == pytest.approx(
                size[0] / 2 + robot.ik.finger_half_x - SQUEEZE_DEPTH
            )
            assert inside[3] == pytest.approx(np.pi / 2)  # the closing axis across the box
            # each arm on the end nearer its base, as the box lies in the scene
            end = turned @ np.array([inside[0], 0.0, 0.0, 1.0])
            far = turned @ np.array([-inside[0], 0.0, 0.0, 1.0])
            assert np.linalg.norm(end[:2] - bases[s][:2]) <= np.linalg.norm(far[:2] - bases[s][:2])
        assert press[p.hand][0][1] == pytest.approx(press[p.other][0][1])


def test_the_held_axis_is_where_the_hands_held_the_object_apart() -> None:
    """Two hands on opposite sides of the centre, at least half the object's length apart
    along an axis, held it along that axis; a hand elsewhere (the other hand not holding it)
    gives no axis (the faces then follow the robot's scene)."""
    from lfd.reproduce.two_arm_carry import _held_axis

    size = np.array([0.28, 0.065, 0.09])
    a, b = np.array([0.08, 0.002, 0.02]), np.array([-0.082, -0.003, 0.03])
    assert _held_axis({"right": a, "left": b}, size) == 0
    assert _held_axis({"right": a[[1, 0, 2]], "left": b[[1, 0, 2]]}, size[[1, 0, 2]]) == 1
    assert _held_axis({"right": a, "left": np.array([0.05, 0.3, 0.0])}, size) is None
    assert _held_axis({"right": a, "left": np.array([-0.02, 0.0, 0.0])}, size) is None


def test_a_narrow_object_is_squeezed_less_deep_keeping_the_wrists_apart() -> None:
    """The big box made 74 mm long (a wine glass's box): the two pressing TCPs are commanded
    MIN_TCP_GAP apart (shallower than SQUEEZE_DEPTH), still inside the faces; the approach
    STANDOFF outside the face."""
    from lfd.reproduce.aloha import aloha
    from lfd.reproduce.goals import DemoFrames
    from lfd.reproduce.two_arm_carry import (
        MIN_TCP_GAP,
        SQUEEZE_DEPTH,
        STANDOFF,
        carry_points,
        press_poses,
    )

    trajs, hands = _program("carry", 3)
    (p,) = carry_points(hands)
    robot = aloha()
    bases = {"right": np.array([0.45, 0.2, 0.0]), "left": np.array([-0.45, 0.2, 0.0])}
    frames = {s: DemoFrames(trajs[s], bases[s], robot.ik) for s in (p.hand, p.other)}
    k = frames[p.hand].object_index("big_box")
    for f in frames.values():
        f.size = f.size.copy()
        f.size[k] = [0.074, 0.065, 0.13]
    i = frames[p.hand].index(hands.lanes[p.hand][p.step].start_s + 0.2)
    press = press_poses(frames, "big_box", i, robot)
    (a_in, a_out), (b_in, _) = press[p.hand], press[p.other]
    assert abs(a_in[0] - b_in[0]) == pytest.approx(MIN_TCP_GAP)
    depth = 0.074 / 2 + robot.ik.finger_half_x - abs(a_in[0])
    assert 0 < depth < SQUEEZE_DEPTH
    assert abs(a_out[0]) - abs(a_in[0]) == pytest.approx(depth + STANDOFF)


def test_a_dmp_squeeze_ends_above_its_goal_no_higher_than_skills_and_turns_smoothly() -> None:
    """DMP mode's object path: a DMP to DMP_ABOVE over the goal, then straight down onto it;
    never higher than skills mode lifts it (LIFT over the higher end), never into the table;
    the yaw turns one way, smoothly, from the start's to the goal's."""
    from lfd.reproduce.aloha import aloha
    from lfd.reproduce.goals import DemoFrames, upright, yaw_of
    from lfd.reproduce.two_arm_carry import DMP_ABOVE, LIFT, carry_points, carry_steps, object_path

    trajs, hands = _program("carry", 3)
    (p,) = carry_points(hands)
    steps = carry_steps(hands, p)
    f = DemoFrames(trajs[p.hand], np.array([0.45, 0.2, 0.0]), aloha().ik)
    size = f.size[f.object_index("big_box")]
    lane = hands.lanes[p.hand]
    pick, place = lane[steps[p.hand][0]], lane[steps[p.hand][2]]
    span = (f.index(pick.end_s), f.index(place.end_s))
    T = upright(f.object_pose("big_box", span[0]))
    start = np.array([*T[:3, 3], yaw_of(T[:3, :3])])
    start[2] = size[2] / 2
    goal = start + np.array([0.15, -0.1, 0.0, 0.4])
    dmp, k = object_path(f, "big_box", start, goal, span, place.start_s, {}, "dmp")
    skills, _ = object_path(f, "big_box", start, goal, span, place.start_s, {}, "skills")
    assert np.allclose(dmp[0], start, atol=1e-6) and np.allclose(dmp[-1], goal, atol=1e-9)
    assert 0 < k < len(dmp)
    assert dmp[:, 2].max() <= max(start[2], goal[2]) + LIFT + 1e-9
    assert dmp[:, 2].max() <= skills[:, 2].max() + 1e-9
    assert dmp[:, 2].min() >= size[2] / 2 - 1e-9
    # the last part: from DMP_ABOVE over the goal straight down
    above = np.nonzero(np.isclose(dmp[:, 2], goal[2] + DMP_ABOVE, atol=1e-9))[0]
    last = int(above[-1])
    assert np.allclose(dmp[last:, :2], goal[:2], atol=1e-6)
    assert np.all(np.diff(dmp[last:, 2]) <= 1e-12)
    turn = np.diff(dmp[:, 3])
    assert np.all(turn >= -1e-12) and np.abs(np.diff(turn)).max() < 1e-3


def test_the_planned_squeeze_is_slow_and_the_approach_closed() -> None:
    """Both arms' plans of the simulated carry: the press, carry and set-down within
    SQUEEZE_SPEED and SQUEEZE_ACCELERATION; the approach to the press with the fingers closed."""
    from lfd.reproduce.aloha import aloha
    from lfd.reproduce.timescale import TOLERANCE, derivatives
    from lfd.reproduce.two_arm_carry import (
        SQUEEZE_ACCELERATION,
        SQUEEZE_SPEED,
        carry_points,
        carry_steps,
    )
    from lfd.reproduce.two_arms import _end, _start, plan_two_arms

    trajs, hands = _program("carry", 4)
    plan = plan_two_arms(trajs, hands, "skills", robot=aloha())
    for point in carry_points(hands):
        for side, (k_pick, k_with, k_place) in carry_steps(hands, point).items():
            a = plan.plans[side]
            i0, i1 = _start(a, k_with), _end(a, k_place)
            v, acc = derivatives(a.position[i0:i1])
            assert np.linalg.norm(v, axis=1).max() <= SQUEEZE_SPEED * TOLERANCE
            assert np.linalg.norm(acc, axis=1).max() <= SQUEEZE_ACCELERATION * TOLERANCE**2
            assert np.all(a.opening[_start(a, k_pick) : _end(a, k_pick)] == 0.0)


def test_a_carry_without_its_pick_up_and_place_is_refused_in_one_line() -> None:
    from lfd.errors import DemonstrationError
    from lfd.reproduce.program import HandsProgram, Segment, SyncPoint
    from lfd.reproduce.two_arms import check_runs

    lanes = {
        "right": [Segment("pick_up", 0, 1, "box"), Segment("move_with", 1, 3, "box"),
                  Segment("place", 3, 4, "box")],
        "left": [Segment("move_with", 0, 3, "box"), Segment("place", 3, 4, "box")],
    }  # fmt: skip
    hands = HandsProgram(lanes, [SyncPoint("carry", "left", 0, "right", 1, "box", 1.0)])
    with pytest.raises(DemonstrationError) as err:
        check_runs(hands)
    msg = str(err.value)
    assert "\n" not in msg and "between each hand's pick_up and place" in msg and "left" in msg


@pytest.mark.slow
@pytest.mark.parametrize("mode", ["skills", "dmp"])
def test_a_simulated_two_handed_carry_is_achieved_on_two_arms(mode: str) -> None:
    """Both arms press the big box, lift, carry and set it down together: it ends at its goal,
    lifted by both (each arm's move_with lifts it and it does not slip), both arms on one clock
    from the press to the set-down."""
    from lfd.reproduce.two_arm_carry import carry_points, carry_steps
    from lfd.reproduce.two_arms import _end, _start, reproduce_two_arms

    trajs, hands = _program("carry", 4)
    (p,) = carry_points(hands)
    steps = carry_steps(hands, p)
    r = reproduce_two_arms(trajs, hands, mode)
    assert r.success, r.failures
    assert r.failures == []
    a, b = (r.plans[s] for s in (p.hand, p.other))
    ka, kb = steps[p.hand][1], steps[p.other][1]
    assert _start(a, ka) == _start(b, kb) and _end(a, ka + 1) == _end(b, kb + 1)
    ex = r.executions[p.hand]
    j = ex.object_names.index(p.object)
    assert ex.object_position[j, :, 2].max() - ex.object_position[j, 0, 2] > 0.04  # lifted
    # the box stays between the two grippers while carried
    s0, s1 = _start(a, ka), _end(a, ka)
    gap = np.linalg.norm(r.executions[p.hand].tcp[s0:s1] - r.executions[p.other].tcp[s0:s1], axis=1)
    assert np.ptp(gap) < 0.01
