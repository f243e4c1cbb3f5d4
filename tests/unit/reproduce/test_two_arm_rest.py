"""Where an idle arm waits in a two-arm sequence, how it comes to its next skill and how far a
plan reaches (lfd.reproduce.two_arm_sequence: rest_pose, transit_to_first, within_reach), on
lfd.sim's ``carry`` demonstration."""

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

BASES = {"right": np.array([0.45, 0.2, 0.0]), "left": np.array([-0.45, 0.2, 0.0])}


def _frames(side: str):  # type: ignore[no-untyped-def]
    from lfd.reproduce.aloha import aloha
    from lfd.reproduce.goals import DemoFrames

    from tests.unit.reproduce.test_two_arm_carry import _program

    trajs, hands = _program("carry", 3)
    return DemoFrames(trajs[side], BASES[side], aloha().ik), trajs, hands


def _gap(xy: np.ndarray, base: np.ndarray, pts: np.ndarray) -> float:
    """Distance from ``xy`` to the segments from ``base`` to every point."""
    d = pts[:, :2] - base[:2]
    w = np.clip(((xy - base[:2]) @ d.T) / (d * d).sum(axis=1), 0, 1)
    return float(np.min(np.hypot(*(base[:2] + w[:, None] * d - xy).T)))


def test_the_rest_is_near_its_base_away_from_where_the_other_arm_works() -> None:
    """The idle right arm rests REST_REACH from its base (at most halfway to the objects), over the objects, within 100 deg of
    the objects' direction and farther from the left arm's reach to the objects than straight
    towards them; the IK reaches it top-down."""
    from lfd.reproduce.aloha import aloha
    from lfd.reproduce.ik import gripper_rotation
    from lfd.reproduce.two_arm_bases import mount_yaw
    from lfd.reproduce.two_arm_sequence import (
        REST_FRACTION,
        REST_REACH,
        REST_Z,
        rest_pose,
    )
    from lfd.reproduce.two_arms import MountedIK

    f, _, _ = _frames("right")
    i = f.index(0.0)
    objs = np.array([f.object_pose(n, i)[:3, 3] for n in f.names])
    centre = objs.mean(axis=0)
    top = float(max(objs[:, 2] + f.size[:, 2] / 2))
    base, other = BASES["right"], BASES["left"]
    r = rest_pose(base, other, centre, top, f, objs)
    straight = rest_pose(base, None, centre, top, f)
    to = centre[:2] - base[:2]
    reach = min(REST_REACH, REST_FRACTION * float(np.hypot(*to)))
    assert np.hypot(*(r[:2] - base[:2])) == pytest.approx(reach)
    assert np.hypot(*(straight[:2] - base[:2])) == pytest.approx(reach)
    v = r[:2] - base[:2]
    angle = np.degrees(np.arccos(v @ to / np.linalg.norm(v) / np.linalg.norm(to)))
    assert angle <= 100.0 + 1e-6
    pts = np.vstack([objs, centre])
    assert _gap(r[:2], other, pts) >= _gap(straight[:2], other, pts) - 1e-9
    assert _gap(r[:2], other, pts) > 0.3
    assert r[2] >= REST_Z and r[2] - aloha().ik.finger_below_tcp >= top + 0.05 - 1e-9
    ik = MountedIK(base, mount_yaw(base, objs), aloha().ik)
    R = gripper_rotation(float(r[3]))
    ik.seed_towards(r[:3], R)
    ik.solve(r[:3], R)
    assert np.linalg.norm(ik.tcp_pose()[0] - r[:3]) < 0.005


def test_within_reach_pulls_far_points_in_and_keeps_near_ones() -> None:
    """A point 0.9 m from the base is pulled straight in to where the wrist is at the arm's
    reach from its shoulder; a point 0.3 m away is not moved; heights are kept."""
    from lfd.reproduce.aloha import aloha
    from lfd.reproduce.two_arm_sequence import within_reach

    arm = aloha().ik
    base = np.array([0.1, -0.2, 0.0])
    pts = np.array([[1.0, -0.2, 0.1], [0.1, 0.1, 0.05], [0.1 + 0.6, -0.2 + 0.6, 0.2]])
    out = within_reach(pts, base, arm)
    assert np.allclose(out[1], pts[1]) and np.allclose(out[:, 2], pts[:, 2])
    for k in (0, 2):
        wrist = np.array([*out[k, :2], out[k, 2] + arm.tcp_offset])
        shoulder = np.array([*base[:2], arm.shoulder_z])
        assert np.linalg.norm(wrist - shoulder) == pytest.approx(arm.reach[1], abs=1e-9)
        d0, d1 = pts[k, :2] - base[:2], out[k, :2] - base[:2]
        assert abs(d0[0] * d1[1] - d0[1] * d1[0]) < 1e-9 and d0 @ d1 > 0  # straight in


def test_transit_to_first_goes_over_then_down_above_the_object() -> None:
    """From the rest to above the big box's top (TRANSIT_CLEAR over it, fingertips), at the
    rest's height until over it, then straight down; the box where the robot's scene has it
    (moved from where the demonstration had it)."""
    from lfd.reproduce.goals import pose, upright
    from lfd.reproduce.two_arm_sequence import TRANSIT_CLEAR, transit_to_first

    f, _, hands = _frames("right")
    pick = next(s for s in hands.lanes["right"] if s.skill == "pick_up")
    T = upright(f.object_pose("big_box", f.index(pick.start_s)))
    scene = {"big_box": pose(T[:3, 3] + np.array([0.05, -0.04, 0.0]), 0.3)}
    cur = np.array([0.3, 0.25, 0.15, 0.0])
    path = transit_to_first(cur, pick, f, scene)
    size = f.size[f.object_index("big_box")]
    top = scene["big_box"][2, 3] + size[2] / 2
    assert np.allclose(path[0], cur)
    assert np.allclose(path[-1, :2], scene["big_box"][:2, 3])
    assert path[-1, 2] == pytest.approx(top + f.robot.finger_below_tcp + TRANSIT_CLEAR)
    high = max(cur[2], path[-1, 2])
    far = np.hypot(*(path[:, :2] - path[-1, :2]).T) > 1e-6
    k = int(np.argmax(path[:, 2] >= high - 1e-9))
    assert np.allclose(path[:k, :2], cur[:2])  # first straight up
    assert np.all(path[k:][far[k:], 2] >= high - 1e-9)  # then across at that height
    assert np.all(np.diff(path[~far, 2]) <= 1e-12)  # over it: only down


def test_a_carry_is_kept_clear_of_the_other_arms_base_but_not_its_skills() -> None:
    """Points of a carry nearer the other arm's base than the radius are pushed straight out
    to it; the skills' own ticks (``fixed``) are never moved and the radius is no more than
    their distance; points already clear are kept."""
    from lfd.reproduce.two_arm_sequence import OTHER_BASE_CLEAR, clear_of_base

    base = np.array([0.4, -0.1, 0.0])
    pts = np.array([[0.0, 0.0, 0.1], [0.25, -0.05, 0.25], [0.3, -0.1, 0.2], [0.0, -0.1, 0.05]])
    fixed = np.array([True, False, False, True])
    out = clear_of_base(pts, fixed, base, OTHER_BASE_CLEAR)
    assert np.allclose(out[fixed], pts[fixed]) and np.allclose(out[:, 2], pts[:, 2])
    for k in (1, 2):
        assert np.hypot(*(out[k, :2] - base[:2])) == pytest.approx(OTHER_BASE_CLEAR)
        d0, d1 = pts[k, :2] - base[:2], out[k, :2] - base[:2]
        assert abs(d0[0] * d1[1] - d0[1] * d1[0]) < 1e-12 and d0 @ d1 > 0
    # a skill 0.25 m from the base: the carry is kept at 0.25 m, no farther (the skill stays)
    near = pts.copy()
    near[3] = [0.15, -0.1, 0.05]
    out = clear_of_base(near, fixed, base, OTHER_BASE_CLEAR)
    assert np.allclose(out[3], near[3])
    assert np.hypot(*(out[2, :2] - base[:2])) == pytest.approx(0.25)
