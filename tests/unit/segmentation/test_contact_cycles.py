"""Contact rules on repeated pick-carry-place cycles (issue 41): one lift-off for the one-hand and
the two-hand segmentation, and every release (not only the last) where the hand lets go;
synthetic tracks with known contact times."""

from __future__ import annotations

import dataclasses
from itertools import pairwise

import numpy as np
from lfd.contact import ContactParams, lift_off, refine
from lfd.geometry import box_distance
from lfd.segmentation.cycles import (
    PUSHED_M,
    carries_by_contact,
    displacement,
    grasps_and_pushes,
    hovers_and_turns,
)
from lfd.segmentation.episodes import carries
from lfd.skills import Draft, allowed
from lfd.trajectory import Trajectory

SIZE = np.array([[0.06, 0.06, 0.06]])
REST = 0.03  # the cube's centre on the table


def _two_cycles(n: int = 400) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Two carries of one cube: lifted at 50 and set down by 110, the hand opening (thumb
    1 cm off the box) at 150 and leaving 3 cm up by 160, back on it at 200; lifted again at
    240, set down by 300, let go at 340."""
    t = np.arange(n)
    obj = np.zeros((1, n, 3))
    obj[0, :, 2] = REST
    for a in (50, 240):
        up = (t >= a) & (t < a + 60)
        obj[0, up, 2] += 0.12 * np.sin(np.pi * (t[up] - a) / 60)
    tcp = obj[0].copy()
    thumb = tcp.copy()
    for a, b in ((150, 200), (340, n)):
        off = (t >= a) & (t < b)
        thumb[off, 1] += 0.035 + 0.002 * np.minimum(t[off] - a, 10)  # thumb opens off the face
        tcp[off, 2] += 0.004 * np.minimum(t[off] - a, 15)  # the hand rises 6 cm
    quat = np.tile([0.0, 0.0, 0.0, 1.0], (1, n, 1))
    return tcp, thumb, obj, quat


def test_every_release_ends_where_the_hand_lets_go() -> None:
    tcp, thumb, obj, quat = _two_cycles()
    d_thumb = box_distance(thumb, obj[0], quat[0], SIZE[0])
    let_go = int(np.argmax(d_thumb > d_thumb[120] + ContactParams().release_thumb_m))
    assert 150 <= let_go <= 155
    # a search whose first Place ends early (at 125, the hand still on the cube)
    drafts = [
        Draft("pick_up", 0, 50, 0),
        Draft("move_with", 50, 100, 0),
        Draft("place", 100, 125, 0),
        Draft("move", 125, 230, 0),
        Draft("pick_up", 230, 240, 0),
        Draft("move_with", 240, 290, 0),
        Draft("place", 290, 400, 0),
    ]
    out = refine(drafts, tcp, thumb, obj, quat, SIZE)
    skills = [d.skill for d in out]
    assert skills[skills.index("place") + 1] == "move"
    first = out[skills.index("place")]
    assert first.end == let_go  # the release between the cycles: where the hand lets go
    assert out[-1].skill == "move" and 340 <= out[-1].start <= 345  # and the last one
    # a Place that the search ended late (the hand gone at 151) ends there too
    drafts[2], drafts[3] = Draft("place", 100, 180, 0), Draft("move", 180, 230, 0)
    out = refine(drafts, tcp, thumb, obj, quat, SIZE)
    assert out[[d.skill for d in out].index("place")].end == let_go


def _slow_lift(n: int = 200, start: int = 60) -> np.ndarray:
    """A cube's heights: resting (0.1 mm noise), then a slow start (1.5 mm per sample for 6
    samples: a grasp tilting and easing it off) and a quick rise to 20 cm."""
    rng = np.random.default_rng(4)
    z = REST + rng.normal(0.0, 0.0001, n)
    k = np.arange(n) - start
    z[k >= 0] += np.where(k[k >= 0] < 6, 0.0015 * k[k >= 0], 0.009 + 0.02 * (k[k >= 0] - 6))
    return np.minimum(z, REST + 0.2)


def _carry_scene(n: int = 200) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A hand resting on the cube from sample 30 (grasp) that lifts it slowly from 60
    (:func:`_slow_lift`), carries it (x) and keeps holding it to the end."""
    obj = np.zeros((1, n, 3))
    obj[0, :, 2] = _slow_lift(n)
    obj[0, 70:, 0] = 0.002 * np.arange(n - 70)
    tcp = obj[0].copy()
    tcp[:30, 0] -= np.linspace(0.2, 0.0, 30)
    quat = np.tile([0.0, 0.0, 0.0, 1.0], (1, n, 1))
    return tcp, obj, quat


def test_lift_off_is_where_the_object_last_rested_before_it_is_lifted() -> None:
    _, obj, _ = _carry_scene()
    # it starts to rise at 60 and has moved 1.5 mm (< 2 mm) in the 0.1 s before 61
    assert lift_off(obj[0], 20, 120) == 61
    assert lift_off(obj[0], 62, 120) == 62  # it never rested after 62
    obj[0, 58:60] = np.nan  # an unknown position is no rest: it rested last at 60
    assert lift_off(obj[0], 20, 120) == 60


def test_one_hand_and_two_hand_segmentation_share_the_lift_off() -> None:
    tcp, obj, quat = _carry_scene()
    drafts = [Draft("pick_up", 0, 100, 0), Draft("move_with", 100, 200, 0)]
    out = refine(drafts, tcp, tcp, obj, quat, SIZE, complete=False)
    expected = lift_off(obj[0], 0, 100)
    assert out[-2].skill == "pick_up" and out[-1].skill == "move_with"
    assert out[-1].start == expected
    # the two-hand path (episodes.carries): the same sample
    dist = box_distance(tcp, obj[0], quat[0], SIZE[0])
    spans = carries(dist, obj[0], REST, 1 / 30)
    assert ("move_with", expected) in [(s, a) for s, a, _ in spans]


def test_a_re_grasp_reaches_from_the_last_8_cm_or_just_after_the_release() -> None:
    tcp, thumb, obj, quat = _two_cycles()
    drafts = [
        Draft("pick_up", 0, 50, 0),
        Draft("move_with", 50, 100, 0),
        Draft("place", 100, 160, 0),
        Draft("move", 160, 180, 0),
        Draft("pick_up", 180, 240, 0),
        Draft("move_with", 240, 290, 0),
        Draft("place", 290, 400, 0),
    ]
    t = np.arange(len(tcp))
    # the hand rose 6 cm over the cube and stayed there until it came back down at 200: it
    # reaches from the end of its back-off
    out = refine(drafts, tcp, thumb, obj, quat, SIZE)
    skills = [d.skill for d in out]
    k = skills.index("move")
    assert out[k - 1].end == out[k].start and skills[k + 1] == "pick_up"
    assert out[k + 1].start == 200
    # a hand that stays at the cube (rises 1 cm, less than BACK_OFF_M farther than where it let
    # go): the shortest Move after the release
    stay = tcp.copy()
    near = (t >= 150) & (t < 200)
    stay[near, 2] = np.minimum(stay[near, 2], obj[0, near, 2] + 0.01)
    out = refine(drafts, stay, thumb, obj, quat, SIZE)
    assert [d.skill for d in out] == skills
    assert out[k - 1].end == out[k].start and out[k].end - out[k].start == ContactParams().min_move
    # a hand that went 10 cm up between the cycles reaches from where it was last 8 cm off
    away = (t >= 160) & (t < 220)
    tcp[away, 2] = obj[0, away, 2] + 0.03 + 0.1 * np.sin(np.pi * (t[away] - 160) / 60)
    out = refine(drafts, tcp, thumb, obj, quat, SIZE)
    d = box_distance(tcp, obj[0], quat[0], SIZE[0])
    last_far = 160 + int(np.flatnonzero(d[160:240] >= 0.08)[-1])
    assert out[k + 1].skill == "pick_up" and out[k + 1].start == last_far + 1


def _low_lift_trajectory() -> Trajectory:
    """30 Hz, 300 samples, one 6 cm cube: carried (15 cm up) over 30-80, lifted quick and low
    (6.6 cm, 0.37 s) over 120-131, carried again over 200-250; the hand at the cube from 5
    samples before each lift to 10 after its set-down, 10 cm off it otherwise."""
    n = 300
    t = np.arange(n)
    z = np.full(n, REST)
    for a, b, h in ((30, 80, 0.15), (120, 131, 0.066), (200, 250, 0.15)):
        k = (t >= a) & (t < b)
        z[k] += h * np.sin(np.pi * (t[k] - a) / (b - a))
    obj = np.stack([np.zeros(n), np.zeros(n), z], axis=1)
    held = np.zeros(n, dtype=bool)
    for a, b in ((25, 90), (115, 141), (195, 260)):
        held[a:b] = True
    tcp = obj + np.where(held, 0.0, 0.13)[:, None] * np.array([1.0, 0.0, 0.0])
    kp = np.repeat(tcp[:, None, :], 21, axis=1)
    return Trajectory(
        t_ns=(t * 1e9 / 30).astype(np.int64),
        tcp=tcp,
        rotation=np.tile(np.eye(3), (n, 1, 1)),
        euler=np.zeros((n, 3)),
        opening=np.full(n, 0.06),
        keypoints=kp,
        object_names=["cube"],
        object_position=obj[None],
        object_quaternion=np.tile([0.0, 0.0, 0.0, 1.0], (1, n, 1)),
        object_size=SIZE,
        hand_valid=np.ones(n, dtype=bool),
        object_valid=np.ones((1, n), dtype=bool),
    )


def _carry_spans(drafts: list[Draft]) -> list[tuple[int, int]]:
    return [(d.start, d.end) for d in drafts if d.skill == "move_with"]


def test_a_quick_low_lift_inside_a_pick_up_is_a_carry_of_its_own() -> None:
    traj = _low_lift_trajectory()
    absorbed = [
        Draft("move", 0, 20),
        Draft("pick_up", 20, 30, 0),
        Draft("move_with", 30, 80, 0),
        Draft("place", 80, 95, 0),
        Draft("move", 95, 105, 0),
        Draft("pick_up", 105, 200, 0),  # the low lift read as part of a long Pick up
        Draft("move_with", 200, 250, 0),
        Draft("place", 250, 270, 0),
        Draft("move", 270, 300),
    ]
    out = carries_by_contact(traj, absorbed)
    assert [d.skill for d in out].count("move_with") == 3
    assert any(a <= 125 < b for a, b in _carry_spans(out))
    assert all(allowed(a.skill, b.skill) for a, b in pairwise(out))
    assert out[0].start == 0 and out[-1].end == 300
    assert all(a.end == b.start for a, b in pairwise(out))
    # two carries read as one Move with are two
    shared = [*absorbed[:5], Draft("pick_up", 105, 120, 0), Draft("move_with", 120, 250, 0)]
    shared += absorbed[7:]
    out = carries_by_contact(traj, shared)
    spans = _carry_spans(out)
    assert len(spans) == 3 and not any(a <= 125 < b and a <= 225 < b for a, b in spans)
    assert all(allowed(a.skill, b.skill) for a, b in pairwise(out))
    # one to one already: nothing changes (the search keeps its drafts)
    right = [*absorbed[:5], Draft("pick_up", 105, 120, 0), Draft("move_with", 120, 131, 0)]
    right += [Draft("place", 131, 145, 0), Draft("move", 145, 190, 0)]
    right += [Draft("pick_up", 190, 200, 0), *absorbed[6:]]
    assert carries_by_contact(traj, right) == right


def test_a_hover_before_a_grasp_is_a_move_and_a_turn_before_it_part_of_the_pick_up() -> None:
    traj = _low_lift_trajectory()  # the hand at the cube over 25-90 (held), 10 cm off before
    hover = [Draft("move", 0, 10), Draft("locate", 10, 22, 0), Draft("pick_up", 22, 35, 0)]
    hover += [Draft("move_with", 35, 80, 0), Draft("place", 80, 300, 0)]
    out = hovers_and_turns(traj, hover, 0.08)
    assert [(d.skill, d.start, d.end) for d in out][:2] == [("move", 0, 22), ("pick_up", 22, 35)]
    # a Locate before a Pick up of another object stays
    other = [*hover[:2], Draft("pick_up", 22, 35, 1), *hover[3:]]
    assert [d.skill for d in hovers_and_turns(traj, other, 0.08)][1] == "locate"
    # a Push, then a Pick up of the same cube, the hand staying at it: one Pick up
    turn = [Draft("move", 0, 26), Draft("push", 26, 40, 0), Draft("move", 40, 45, 0)]
    turn += [Draft("pick_up", 45, 50, 0), *hover[3:]]
    out = hovers_and_turns(traj, turn, 0.08)
    assert [(d.skill, d.start, d.end) for d in out][:2] == [("move", 0, 26), ("pick_up", 26, 50)]
    # the hand 10 cm off between them: a Push, then a reach
    away = [Draft("move", 0, 5), Draft("push", 5, 15, 0), Draft("move", 15, 26, 0)]
    away += [Draft("pick_up", 26, 35, 0), *hover[3:]]
    assert hovers_and_turns(traj, away, 0.08) == away


def test_a_grasp_is_of_the_object_it_lifts_and_a_push_moves_its_object() -> None:
    traj = _low_lift_trajectory()  # one cube, at rest over 90-115 and 141-195
    two = dataclasses.replace(
        traj,
        object_names=["cube", "other"],
        object_position=np.concatenate([traj.object_position, traj.object_position + 0.3]),
        object_quaternion=np.concatenate([traj.object_quaternion] * 2),
        object_size=np.concatenate([SIZE, SIZE]),
        object_valid=np.ones((2, len(traj)), dtype=bool),
    )
    # a Pick up of the other object followed by the Move with of the cube: a Pick up of the cube
    wrong = [Draft("move", 0, 20), Draft("pick_up", 20, 30, 1), Draft("move_with", 30, 80, 0)]
    wrong += [Draft("place", 80, 300, 0)]
    out = grasps_and_pushes(two, wrong)
    assert [(d.skill, d.obj) for d in out][1:3] == [("pick_up", 0), ("move_with", 0)]
    # a Push of the resting cube (it stays where it is): a Move, joined to its neighbours
    still = [Draft("move", 0, 92), Draft("push", 92, 108, 0), Draft("move", 108, 116)]
    still += [Draft("pick_up", 116, 120, 0), Draft("move_with", 120, 131, 0)]
    still += [Draft("place", 131, 300, 0)]
    out = grasps_and_pushes(two, still)
    assert (out[0].skill, out[0].start, out[0].end) == ("move", 0, 116)
    # a Push over which the cube moves (it is lifted at 120): kept
    moved = [Draft("move", 0, 92), Draft("push", 92, 125, 0), Draft("move", 125, 300)]
    assert grasps_and_pushes(two, moved) == moved
    assert displacement(traj.object_position[0], 92, 125) >= PUSHED_M
    assert displacement(np.full((5, 3), np.nan), 0, 5) == 0.0
