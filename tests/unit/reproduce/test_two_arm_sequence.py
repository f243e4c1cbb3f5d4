"""Two-hand programs with carries on two arms (lfd.reproduce.two_arm_sequence), a hold by
pressing (lfd.reproduce.two_arm_press), and a take given as one file per hand
(lfd reproduce RIGHT LEFT)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("mujoco")
pytest.importorskip("mink")
pytestmark = pytest.mark.skipif(
    importlib.util.find_spec("gym_aloha") is None,
    reason="gym-aloha is not installed (pip install --no-deps gym-aloha==0.1.5)",
)

MUG = np.array([0.10, 0.09, 0.11])
CUBE = np.array([0.05, 0.05, 0.05])


def _lanes():  # type: ignore[no-untyped-def]
    from lfd.reproduce.program import Segment

    right = [
        Segment("move", 0, 1, None),
        Segment("pick_up", 1, 2, "mug"),
        Segment("move_with", 2, 5, "mug"),
        Segment("place", 5, 6, "mug"),
        Segment("move", 6, 12, None),
    ]
    left = [
        Segment("move", 0, 7, None),
        Segment("pick_up", 7, 8, "mug"),
        Segment("move_with", 8, 10, "mug"),
        Segment("place", 10, 11, "mug"),
        Segment("move", 11, 12, None),
    ]
    return right, left  # fmt: skip


def test_a_one_hand_carry_of_a_wide_object_becomes_two_handed() -> None:
    """A mug 90 mm across (the gripper takes 61 mm) carried by one hand while the other is
    free: the other lane gets the same steps and a carry point; one the gripper closes across
    is left to one hand."""
    from lfd.reproduce.aloha import aloha
    from lfd.reproduce.program import HandsProgram
    from lfd.reproduce.two_arm_sequence import has_carry, prepare

    right, left = _lanes()
    hands = HandsProgram({"right": right, "left": left})
    out = prepare(hands, {"mug": MUG}, aloha())
    assert has_carry(out)
    kinds = {(p.kind, p.object) for p in out.sync}
    assert kinds == {("carry", "mug")} and len(out.sync) == 2  # each hand's carry, both arms
    for side in ("right", "left"):
        skills = [s.skill for s in out.lanes[side]]
        assert skills.count("pick_up") == skills.count("move_with") == skills.count("place") == 2
        starts = [s.start_s for s in out.lanes[side]]
        assert starts == sorted(starts)
    assert prepare(hands, {"mug": CUBE}, aloha()) is hands  # one gripper holds a cube


def test_a_wide_object_still_carried_at_the_end_is_set_down_by_both_arms() -> None:
    """The take ends with the mug in the right hand (a pick_up, then a move_with to the end):
    the carry's last SET_DOWN_S become a place, and the free left hand joins it (a two-handed
    carry); a cube carried to the end is left to one hand, as it was."""
    from lfd.reproduce.aloha import aloha
    from lfd.reproduce.program import HandsProgram, Segment
    from lfd.reproduce.two_arm_sequence import SET_DOWN_S, has_carry, prepare

    right = [
        Segment("move", 0, 1, None),
        Segment("pick_up", 1, 2, "mug"),
        Segment("move_with", 2, 6, "mug"),
    ]
    left = [Segment("move", 0, 6, None)]  # fmt: skip
    hands = HandsProgram({"right": right, "left": left})
    out = prepare(hands, {"mug": MUG}, aloha())
    assert has_carry(out)
    for side in ("right", "left"):
        lane = [s for s in out.lanes[side] if s.skill != "move"]
        assert [s.skill for s in lane] == ["pick_up", "move_with", "place"]
        assert lane[-1].start_s == pytest.approx(6 - SET_DOWN_S) and lane[-1].end_s == 6
        assert lane[1].end_s == lane[-1].start_s
    assert prepare(hands, {"mug": CUBE}, aloha()) is hands


def test_a_carry_from_the_first_sample_gets_its_pick_up() -> None:
    """A take that starts with the object in both hands: each lane gets a pick_up first."""
    from lfd.reproduce.aloha import aloha
    from lfd.reproduce.program import HandsProgram, Segment
    from lfd.reproduce.two_arm_carry import carry_steps
    from lfd.reproduce.two_arm_sequence import prepare

    lane = [Segment("move_with", 0, 4, "box"), Segment("place", 4, 5, "box"),
            Segment("move", 5, 8, None)]  # fmt: skip
    hands = HandsProgram({"right": list(lane), "left": list(lane)})
    out = prepare(hands, {"box": CUBE}, aloha())
    (p,) = out.sync
    assert carry_steps(out, p) == {"right": (0, 1, 2), "left": (0, 1, 2)}
    assert out.lanes["right"][0].skill == "pick_up" and out.lanes["right"][0].object == "box"


def test_a_hold_program_is_not_made_a_carry_and_a_wide_hold_is_a_press() -> None:
    """hold_stack's plank (65 mm) is held still: no carry, the holding lane pressed; the press
    at the plank's end on the hand's side, its fingertips 2 mm into its top."""
    from lfd.reproduce.aloha import aloha
    from lfd.reproduce.goals import DemoFrames, upright
    from lfd.reproduce.two_arm_press import PRESS_DEPTH, PRESS_EDGE, press_holds, press_pose
    from lfd.reproduce.two_arm_sequence import prepare

    from tests.unit.reproduce.test_two_arm_carry import _program

    trajs, hands = _program("hold_stack", 3)
    t = trajs["right"]
    sizes = dict(zip(t.object_names, np.asarray(t.object_size), strict=True))
    robot = aloha()
    assert prepare(hands, sizes, robot) is hands
    (point,) = press_holds(hands, sizes, robot).values()
    assert point.kind == "hold_until" and point.object == "plank"
    f = DemoFrames(trajs[point.hand], np.array([0.0, -0.2, 0.0]), robot.ik)
    i = f.index(hands.lanes[point.hand][point.step - 1].end_s)
    T = upright(f.object_pose("plank", i))
    p = press_pose(f, "plank", i, T)
    size = f.size[f.object_index("plank")]
    local = np.linalg.inv(T) @ np.array([*p[:3], 1.0])
    assert abs(local[0]) == pytest.approx(size[0] / 2 - PRESS_EDGE)  # at the end
    held = (np.linalg.inv(T) @ f.tcp_pose(i))[0, 3]
    assert np.sign(local[0]) == np.sign(held)  # the end the hand held
    top = T[2, 3] + size[2] / 2
    assert p[2] - robot.ik.finger_below_tcp == pytest.approx(top - PRESS_DEPTH)


@pytest.mark.slow
def test_a_simulated_hold_stack_is_achieved_by_pressing() -> None:
    """The holding arm presses the plank, the other stacks a cube on it, the plank stays."""
    from lfd.reproduce.two_arms import _start, reproduce_two_arms

    from tests.unit.reproduce.test_two_arm_carry import _program

    trajs, hands = _program("hold_stack", 4)
    (hold,) = [p for p in hands.sync if p.kind == "hold_until"]
    r = reproduce_two_arms(trajs, hands, "skills")
    assert r.success, r.failures
    holder = r.plans[hold.hand]
    assert np.all(holder.opening[_start(holder, hold.step - 1) + len(holder) // 100 :] >= 0)
    k = hold.step
    a, b = _start(holder, k), _start(holder, k + 1)
    assert np.all(holder.opening[a:b] == 0.0)  # pressing closed, not grasping
    ex = r.executions[hold.hand]
    j = ex.object_names.index("plank")
    assert np.ptp(ex.object_position[j, a:b, 2]) < 0.005  # never lifted


def test_cli_joins_a_take_of_two_files_and_refuses_two_of_one_hand(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``lfd reproduce RIGHT LEFT --program``: one two-hand program of the two files; two files
    of the same hand: one line, exit 2, nothing written."""
    import dataclasses

    import lfd
    from lfd.cli import main

    rec = tmp_path / "carry.mcap"
    assert main(["simulate", "carry", "--seed", "3", "--style", "careful", "-o", str(rec)]) == 0
    demo = lfd.load(rec, images=False)
    for side in demo.sides:
        one = demo.one_hand(side)
        labels = [dataclasses.replace(lab, hand=None) for lab in demo.labels_of(side)]
        lfd.save(dataclasses.replace(one, labels=labels), tmp_path / f"take.{side}.mcap")
    capsys.readouterr()
    out = tmp_path / "p.json"
    args = ["reproduce", str(tmp_path / "take.right.mcap"), str(tmp_path / "take.left.mcap")]
    assert main([*args, "--program", "--json", str(out)]) == 0
    import json

    doc = json.loads(out.read_text())["program"]
    assert set(doc["hands"]) == {"right", "left"}
    assert [p["kind"] for p in doc["sync"]] == ["carry"]
    capsys.readouterr()
    bad = tmp_path / "bad.json"
    right = str(tmp_path / "take.right.mcap")
    assert main(["reproduce", right, right, "--robot", "aloha", "--json", str(bad)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "right and a left hand" in err[0]
    assert not bad.exists()
