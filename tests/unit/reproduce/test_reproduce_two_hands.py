"""Two hands on one arm: the task program per hand with its synchronisation points, and
``lfd reproduce`` of a two-hand recording (run when one hand does all of it, else refused)."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import _paths
import lfd
import pytest
from _two_hand_tasks import busy_left, handover_labels, hold_labels, idle_left
from lfd.errors import DemonstrationError
from lfd.reproduce.program import from_hand_labels, from_hands

EXP1 = _paths.EXP1


@pytest.fixture(scope="module")
def exp1() -> lfd.Demonstration:
    return lfd.load(EXP1, images=False)


def test_handover_sync_point(exp1: lfd.Demonstration) -> None:
    """The giver's place waits for the taker's pick_up: the handover's sync point names both
    steps, in JSON and in the printed program; the refusal names the handover."""
    labels, handovers = handover_labels(exp1.start_ns)
    prog = from_hand_labels(labels, exp1.start_ns, sides=("right", "left"), handovers=handovers)
    assert [s.skill for s in prog.lanes["right"]] == ["pick_up", "move_with", "place", "move"]
    (point,) = [p for p in prog.sync if p.kind == "handover"]
    assert (point.hand, point.step, point.other, point.other_step) == ("right", 2, "left", 1)
    assert point.object == "box_2" and point.t_s == pytest.approx(3.0)
    # the giver's move_with and the taker's pick_up are of the same object: no hold
    assert [p.kind for p in prog.sync] == ["handover"]
    doc = json.loads(json.dumps(prog.to_json()))
    assert doc["sync"][0] | {"t_s": 3.0} == {
        "kind": "handover", "hand": "right", "step": 2, "other": "left", "other_step": 1,
        "object": "box_2", "t_s": 3.0,
    }  # fmt: skip
    assert set(doc["hands"]) == {"right", "left"}
    text = "\n".join(prog.lines())
    assert "handover of box_2 at 3.00 s: right 2 place lets go after left 1 pick_up" in text
    with pytest.raises(DemonstrationError) as err:
        prog.one_arm_side()
    msg = str(err.value)
    assert "\n" not in msg and "both hands handle objects" in msg
    assert (
        "the left hand's pick_up of box_2 at 2.0 s" in msg and "a handover of box_2 at 3.0 s" in msg
    )


def test_hold_until_sync_point(exp1: lfd.Demonstration) -> None:
    """A hand holding box_2 while the other stacks box_3 on it holds until the stack ends."""
    prog = from_hand_labels(hold_labels(exp1.start_ns), exp1.start_ns, sides=("right", "left"))
    holds = [p for p in prog.sync if p.kind == "hold_until"]
    assert [(p.hand, p.step, p.other, p.other_step, p.object) for p in holds] == [
        ("right", 1, "left", 3, "box_2")
    ]
    assert holds[0].t_s == pytest.approx(9.0)
    assert "right 1 move_with holds it still until left 3 stack ends" in "\n".join(prog.lines())
    # with the object tracks: box_2 rests in exp1 from 5.1 s on, held still during the stack
    tracked = from_hand_labels(
        hold_labels(exp1.start_ns), exp1.start_ns, sides=("right", "left"), objects=exp1.objects
    )
    assert [p.kind for p in tracked.sync] == ["hold_until"]
    # box_3, carried in exp1 from 8.8 s, is not held still while the other hand stacks
    moving = [
        dataclasses.replace(lab, object={"box_2": "box_3", "box_3": "box_2"}.get(lab.object))
        for lab in hold_labels(exp1.start_ns)
    ]
    assert from_hand_labels(moving, exp1.start_ns, sides=("right", "left")).sync  # labels alone
    tracked = from_hand_labels(moving, exp1.start_ns, sides=("right", "left"), objects=exp1.objects)
    assert tracked.sync == []


def test_carry_and_idle_hand(exp1: lfd.Demonstration) -> None:
    """Both hands carrying box_2 at once is a carry point; a hand that only moves leaves the
    task to the other."""
    labels, _ = handover_labels(exp1.start_ns)
    carry = [lab for lab in labels if lab.hand == "right"]
    carry += [
        lfd.SkillLabel(lab.skill, lab.start_ns, lab.end_ns, lab.object, "left") for lab in carry
    ]
    prog = from_hand_labels(carry, exp1.start_ns, sides=("right", "left"))
    assert [(p.kind, p.hand, p.other, p.object) for p in prog.sync] == [
        ("carry", "left", "right", "box_2")
    ]
    idle = idle_left(exp1)
    prog = from_hand_labels(idle.labels, idle.start_ns, sides=idle.sides)
    assert prog.one_arm_side() == "right" and prog.sync == []
    assert [s.skill for s in prog.program("right").segments] == [lab.skill for lab in exp1.labels]


def test_from_hands_segmentation(exp1: lfd.Demonstration) -> None:
    """The program of lfd.segment_hands has a lane per hand, the segments of each."""
    both = lfd.segment_hands(idle_left(exp1))
    prog = from_hands(both, exp1.start_ns)
    assert set(prog.lanes) == {"right", "left"}
    assert [s.skill for s in prog.lanes["right"]] == both.lanes["right"].skill_sequence


def _saved(demo: lfd.Demonstration, path: Path) -> Path:
    """``demo`` written with lfd.save (both hands, labels per hand, handovers)."""
    lfd.save(demo, path)
    return path


def test_reproduce_refuses_a_two_hand_task_in_one_line(
    exp1: lfd.Demonstration,
    capsys: pytest.CaptureFixture[str],
    tmp_path: Path,
) -> None:
    from lfd.cli import main

    pytest.importorskip("mujoco")
    labels, handovers = handover_labels(exp1.start_ns)
    rec = _saved(busy_left(exp1, labels, handovers), tmp_path / "two.mcap")
    out = tmp_path / "r.json"
    assert main(["reproduce", str(rec), "--json", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("lfd reproduce: error: both hands handle objects")
    assert "--hand right or --hand left" in err[0]
    assert not out.exists()
    # the program is still printed (and written) on request, nothing simulated
    assert main(["reproduce", str(rec), "--program", "--json", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "left hand:" in printed and "handover of box_2" in printed
    assert json.loads(out.read_text())["program"]["sync"][0]["kind"] == "handover"
    # --program runs nothing: what only a run makes is refused, one line
    assert main(["reproduce", str(rec), "--program", "--rerun-save", str(tmp_path / "v.rrd")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        "lfd reproduce: error: --program prints the program and runs nothing; drop --rerun"
    ]
    # one hand's part, as a one-arm program
    assert main(["reproduce", str(rec), "--program", "--hand", "left"]) == 0
    steps = capsys.readouterr().out.splitlines()
    assert [line.split()[1] for line in steps] == [
        lab.skill for lab in labels if lab.hand == "left"
    ]
    assert main(["reproduce", str(EXP1), "--hand", "left"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"lfd reproduce: error: --hand left: {EXP1} has no left hand (it has the right)"]


def test_reproduce_runs_the_hand_that_does_it_all(exp1: lfd.Demonstration, tmp_path: Path) -> None:
    """The left hand only rests: the arm does the right hand's task, with the right hand's
    trajectory, as it does the one-hand recording."""
    from lfd.cli import main

    pytest.importorskip("mujoco")
    one, two = tmp_path / "one.json", tmp_path / "two.json"
    assert main(["reproduce", str(EXP1), "--json", str(one)]) == 0
    rec = _saved(idle_left(exp1), tmp_path / "two.mcap")
    rrd = tmp_path / "two.rrd"
    assert main(["reproduce", str(rec), "--json", str(two), "--rerun-save", str(rrd)]) == 0
    a, b = json.loads(one.read_text()), json.loads(two.read_text())
    if rrd.exists():  # the viewer (optional extra): both hands, the followed one's gripper
        from _rrd import Rrd

        data = Rrd(rrd)
        assert "/world/hand/left/keypoints" in data.rows
        assert "/world/hand/right/gripper" in data.rows and "/world/gripper" not in data.rows
    assert b["hands"]["reproduced"] == "right"
    assert b["program"] == a["program"]
    ra, rb = a["results"]["skills"], b["results"]["skills"]
    assert rb["success"] and rb["path_length_m"] == pytest.approx(ra["path_length_m"], rel=1e-9)


def test_program_of_the_segmentation(
    exp1: lfd.Demonstration, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    """``--program --segment`` of a two-hand recording: each hand's lane as lfd.segment_hands
    finds it, nothing simulated."""
    from lfd.cli import main

    rec = _saved(idle_left(exp1), tmp_path / "two.mcap")
    assert main(["reproduce", str(rec), "--program", "--segment"]) == 0
    out = capsys.readouterr().out.splitlines()
    both = lfd.segment_hands(lfd.load(rec))
    left = out.index("left hand:")
    assert out[0] == "right hand:" and left == 1 + len(both.lanes["right"].segments)
    steps = out[left + 1 : left + 1 + len(both.lanes["left"].segments)]
    assert [line.split()[1] for line in steps] == both.lanes["left"].skill_sequence
    assert out[left + 1 + len(steps) :][:1] in ([], ["synchronisation:"])
