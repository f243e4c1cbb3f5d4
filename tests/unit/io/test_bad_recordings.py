"""Recordings that load but cannot be segmented as they are (docs/cli.md, "Recordings lfd
cannot segment as they are"): an object without a size, a hand that never comes near any object,
objects that never move. Each made from the shipped simulated ``recordings/exp1.mcap`` with one
thing changed, and run through ``lfd info``, ``segment``, ``eval`` and ``reproduce --segment``.

What each command does (exit status, what stderr says) is the table of docs/cli.md:

=================  ============================  ===============================================
recording          info                          segment / eval / reproduce --segment
=================  ============================  ===============================================
no object size     0, a warning per object       0, the same warnings (the 5 cm default cube)
hand reaches none  0, one warning                2, one error line (eval: ``error: PATH: ...``)
objects never move 0, warning (ground truth has  segment, eval: 0, the result and one warning;
                   skills that move one)         reproduce --segment: 2, one error line
=================  ============================  ===============================================
"""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
from pathlib import Path

import _paths
import lfd
import numpy as np
import pytest
from lfd.io.checks import (
    MOVED_M,
    NEAR_M,
    check_hand_reaches,
    closest_approach,
    object_travel,
    unmoved_objects_message,
)
from test_object_sizes import strip_sizes

ROOT = _paths.ROOT
EXP1 = ROOT / "recordings" / "exp1.mcap"
AWAY = np.array([1.5, 1.5, 0.0])  # every object moved this far: the hand reaches none


def _moved(demo: lfd.Demonstration, offset: np.ndarray) -> lfd.Demonstration:
    objects = {
        n: dataclasses.replace(o, position=o.position + offset) for n, o in demo.objects.items()
    }
    return dataclasses.replace(demo, objects=objects)


def _frozen(demo: lfd.Demonstration) -> lfd.Demonstration:
    """Every object held at its first pose: the hand grasps and carries nothing."""
    objects = {
        n: dataclasses.replace(
            o,
            position=np.repeat(o.position[:1], len(o), axis=0),
            quaternion=np.repeat(o.quaternion[:1], len(o), axis=0),
        )
        for n, o in demo.objects.items()
    }
    return dataclasses.replace(demo, objects=objects)


@pytest.fixture(scope="module")
def bad(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    out = tmp_path_factory.mktemp("bad")
    demo = lfd.load(EXP1, images=False)
    paths = {
        "nosize": strip_sizes(EXP1, out / "nosize.mcap"),
        "far": out / "far.mcap",
        "static": out / "static.mcap",
        "far_static": out / "far_static.mcap",
    }
    lfd.save(_moved(demo, AWAY), paths["far"])
    lfd.save(_frozen(demo), paths["static"])
    lfd.save(_moved(_frozen(demo), AWAY), paths["far_static"])
    return paths


def _cli(*argv: str | Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "lfd.cli", *map(str, argv)],
        capture_output=True,
        text=True,
        timeout=600,
    )


def _lines(proc: subprocess.CompletedProcess[str], *, tables: bool = False) -> list[str]:
    """stderr's lines; with ``tables`` (``--json -`` puts the tables on stderr) only lfd's own."""
    assert "Traceback" not in proc.stderr, proc.stderr
    lines = [line for line in proc.stderr.splitlines() if line.strip()]
    return [line for line in lines if line.startswith("lfd ")] if tables else lines


# --- the library checks ---------------------------------------------------------------------
def test_checks_on_the_shipped_recordings() -> None:
    """Every shipped recording passes: the hand touches a box, and the skills that move one
    come with a box that moves (the Locate and Move template demos move none, and need not)."""
    for path in sorted((ROOT / "recordings").glob("**/*.mcap")):
        demo = lfd.load(path, images=False)
        if not demo.objects:
            continue
        assert closest_approach(demo).distance_m < NEAR_M, path
        check_hand_reaches(demo)
        assert unmoved_objects_message(demo, demo.skill_sequence) is None, path


def test_checks_see_the_bad_recordings(bad: dict[str, Path]) -> None:
    far = lfd.load(bad["far"], images=False)
    near = closest_approach(far)
    assert near.distance_m > 1.0 and near.object in far.objects
    with pytest.raises(lfd.errors.DemonstrationError, match=r"never comes within 0\.15 m"):
        check_hand_reaches(far)
    assert max(object_travel(far).values()) > 0.1  # its boxes still move: exp1's carries
    static = lfd.load(bad["static"], images=False)
    assert closest_approach(static).distance_m < 0.01
    assert max(object_travel(static).values()) < MOVED_M
    assert unmoved_objects_message(static, ["move", "locate", "pick_up"]) is None
    msg = unmoved_objects_message(static, ["pick_up", "move_with", "place", "move_with"])
    assert msg is not None and "move_with, place, which move one" in msg


def test_one_misdetected_tag_is_not_motion() -> None:
    demo = _frozen(lfd.load(EXP1, images=False))
    o = next(iter(demo.objects.values()))
    o.position[40] += 0.3  # one sample 30 cm off
    assert max(object_travel(demo).values()) < MOVED_M


# --- the commands ---------------------------------------------------------------------------
@pytest.mark.parametrize("case", ["far", "far_static"])
@pytest.mark.parametrize(
    "command", [("segment",), ("eval",), ("reproduce", "--segment", "--mode", "skills")]
)
def test_hand_reaching_no_object_is_one_error_line(
    bad: dict[str, Path], case: str, command: tuple[str, ...]
) -> None:
    """Before: exit 0 with a Push of a box 1.5 m from the hand (reproduce: 1 or even 0)."""
    proc = _cli(command[0], bad[case], *command[1:])
    lines = _lines(proc)
    assert proc.returncode == 2, proc.stderr
    assert len(lines) == 1, lines
    where = f"{bad[case]}: " if command[0] == "eval" else ""
    assert lines[0].startswith(f"lfd {command[0]}: error: {where}the hand never comes within")
    assert "frame and unit" in lines[0]


def test_hand_reaching_no_object_in_a_batch(bad: dict[str, Path], tmp_path: Path) -> None:
    """Many recordings: the bad one is one error line, the others are segmented, exit 2."""
    out = tmp_path / "seg.json"
    proc = _cli("segment", bad["far"], EXP1, "--json", out, "--jobs", "1")
    assert proc.returncode == 2
    errors = [line for line in _lines(proc) if ": error: " in line]
    assert len(errors) == 1 and errors[0].startswith(f"lfd segment: error: {bad['far']}: the hand")
    doc = json.loads(out.read_text())
    assert "the hand never comes" in doc[0]["error"] and len(doc[1]["segments"]) > 3


def test_info_warns_about_a_hand_reaching_no_object(bad: dict[str, Path]) -> None:
    proc = _cli("info", bad["far"], "--check", "--json", "-")
    assert proc.returncode == 0
    lines = _lines(proc, tables=True)
    assert len(lines) == 1 and lines[0].startswith("lfd info: warning: the hand never comes")
    doc = json.loads(proc.stdout)
    assert doc["warnings"] == [] and lines[0].endswith(doc["problems"][0])
    assert doc["hand_approach"]["distance_m"] > 1.0
    assert {o["name"]: o["travel_m"] > 0.1 for o in doc["objects"]}["box_2"]


def test_objects_that_never_move_segment_with_one_warning(bad: dict[str, Path]) -> None:
    """Before: the same result and no warning at all."""
    proc = _cli("segment", bad["static"], "--json", "-")
    assert proc.returncode == 0
    lines = _lines(proc, tables=True)
    assert len(lines) == 1, lines
    assert lines[0].startswith("lfd segment: warning: no object moves (at most 0.0 mm), yet ")
    doc = json.loads(proc.stdout)
    assert doc["segments"] and doc["warnings"][-1] in lines[0]
    proc = _cli("eval", bad["static"], "--methods", "dp")
    assert proc.returncode == 0
    lines = _lines(proc)
    assert len(lines) == 1 and lines[0].startswith(f"lfd eval: warning: {bad['static'].name}: no")


def test_objects_that_never_move_are_not_reproduced(bad: dict[str, Path]) -> None:
    """Before: the robot picked and placed boxes the demonstrator never moved (exit 1, with
    collisions)."""
    proc = _cli("reproduce", bad["static"], "--segment", "--mode", "skills")
    assert proc.returncode == 2
    lines = _lines(proc)
    assert len(lines) == 1 and lines[0].startswith("lfd reproduce: error: not reproduced: no ")
    proc = _cli("info", bad["static"], "--check")
    assert proc.returncode == 0
    lines = _lines(proc)
    assert len(lines) == 1 and "yet the ground truth has move_with, place, stack" in lines[0]


@pytest.mark.parametrize("command", [("info",), ("segment",), ("eval", "--methods", "dp")])
def test_object_without_size_is_a_warning_per_object(
    bad: dict[str, Path], command: tuple[str, ...]
) -> None:
    proc = _cli(command[0], bad["nosize"], *command[1:])
    assert proc.returncode == 0
    lines = _lines(proc)
    assert len(lines) == 3 and all(
        line.startswith(f"lfd {command[0]}: warning: object box_") and "has no size" in line
        for line in lines
    )


@pytest.mark.slow
def test_object_without_size_is_reproduced_with_the_default_cube(bad: dict[str, Path]) -> None:
    """The robot runs on 5 cm cubes (warned); a stack off target is a failed result (1), not
    an error."""
    proc = _cli("reproduce", bad["nosize"], "--segment", "--mode", "skills")
    assert proc.returncode in (0, 1), proc.stderr
    warned = [line for line in _lines(proc) if "has no size" in line]
    assert len(warned) == 3


def test_checks_see_either_hand() -> None:
    """Two hands where only the left one reaches the boxes (the right one 2 m away): the hand
    reaches an object, the left one, and ``lfd info`` would say which; not "never comes
    within" as a check of the right hand alone said."""
    from _two_hands import left_of

    demo = lfd.load(ROOT / "recordings" / "exp1.mcap", images=False)
    away = dataclasses.replace(demo.hand, keypoints=demo.hand.keypoints + np.array([2.0, 0, 0]))
    two = dataclasses.replace(demo, hand=away, other_hand=left_of(demo.hand, dx=0.0), labels=[])
    near = closest_approach(two)
    assert near.hand == "left" and near.distance_m < 0.01
    check_hand_reaches(two)
    alone = dataclasses.replace(demo, hand=away, labels=[])
    assert closest_approach(alone).hand == "right" and closest_approach(alone).distance_m > 1.0
