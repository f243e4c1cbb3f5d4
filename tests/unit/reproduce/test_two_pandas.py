"""A second two-arm robot (``--robot two_pandas``, :func:`lfd.reproduce.panda.two_pandas`): two
Pandas from robosuite's MJCF, every name of each arm prefixed with its side, for the objects the
ALOHA's gripper cannot close across; and a hold under a stack done by pressing."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest
from _two_arm_programs import program

pytest.importorskip("mujoco")
pytest.importorskip("mink")
pytestmark = pytest.mark.skipif(
    importlib.util.find_spec("robosuite") is None,
    reason="robosuite not installed (the robots extra: pip install --no-deps robosuite==1.5.2)",
)

BASES = {"right": np.array([0.55, 0.45, 0.0]), "left": np.array([-0.55, 0.45, 0.0])}
YAWS = {"right": np.pi, "left": 0.0}


def test_two_pandas_compile_in_one_scene_each_arm_named_by_its_side() -> None:
    import mujoco
    from lfd.reproduce.panda import FINGER_RANGE, panda, two_pandas
    from lfd.reproduce.robots import TWO_ARM_ROBOTS, any_robot
    from lfd.reproduce.two_arms import scene_xml

    robot = any_robot("two_pandas")
    assert robot is two_pandas() and TWO_ARM_ROBOTS["two_pandas"] is two_pandas
    assert robot.sides == ("right", "left") and robot.ik is panda() and robot.ik.dof == 7
    model = mujoco.MjModel.from_xml_string(scene_xml(BASES, [], robot, YAWS))
    data = mujoco.MjData(model)
    assert model.nu == 18 and model.nq == 18  # 7 joints and 2 fingers per arm
    driven = [model.joint(model.actuator(i).trnid[0]).name for i in range(model.nu)]
    arms = robot.arms
    assert driven == [
        *arms["right"].arm_joints,
        *arms["right"].finger_joints,
        *arms["left"].arm_joints,
        *arms["left"].finger_joints,
    ]
    assert arms["left"].arm_joints[0] == "left/joint1"
    for side in BASES:
        for j, q in zip(arms[side].arm_joints, robot.ik.home_q, strict=True):
            data.qpos[model.joint(j).qposadr[0]] = q
        for f in arms[side].finger_joints:
            assert tuple(model.jnt_range[model.joint(f).id]) == pytest.approx((0, FINGER_RANGE))
    mujoco.mj_forward(model, data)
    for side, base in BASES.items():
        tcp = data.site(f"{side}/tcp").xpos
        ahead = np.array([np.cos(YAWS[side]), np.sin(YAWS[side])])
        assert 0.2 < float((tcp[:2] - base[:2]) @ ahead) < 0.8 and tcp[2] > 0.05
    # the one-arm Panda keeps its unprefixed names
    one = mujoco.MjModel.from_xml_string(panda().model_xml())
    assert one.site("tcp").id >= 0 and one.joint("joint1").id >= 0


def test_a_hold_under_a_stack_is_a_press_even_where_the_gripper_fits() -> None:
    """The plank (65 mm) fits a Panda hand (72 mm) but not the ALOHA's (61 mm): held while the
    other arm stacks on it, it is pressed on both; a plank held while the other arm only
    moves is grasped where it fits."""
    from dataclasses import replace

    from lfd.reproduce.aloha import aloha
    from lfd.reproduce.panda import two_pandas
    from lfd.reproduce.two_arm_press import press_holds

    _, hands = program("hold_stack", 9501, style="careful")
    sizes = {"plank": np.array([0.17, 0.065, 0.04])}
    (hold,) = [p for p in hands.sync if p.kind == "hold_until"]
    for robot in (two_pandas(), aloha()):
        assert press_holds(hands, sizes, robot) == {hold.hand: hold}
    moving = list(hands.lanes[hold.other])
    moving[hold.other_step] = replace(moving[hold.other_step], skill="move")
    other = replace(hands, lanes={**hands.lanes, hold.other: moving})
    assert press_holds(other, sizes, two_pandas()) == {}
    assert press_holds(other, sizes, aloha()) == {hold.hand: hold}  # too wide: pressed


@pytest.mark.slow  # two runs of a whole demonstration on two arms (~60 s)
@pytest.mark.parametrize("mode", ["skills", "dmp"])
def test_a_natural_hold_stack_the_aloha_refuses_is_achieved_on_two_pandas(mode: str) -> None:
    """Natural hold_stack seed 9501 stacks a 65 mm cube: wider than the ALOHA's gripper takes,
    and its left hand's path out of a ViperX's reach (refused), within a Panda's; before the
    press under a stack its box landed 36 mm off target on the plank the holding Panda had
    lifted."""
    from lfd.errors import LfdError
    from lfd.reproduce.aloha import aloha
    from lfd.reproduce.panda import two_pandas
    from lfd.reproduce.two_arms import reproduce_two_arms

    trajs, hands = program("hold_stack", 9501, style="natural")
    with pytest.raises(LfdError, match="cannot"):
        reproduce_two_arms(trajs, hands, mode=mode, robot=aloha())
    res = reproduce_two_arms(trajs, hands, mode=mode, robot=two_pandas())
    assert res.success, res.failures


def test_a_straight_approach_goes_over_to_the_hold_in_the_same_ticks() -> None:
    """The holder's way to its press (the move, then the approach to the hover above the hold)
    is replaced by up, over and down at its highest height, on the same clock; the press and
    what follows are kept."""
    from dataclasses import replace

    from lfd.reproduce.controller import Plan
    from lfd.reproduce.program import HandsProgram, Segment, SyncPoint
    from lfd.reproduce.two_arm_clearance import straight_approach

    lane = [
        Segment("move", 0.0, 1.0, "plank"),
        Segment("pick_up", 1.0, 2.0, "plank"),
        Segment("move_with", 2.0, 3.0, "plank"),
        Segment("place", 3.0, 3.5, "plank"),
    ]
    other = [Segment("move", 0.0, 1.0, "box"), Segment("stack", 1.0, 3.0, "box")]
    hold = SyncPoint("hold_until", "left", 2, "right", 1, "plank", 3.0)
    hands = HandsProgram(lanes={"right": other, "left": lane}, sync=[hold])
    start, dip = np.array([-0.2, 0.0, 0.16]), np.array([0.0, 0.2, 0.06])  # the approach's start
    hover, press = np.array([-0.07, 0.18, 0.1]), np.array([-0.07, 0.18, 0.05])
    pts = [np.linspace(a, b, n) for a, b, n in [(start, dip, 30), (dip, hover, 20)]]
    pts += [np.linspace(hover, press, 10), np.repeat(press[None], 15, 0)]
    position = np.concatenate(pts)
    segment = np.repeat([0, 1, 1, 2], [30, 20, 10, 15])
    n = len(position)
    plan = Plan(position, np.zeros(n), np.full(n, 0.08), segment)
    out = straight_approach(plan, hands, hold)
    h = 50  # the hover: the last tick at the pick_up's highest before its descent
    assert len(out) == n and np.array_equal(out.segment, segment)
    np.testing.assert_allclose(out.position[h:], position[h:])
    way = out.position[: h + 1]
    assert way[:, 2].min() >= 0.1 - 1e-9 and way[:, 2].max() == pytest.approx(0.16)
    # over from above the start to above the hover: never towards the approach's start
    d = np.linalg.norm(way[:, :2] - dip[:2], axis=1)
    assert d.min() >= np.linalg.norm(hover[:2] - dip[:2]) - 1e-9
    # a lane whose pick_up no move comes right before is kept
    at_first = replace(hold, step=1)
    first = HandsProgram(lanes={"right": other, "left": lane[1:]}, sync=[at_first])
    assert straight_approach(plan, first, at_first) is plan


@pytest.mark.slow  # one layout planned and run on two arms in both modes (~80 s)
@pytest.mark.parametrize("mode", ["skills", "dmp"])
def test_the_press_is_approached_straight_where_the_waiting_arm_is_above(mode: str) -> None:
    """Natural hold_stack seed 9504, its second randomised layout (the plank moved and turned
    42 deg): the right arm waits with box_2 above the plank for the left arm's press, whose
    one-arm approach came to where the person's hand began its approach, under the right arm
    (the arms touched at 8.2-8.3 s); straight over to above the press, it succeeds."""
    from lfd.reproduce.panda import two_pandas
    from lfd.reproduce.two_arms import reproduce_two_arms

    trajs, hands = program("hold_stack", 9504, style="natural")
    displace = {
        "plank": (-0.0579034619727993, 0.010213482519517881, 42.29318239859654),
        "box_1": (-0.010213927735668699, -0.020469585472165208, 25.03181229055096),
        "box_2": (0.030817843543256878, -0.024322692824982187, -27.51103701363876),
    }
    res = reproduce_two_arms(trajs, hands, mode=mode, robot=two_pandas(), displace=displace)
    assert res.success, res.failures


def test_the_holder_lifts_off_once_the_other_arm_is_done() -> None:
    """The holder's press outlasting the other arm's step (the person's hand held on a while
    more) is cut short: it lifts off once the other arm's step (release and back-off) has
    ended, its lift-off and what follows the same, earlier; a hold that does not outlast it is
    kept."""
    from lfd.reproduce.controller import Plan
    from lfd.reproduce.program import SyncPoint
    from lfd.reproduce.two_arm_clearance import lift_early

    hold = SyncPoint("hold_until", "left", 2, "right", 1, "plank", 3.0)
    press, up = np.array([0.0, 0.2, 0.05]), np.array([0.0, 0.2, 0.15])
    holder_pts = [np.linspace(up, press, 10), np.repeat(press[None], 40, 0)]
    holder_pts.append(np.linspace(press, up, 10))
    position = np.concatenate(holder_pts)
    segment = np.repeat([1, 2, 3], [10, 40, 10])
    n = len(position)
    holder = Plan(position, np.zeros(n), np.zeros(n), segment)
    # the other arm: its step (1) ends at tick 30, then it goes away (2)
    other_seg = np.repeat([0, 1, 2], [10, 20, 30])
    other = Plan(np.zeros((60, 3)), np.zeros(60), np.zeros(60), other_seg)
    out = lift_early({"left": holder, "right": other}, hold)
    assert len(out) == n - 20 and np.array_equal(out.segment, np.repeat([1, 2, 3], [10, 20, 10]))
    np.testing.assert_allclose(out.position[30:], position[50:])  # the lift-off, earlier
    np.testing.assert_allclose(out.position[:30], position[:30])
    # the other arm's step ends after the hold: nothing to cut
    late = Plan(np.zeros((60, 3)), np.zeros(60), np.zeros(60), np.repeat([0, 1, 2], [10, 45, 5]))
    assert lift_early({"left": holder, "right": late}, hold) is holder


def test_bases_level_with_the_work_are_tried_where_the_arms_meet() -> None:
    """choose_bases' ``level`` keeps both bases within it of the work's centre along y (the
    widest reach margin alone puts a Panda's behind the work); bases_apart plans again with
    the bases so only where the planned arms touch or come closer than APART, keeping the plan whose
    arms stay furthest apart, and skips a level from which no base reaches."""
    from types import SimpleNamespace

    from lfd.errors import DemonstrationError
    from lfd.reproduce.panda import two_pandas
    from lfd.reproduce.two_arm_apart import APART, bases_apart
    from lfd.reproduce.two_arm_bases import choose_bases

    robot = two_pandas()
    xs = np.linspace(-0.15, 0.15, 20)
    points = {
        "right": np.stack([xs + 0.05, 0.2 + 0 * xs, 0.1 + 0 * xs], axis=1),
        "left": np.stack([xs - 0.05, 0.15 + 0 * xs, 0.1 + 0 * xs], axis=1),
    }
    objects = np.array([[0.0, 0.18, 0.02]])
    centre_y = np.concatenate(list(points.values()))[:, 1].mean()
    anywhere = choose_bases(points, objects, robot)
    level = choose_bases(points, objects, robot, level=0.2)
    assert max(abs(b[1] - centre_y) for b in anywhere.values()) > 0.2
    assert all(abs(b[1] - centre_y) <= 0.2 + 1e-9 for b in level.values())
    assert level["right"][0] > 0 > level["left"][0]

    scores = {
        (np.inf, False, False): (-0.0, -40),
        (np.inf, True, False): (0.0, -20),
        (0.3, False, False): (0.0, -30),
        (0.3, True, False): (0.015, 0),
    }
    asked: list[tuple[float, bool, bool]] = []

    def plan(level: float, away: bool, turn: bool) -> SimpleNamespace | None:
        asked.append((level, away, turn))
        if level == 0.2:
            raise DemonstrationError("short by 4 mm")
        if turn and (level, away, turn) not in scores:
            return None  # no box turned
        return SimpleNamespace(plans={"right": 0, "left": 0}, key=(level, away, turn))

    def score(p: SimpleNamespace) -> tuple[float, int]:
        return scores[p.key]

    # the object taken away from the press first, then each level, then both
    unturned = [(np.inf, True), (0.2, False), (0.3, False), (0.2, True), (0.3, True)]
    order = [(np.inf, False, False), *((x, a, False) for x, a in unturned)]
    assert bases_apart(plan, score, (0.2, 0.3)).key == (0.3, True, False) and asked == order
    scores[(0.3, True, False)] = (0.0, -25)  # nothing clear: the one that overlaps least
    asked.clear()
    assert bases_apart(plan, score, (0.2, 0.3)).key == (np.inf, True, False)
    # then each again with a square box stacked turned (None where none is)
    assert asked == order + [(x, a, True) for x, a in [(np.inf, False), *unturned]]
    scores[(np.inf, True, True)] = (0.012, 0)
    scores[(0.3, False, True)] = (0.02, 0)  # further apart, but not tried: already clear
    asked.clear()
    assert bases_apart(plan, score, (0.2, 0.3)).key == (np.inf, True, True)
    assert asked[-2:] == [(np.inf, False, True), (np.inf, True, True)]
    for clear in [(0.015, 0), (0.005, -3)]:  # clear, or apart though closer: planned once
        scores[(np.inf, False, False)] = clear
        asked.clear()
        assert bases_apart(plan, score, (0.2, 0.3)).key == (np.inf, False, False)
        assert asked == [(np.inf, False, False)]
    # apart but closer than APART (the executed arms lag the plan): made again, the clearer kept
    scores[(np.inf, False, False)] = (APART - 0.001, -3)
    asked.clear()
    assert bases_apart(plan, score, (0.2, 0.3)).key == (np.inf, True, True)
    assert asked[:2] == order[:2] and asked[-1] == (np.inf, True, True)
    scores[(np.inf, False, False)] = (0.0, -40)
    only = lambda lv, a, t: None if a or t else plan(lv, a, t)  # noqa: E731
    assert bases_apart(only, score, ()).key == (np.inf, False, False)


def test_a_holder_made_to_wait_waits_by_its_base_then_comes_in() -> None:
    """A holder made to wait (:func:`hold_later`: its first ticks a wait, step -1) waits up by
    its own base, not where the person's hand rested (in the other arm's way when the hands
    crossed), then comes over to the hover above its hold (``low``: down by its base first,
    then in at the hover's height) in the ticks of its way there; the hold and what follows
    are kept. A hold whose way there is not the lane's first step is kept."""
    from dataclasses import replace

    from lfd.reproduce.controller import Plan
    from lfd.reproduce.program import HandsProgram, Segment, SyncPoint
    from lfd.reproduce.two_arm_clearance import (
        PARK_HEIGHT,
        PARK_IN_RISE,
        PARK_REACH,
        PARK_TURNS,
        park_first,
    )

    lane = [
        Segment("move", 0.0, 1.0, "plank"),
        Segment("pick_up", 1.0, 2.0, "plank"),
        Segment("move_with", 2.0, 3.0, "plank"),
        Segment("place", 3.0, 3.5, "plank"),
    ]
    other = [Segment("move", 0.0, 1.0, "box"), Segment("stack", 1.0, 3.0, "box")]
    hold = SyncPoint("hold_until", "left", 2, "right", 1, "plank", 3.0)
    hands = HandsProgram(lanes={"right": other, "left": lane}, sync=[hold])
    rest = np.array([-0.25, 0.04, 0.16])  # where the person's hand rested: waited at
    hover, press = np.array([-0.05, 0.23, 0.1]), np.array([-0.05, 0.23, 0.05])
    pts = [np.repeat(rest[None], 40, 0), np.linspace(rest, hover, 30)]
    pts += [np.linspace(hover, press, 10), np.repeat(press[None], 15, 0)]
    position = np.concatenate(pts)
    segment = np.repeat([-1, 0, 1, 2], [40, 30, 10, 15])
    n = len(position)
    plan = Plan(position, np.full(n, 0.3), np.full(n, 0.08), segment)
    base = np.array([-0.46, 0.49, 0.0])
    u = (hover[:2] - base[:2]) / np.linalg.norm(hover[:2] - base[:2])
    h = 70  # the hover: the pick_up's first (highest) tick before its descent
    assert PARK_TURNS[0] == 0.0 and len(PARK_TURNS) > 1
    for low, turn in [(low, turn) for low in (False, True) for turn in PARK_TURNS]:
        c, si = np.cos(turn), np.sin(turn)  # towards the hover, turned about the base
        park = np.array(
            [*(base[:2] + PARK_REACH * (np.array([[c, -si], [si, c]]) @ u)), PARK_HEIGHT]
        )
        out = park_first(plan, hands, hold, base, low=low, turn=turn)
        assert len(out) == n and np.array_equal(out.segment, segment)
        np.testing.assert_allclose(out.position[:40], np.repeat(park[None], 40, 0))
        np.testing.assert_allclose(out.position[h:], position[h:])
        way = out.position[40 : h + 1]
        np.testing.assert_allclose(way[-1], hover)
        off = np.linalg.norm(way[:, :2] - park[:2], axis=1) > 1e-6
        if low:  # in at the hover's height, at least PARK_IN_RISE above the grasp, and down
            z = max(hover[2], press[2] + PARK_IN_RISE)
            level = off & (np.linalg.norm(way[:, :2] - hover[:2], axis=1) > 1e-6)
            np.testing.assert_allclose(way[level, 2], z, atol=1e-9)
            assert z > hover[2] and np.all(way[:, 2] >= hover[2] - 1e-9)
        else:  # over at the park's height, down above the hover
            near = np.linalg.norm(way[:, :2] - hover[:2], axis=1) > 1e-6
            np.testing.assert_allclose(way[off & near, 2], PARK_HEIGHT, atol=1e-9)
    # the hold's way there is not the first step: kept
    at_second = replace(hold, step=3)
    later = HandsProgram(lanes={"right": other, "left": [lane[0], *lane]}, sync=[at_second])
    assert park_first(plan, later, at_second, base) is plan


def test_a_step_beside_a_hold_goes_over_then_straight_down() -> None:
    """The other arm's step at a hold (straight_down): a DMP's curve sweeping sideways towards
    the holder becomes up to its highest height, over above the step's lowest point and
    straight down to it, in the same ticks; what follows its lowest point is kept. A step of
    one tick is kept."""
    from lfd.reproduce.controller import Plan
    from lfd.reproduce.two_arm_clearance import straight_down

    n0, n1, n2 = 20, 50, 30  # before, the stack's descent, its release and what follows
    start, low = np.array([0.03, 0.23, 0.19]), np.array([0.05, 0.22, 0.08])
    s = np.linspace(0.0, 1.0, n1)[:, None]
    curve = start + s * (low - start) + np.sin(np.pi * s) * np.array([-0.04, 0.0, 0.0])
    position = np.concatenate([np.repeat(start[None], n0, 0), curve, np.repeat(low[None], n2, 0)])
    segment = np.repeat([2, 3, 4], [n0, n1, n2])
    n = len(position)
    plan = Plan(position, np.full(n, 1.5), np.zeros(n), segment)
    out = straight_down(plan, 3)
    assert len(out) == n and np.array_equal(out.segment, segment)
    np.testing.assert_allclose(out.position[: n0 + 1], position[: n0 + 1])
    np.testing.assert_allclose(out.position[n0 + n1 - 1 :], position[n0 + n1 - 1 :])
    way = out.position[n0 : n0 + n1]
    assert way[:, 2].max() <= start[2] + 1e-9  # no higher than the step was
    below = way[:, 2] < start[2] - 1e-6  # once going down, straight above its lowest point
    np.testing.assert_allclose(way[below, :2], np.repeat(low[None, :2], below.sum(), 0), atol=1e-9)
    assert np.all(way[:, 0] >= start[0] - 1e-9)  # no sweep towards the holder (-x)
    assert np.all(np.diff(way[:, 2]) <= 1e-12)  # never up again
    one = Plan(position, np.full(n, 1.5), np.zeros(n), np.repeat([2, 3, 4], [n0 + n1 - 1, 1, n2]))
    assert straight_down(one, 3) is one


def test_a_carry_to_beside_a_hold_goes_over_the_holder() -> None:
    """The other arm's carry to its step beside a hold (carry_over): a slant from where it
    picked its object up to where its step begins becomes straight up to PARK_HEIGHT, over and
    down, in the same ticks, both ends kept; a carry of two ticks is kept."""
    from lfd.reproduce.controller import Plan
    from lfd.reproduce.two_arm_clearance import PARK_HEIGHT, carry_over

    a, b = np.array([-0.16, 0.14, 0.04]), np.array([0.11, 0.30, 0.19])
    slant = np.linspace(a, b, 60)
    position = np.concatenate([np.repeat(a[None], 10, 0), slant, np.repeat(b[None], 10, 0)])
    segment = np.repeat([1, 2, 3], [10, 60, 10])
    n = len(position)
    plan = Plan(position, np.linspace(0.0, 1.0, n), np.zeros(n), segment)
    out = carry_over(plan, 2)
    assert len(out) == n and np.array_equal(out.segment, segment)
    np.testing.assert_allclose(out.position[:11], position[:11])
    np.testing.assert_allclose(out.position[69:], position[69:])
    way = out.position[10:70]
    assert way[:, 2].max() == pytest.approx(PARK_HEIGHT)
    rising = way[:, 2] < PARK_HEIGHT - 1e-6
    first = int(np.argmax(~rising))  # up above where it picked, then over, then down
    np.testing.assert_allclose(way[:first, :2], np.repeat(a[None, :2], first, 0), atol=1e-9)
    two = Plan(position, np.zeros(n), np.zeros(n), np.repeat([1, 2, 3], [10, 2, n - 12]))
    assert carry_over(two, 2) is two


def test_the_arms_clearance_counts_the_ticks_they_overlap_before_those_merely_close(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Two plans whose arms both touch (least distance 0 once clipped): the one overlapping at
    fewer ticks scores higher, though closer than the clearance at more; apart scores higher
    still (clearance_score, on measured distances)."""
    import lfd.reproduce.two_arm_clearance as clearance

    got = {
        "deep": np.array([0.05, -0.01, -0.02, -0.01, 0.05]),
        "brush": np.array([0.01, -0.001, 0.01, 0.012, 0.01]),
        "apart": np.array([0.01, 0.008, 0.01, 0.012, 0.01]),
    }

    def score(name: str) -> tuple[float, int, int]:
        monkeypatch.setattr(clearance, "arm_distances", lambda *a, **k: got[name])
        return clearance.clearance_score({}, "", lambda s: None, None)

    assert score("deep") == (0.0, -3, -3) and score("brush") == (0.0, -1, -5)
    assert score("apart") == (0.008, 0, -5)
    assert score("apart") > score("brush") > score("deep")


@pytest.mark.slow  # one layout planned (its bases tried level with the work) and run (~3 min)
def test_a_holder_waits_by_its_base_while_the_other_arm_fetches_across() -> None:
    """Natural hold_stack seed 9502, its first randomised layout: the right hand fetched box_1
    left of the plank, past the left hand resting where the right arm goes (planned -59 mm,
    the right gripper on the left arm's wrist at 1.7 s). The left arm waits up by its base
    while the right one fetches box_1, then comes in low to press: achieved."""
    from lfd.reproduce.panda import two_pandas
    from lfd.reproduce.two_arms import reproduce_two_arms

    trajs, hands = program("hold_stack", 9502, style="natural")
    displace = {
        "plank": (0.018390069464318225, -0.05779199040758162, 2.2309880077185866),
        "box_1": (0.017565432759465514, -0.08960177087296553, -39.12577877425881),
        "box_2": (-0.08763323558611212, -0.02442548558610065, -6.047052402567495),
    }
    res = reproduce_two_arms(trajs, hands, mode="skills", robot=two_pandas(), displace=displace)
    assert res.success, res.failures


@pytest.mark.slow  # one layout planned (seven times: the arms touch until the cube turns), run
def test_a_cube_stacked_a_quarter_turn_round_keeps_the_pandas_apart() -> None:
    """Natural hold_stack seed 9510, its first randomised layout: the right hand stacks a 53 mm
    cube 12 cm from the left's press, and at the pick-up the plank lies within the open
    fingers' room across the line to the press, so the gripper closes along it: a Panda hand,
    20 cm along its closing axis, reached the pressing wrist (-25 mm, the right gripper on the
    left arm's link6 at 10.2 s). Stacked a quarter turn round, the gripper closes across that
    line there: the arms stay apart, the task is achieved."""
    from lfd.reproduce.panda import two_pandas
    from lfd.reproduce.two_arms import plan_two_arms, run_two_arm_plan

    trajs, hands = program("hold_stack", 9510, style="natural")
    displace = {
        "plank": (-0.032685209730525966, 0.003044329356605491, -18.74755124927825),
        "box_1": (-0.03644024484159324, 0.029823837137016973, 28.510415836488633),
        "box_2": (-0.024641963235039633, -0.07312955635140429, -34.40161467385295),
    }
    robot = two_pandas()
    plan = plan_two_arms(trajs, hands, "skills", robot=robot, displace=displace)
    turned = {n for s in plan.planned for n in plan.planned[s][2].turned}
    assert turned, "the cube is stacked as the person did"
    res = run_two_arm_plan(plan, robot)
    assert res.success, res.failures


def test_a_move_whose_mapped_end_lies_in_another_object_arrives_above_its_grasp() -> None:
    """Natural hold_stack seed 9528, its second randomised layout: the left hand began to pick
    box_1 up 14 cm from it, where this layout puts the plank; the left arm's DMP move ended
    there, 9 mm below the plank's top, and its fingers shoved the plank 27 mm before the right
    arm pressed it. The move now arrives above box_1's grasp, clear of the plank, and the
    pick_up comes down from there (the fingers never reach into the plank)."""
    from lfd.geometry import in_box_frame
    from lfd.reproduce.panda import two_pandas
    from lfd.reproduce.two_arms import plan_two_arms

    trajs, hands = program("hold_stack", 9528, style="natural")
    displace = {
        "plank": (0.0424579359891018, 0.08291784752036785, -25.94919776532525),
        "box_1": (0.06454677839938493, 0.020797958292385902, 40.43977038802193),
        "box_2": (0.06846891814924883, 0.07038434241457857, -42.98646865940027),
    }
    robot = two_pandas()
    plan = plan_two_arms(trajs, hands, "dmp", robot=robot, displace=displace)
    plank = next(o for o in plan.specs if o.name == "plank")
    p = plan.plans["left"]
    steps = np.flatnonzero((p.segment == 0) | (p.segment == 1))  # the move and the pick_up
    local = in_box_frame(p.position[steps] - plank.position, plank.quaternion)
    over = np.all(np.abs(local[:, :2]) < plank.size[:2] / 2 + robot.ik.hand_radius, axis=1)
    fingertips = p.position[steps, 2] - robot.ik.finger_below_tcp
    top = plank.position[2] + plank.size[2] / 2
    assert not np.any(over & (fingertips <= top)), "the open fingers in the plank"
    box_1 = next(o for o in plan.specs if o.name == "box_1")
    end = p.position[np.flatnonzero(p.segment == 0)[-1]]
    assert np.hypot(*(end[:2] - box_1.position[:2])) < 0.5 * box_1.size[0]  # above box_1


def test_an_arm_done_goes_up_by_its_base_not_where_the_hand_rested() -> None:
    """An arm's last move to where the person's hand went to rest (no object) goes instead up
    by its own base, over the same ticks (up, over, down to the park height), and stays there;
    the steps before are kept; a lane whose last step is not such a move is kept."""
    from lfd.reproduce.controller import Plan
    from lfd.reproduce.program import Segment
    from lfd.reproduce.two_arm_clearance import PARK_HEIGHT, PARK_REACH, park_last

    lane = [Segment("stack", 0.0, 1.0, "box"), Segment("move", 1.0, 2.0, None)]
    stacked, rest = np.array([0.05, 0.22, 0.08]), np.array([0.25, 0.01, 0.13])
    position = np.concatenate([np.repeat(stacked[None], 20, 0), np.linspace(stacked, rest, 30)])
    position = np.concatenate([position, np.repeat(rest[None], 5, 0)])
    segment = np.repeat([0, 1, -1], [20, 30, 5])
    n = len(position)
    plan = Plan(position, np.full(n, 0.2), np.full(n, 0.08), segment)
    base = np.array([0.1, -0.41, 0.0])
    u = (stacked[:2] - base[:2]) / np.linalg.norm(stacked[:2] - base[:2])
    park = np.array([*(base[:2] + PARK_REACH * u), PARK_HEIGHT])
    out = park_last(plan, lane, base)
    assert len(out) == n and np.array_equal(out.segment, segment)
    np.testing.assert_allclose(out.position[:20], position[:20])
    np.testing.assert_allclose(out.position[49:], np.repeat(park[None], 6, 0), atol=1e-12)
    way = out.position[20:50]
    assert way[:, 2].min() >= stacked[2] - 1e-12 and way[:, 2].max() == pytest.approx(PARK_HEIGHT)
    assert park_last(plan, [lane[1], lane[0]], base) is plan  # last step not a free move
