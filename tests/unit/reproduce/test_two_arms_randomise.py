"""Two arms over randomised layouts (lfd.reproduce.two_arms_randomise) and the two arms'
contacts with each other and the table (lfd.reproduce.two_arms): on lfd's simulated two-hand
demonstrations."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from typing import Any

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


def _line(start: np.ndarray, end: np.ndarray, n: int):  # type: ignore[no-untyped-def]
    from lfd.reproduce.controller import Plan

    pos = start + np.linspace(0.0, 1.0, n)[:, None] * (end - start)
    return Plan(pos, np.zeros(n), np.full(n, 0.05), np.zeros(n, dtype=int))


def test_arms_driven_into_each_other_and_the_table_are_reported_naming_the_arm() -> None:
    """The links collide with the other arm and the table (not with the objects): two arms
    sent to the same point touch, an arm pushed below the table top touches it; each contact
    is reported once, naming the arm and its link, and the run is not achieved."""
    from lfd.reproduce.aloha import aloha
    from lfd.reproduce.two_arms import Collision, execute_two

    robot = aloha()
    bases = {"right": np.array([0.3, 0.0, 0.0]), "left": np.array([-0.3, 0.0, 0.0])}
    yaws = {"right": np.pi, "left": 0.0}
    meet = np.array([0.0, 0.0, 0.15])
    plans = {
        "right": _line(np.array([0.1, 0.0, 0.15]), meet, 150),
        "left": _line(np.array([-0.1, 0.0, 0.15]), meet, 150),
    }
    hits: list[Collision] = []
    execute_two(plans, bases, [], robot, yaws, settle_s=0.1, collisions=hits)
    assert [(c.other, c.arm) for c in hits][:1] in ([("left", "right")], [("right", "left")])
    assert "arm: collision: its" in hits[0].describe() and "arm's" in hits[0].describe()
    down = {"right": _line(np.array([0.1, 0.1, 0.1]), np.array([0.1, 0.1, -0.05]), 150)}
    hits = []
    execute_two(down, {"right": bases["right"]}, [], robot, {"right": np.pi}, collisions=hits)
    assert [(c.arm, c.other) for c in hits] == [("right", "table")]
    assert hits[0].describe().endswith(f"touched the table at {hits[0].t_s:.1f} s")


def test_a_held_box_is_put_down_relative_to_where_the_other_arm_pushes_its_neighbour() -> None:
    """The holding lane's place is re-grounded relative to the box the other hand pushed next
    to it: planned knowing where the other arm's push leaves that box (not where it started),
    the held box ends beside it as in the demonstration, displaced or not; undisplaced, it is
    put down where it was held (it was put 0.09 m away, onto the pushed box)."""
    from lfd.reproduce.aloha import aloha
    from lfd.reproduce.two_arms import plan_two_arms

    trajs, hands = _program("hold_push", 309)
    (hold,) = [p for p in hands.sync if p.kind == "hold_until"]
    held = hands.lanes[hold.hand][hold.step].object
    pushed = hands.lanes[hold.other][hold.other_step].object
    traj = trajs[hold.hand]
    names = list(traj.object_names)
    end = np.asarray(traj.object_position, dtype=np.float64)[:, -1, :2]
    demo = end[names.index(held)] - end[names.index(pushed)]
    for displace in ({}, {held: (0.03, -0.02, 20.0)}):
        plan = plan_two_arms(trajs, hands, "skills", robot=aloha(), displace=displace)
        got = plan.expected[held][:2, 3] - plan.expected[pushed][:2, 3]
        assert np.linalg.norm(got - demo) < 0.012, (displace, got, demo)
        if not displace:
            start = plan.planned[hold.hand][1][held][:2, 3]
            assert np.linalg.norm(plan.expected[held][:2, 3] - start) < 0.012


def test_a_layout_out_of_an_arms_reach_is_drawn_again_naming_the_arm() -> None:
    from lfd.reproduce.aloha import aloha
    from lfd.reproduce.randomise import _rejection_kind
    from lfd.reproduce.two_arms_randomise import check_two_arm_layout

    trajs, hands = _program("hold_push", 306)
    robot = aloha()
    ((side, pushed),) = [
        (s, g.object) for s, lane in hands.lanes.items() for g in lane if g.skill == "push"
    ]
    far = {pushed: (0.0, 0.8, 0.0)}
    why = check_two_arm_layout(trajs, hands, far, robot=robot, modes=("skills",))
    assert why is not None and "\n" not in why
    assert _rejection_kind(why) == f"out of the {side} arm's reach", why
    assert check_two_arm_layout(trajs, hands, {}, robot=robot, modes=("skills",)) is None


@pytest.mark.slow
def test_hold_push_over_randomised_layouts_on_two_arms() -> None:
    """Each layout re-grounds both lanes: the pushed box ends where its displaced start and the
    demonstrated push put it; every run gives the task's and each arm's success, and the
    document has the one-arm randomiser's shape."""
    from lfd.reproduce.two_arms_randomise import reproduce_two_arms_randomised

    trajs, hands = _program("hold_push", 306)
    done: list[tuple[int, int]] = []
    res = reproduce_two_arms_randomised(
        trajs, hands, 2, modes=("skills",), seed=5, progress=lambda i, n: done.append((i, n))
    )
    assert done == [(1, 2), (2, 2)]
    assert [lay.index for lay in res.layouts] == [0, 1]
    assert all(max(np.hypot(*d[:2]) for d in lay.displace.values()) > 0 for lay in res.layouts)
    for run in res.runs:
        assert run.arms is not None and set(run.arms) == {"right", "left"}
        assert run.success == (all(run.arms.values()) and not run.failures), run.failures
        assert {s["arm"] for s in run.skills} == {"right", "left"}
    assert res.success_rate("skills") == 1.0, [r.failures for r in res.runs]
    doc = res.to_json()
    assert doc["settings"]["robot"] == "aloha"
    (hold,) = [p for p in hands.sync if p.kind == "hold_until"]
    assert set(doc["summary"]["skills"]["skills"]) >= {f"{hold.other} push", f"{hold.hand} pick_up"}
    assert doc["layouts"][0]["results"]["skills"]["arms"] == {"right": True, "left": True}


def test_cli_randomise_on_two_arms_bad_input(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A one-hand recording, --displace or --video with --randomise: one line, exit 2,
    nothing written."""
    from lfd.cli import main

    one = tmp_path / "exp1.mcap"
    assert main(["simulate", "exp1", "--seed", "3", "-o", str(one)]) == 0
    carry = tmp_path / "carry.mcap"
    assert main(["simulate", "carry", "--seed", "3", "--style", "careful", "-o", str(carry)]) == 0
    capsys.readouterr()
    out = tmp_path / "r.json"
    for argv, words in (
        ([one, "--randomise", "3"], "takes a two-hand recording"),
        ([carry, "--randomise", "3", "--displace", "box_1:0.1,0"], "--displace"),
        ([carry, "--randomise", "3", "--video", str(tmp_path / "v.mp4")], "--video"),
    ):
        code = main(["reproduce", str(argv[0]), *argv[1:], "--robot", "aloha", "--json", str(out)])
        err = capsys.readouterr().err.strip().splitlines()
        assert code == 2 and len(err) == 1 and words in err[0], err
        assert err[0].startswith("lfd reproduce: error: ")
        assert not out.exists() and not (tmp_path / "v.mp4").exists()


@pytest.mark.slow
@pytest.mark.parametrize("task", ["carry", "hold_stack"])
def test_a_two_handed_carry_and_a_press_follow_their_displaced_object(task: str) -> None:
    """A two-handed carry (both arms press the wide box between them) and a hold by pressing
    (the plank too wide for a grasp) start from where a layout puts the object: the plan's
    scene has it there, both arms' plans go to it (not to where the person found it), and the
    run on the layout is achieved per arm and for the task."""
    from lfd.reproduce.aloha import aloha
    from lfd.reproduce.two_arms import plan_two_arms, run_two_arm_plan

    trajs, hands = _program(task, 4)
    robot = aloha()
    demo = plan_two_arms(trajs, hands, "skills", robot=robot)
    name = {"carry": "big_box", "hold_stack": "plank"}[task]
    spec = {o.name: o for o in demo.specs}[name]
    plan = plan_two_arms(trajs, hands, "skills", robot=robot, displace={name: (0.06, -0.04, 20)})
    moved = {o.name: o for o in plan.specs}[name]
    assert np.allclose(moved.position[:2] - spec.position[:2], [0.06, -0.04], atol=1e-6)

    def near(p: Any, xy: np.ndarray) -> float:  # the closest any arm's planned TCP comes
        return min(
            float(np.min(np.linalg.norm(p.plans[s].position[:, :2] - xy, axis=1))) for s in p.sides
        )

    # the arms come as close to the moved object as they came to it where the person found it
    assert near(plan, moved.position[:2]) < near(demo, spec.position[:2]) + 0.02
    run = run_two_arm_plan(plan, robot)
    assert run.success, run.failures


def test_crowding_is_measured_between_footprints() -> None:
    """Two arms keep 3 cm between the objects' footprints: a box 5 cm beside a 16 cm bar's side
    is room enough (one arm's circumscribed circles would call it 3 cm too close), 2 cm is not,
    and overlapping boxes are."""
    from types import SimpleNamespace

    from lfd.reproduce import randomise
    from lfd.reproduce.goals import pose
    from lfd.reproduce.two_arms_randomise import _crowded

    frames = SimpleNamespace(
        names=["bar", "box"], size=np.array([[0.16, 0.045, 0.045], [0.05, 0.05, 0.05]])
    )

    def scene(dy: float, yaw: float = 0.0) -> dict[str, np.ndarray]:
        return {
            "bar": pose(np.array([0.0, 0.0, 0.0225]), yaw),
            "box": pose(np.array([0.03, dy, 0.025]), 0.3),
        }

    far = 0.0225 + 0.05 + 0.025 * np.sqrt(2) * np.cos(np.pi / 4 - 0.3)  # 5 cm between the sides
    assert _crowded(frames, scene(far), 0.03) is None
    assert randomise._crowded(frames, scene(far), 0.03) is not None  # type: ignore[arg-type]
    near = _crowded(frames, scene(far - 0.03), 0.03)
    assert near is not None and "0.020 m apart" in near
    assert "overlapping" in (_crowded(frames, scene(0.03), 0.03) or "")
