"""Contact rules (lfd.contact): where a Pick up, a carry and a release begin and end, on synthetic
motion with known contact times, and on real motion capture when it is present."""

from __future__ import annotations

import math

import _paths
import lfd
import numpy as np
import pytest
from lfd.contact import ContactParams, box_distance, refine
from lfd.skills import Draft

SIZE = np.array([[0.06, 0.06, 0.06]])
REALMOTION = _paths.SHARED / "realmotion"


def test_box_distance_is_zero_inside_and_euclidean_outside() -> None:
    q = np.array([[0.0, 0.0, math.sin(math.pi / 8), math.cos(math.pi / 8)]] * 3)  # 45 deg yaw
    c = np.zeros((3, 3))
    pts = np.array([[0.01, 0.0, 0.0], [0.0, 0.0, 0.13], [0.1, 0.1, 0.0]])
    d = box_distance(pts, c, q, SIZE[0])
    assert d[0] == 0.0
    assert d[1] == pytest.approx(0.10)
    # (0.1, 0.1) lies on the turned box's local x axis, at 0.1414 from its centre
    assert d[2] == pytest.approx(math.hypot(0.1, 0.1) - 0.03)
    assert np.isnan(box_distance(pts[:1], c[:1], np.zeros((1, 4)), SIZE[0])).all()


def _scene(n: int = 300) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A hand that comes from 20 cm away (reaching 8 cm at sample 60), grasps a 6 cm cube, lifts it
    from sample 100, carries it, sets it down at sample 200, lets go at 230 and leaves."""
    t = np.arange(n)
    obj = np.zeros((1, n, 3))
    obj[0, :, 2] = 0.03
    lift = (t >= 100) & (t < 200)
    obj[0, lift, 2] += 0.15 * np.sin(np.pi * (t[lift] - 100) / 100)
    obj[0, lift, 0] += 0.2 * (t[lift] - 100) / 100
    obj[0, t >= 200, 0] = 0.2
    tcp = obj[0].copy()
    dist = np.interp(t, [0, 60, 80], [0.2, 0.08 + 0.03, 0.0])  # from the centre: box 3 cm
    tcp[:, 0] -= dist
    away = t >= 230
    tcp[away, 2] += 0.005 * (t[away] - 229)
    thumb = tcp.copy()
    quat = np.tile([0.0, 0.0, 0.0, 1.0], (1, n, 1))
    return tcp, thumb, obj, quat


def _drafts(*spans: tuple[str, int, int, int | None]) -> list[Draft]:
    """Drafts of ``(skill, start, end, object)``, each with a score of its own (its index)."""
    return [Draft(*span, score=float(k)) for k, span in enumerate(spans)]


def _refine(drafts: list[Draft], *args: object, **kwargs: object) -> list[tuple]:
    """:func:`refine`'s drafts as ``(skill, start, end, object)``; the drafts given unchanged."""
    before = [(d.span, d.score) for d in drafts]
    out = refine(drafts, *args, **kwargs)  # type: ignore[arg-type]
    assert [(d.span, d.score) for d in drafts] == before
    return [d.span for d in out]


def test_refine_puts_every_boundary_at_its_contact_event() -> None:
    tcp, thumb, obj, quat = _scene()
    # what a search might give: no leading Move, late lift, early set-down, no final Move
    drafts = _drafts(("pick_up", 0, 120, 0), ("move_with", 120, 180, 0), ("place", 180, 300, 0))
    refined = refine(drafts, tcp, thumb, obj, quat, SIZE)
    out = [d.span for d in refined]
    skills = [s for s, *_ in out]
    assert skills == ["move", "pick_up", "move_with", "place", "move"]
    # the drafts keep their scores; the Moves inserted have none
    assert [d.score for d in refined][1:4] == [0.0, 1.0, 2.0]
    assert math.isnan(refined[0].score) and math.isnan(refined[-1].score)
    (_, _, b0, _), (_, a1, b1, _), (_, a2, b2, _), (_, a3, b3, _), (_, a4, b4, o4) = out
    assert b0 == a1 and abs(a1 - 61) <= 1  # the last sample 8 cm away is 60
    assert b1 == a2 and 97 <= a2 <= 101  # the object starts to rise at 100
    rest_5cm = 200 - 100 / np.pi * np.arcsin(0.05 / 0.15)  # the last time 5 cm up
    assert b2 == a3 and abs(a3 - rest_5cm) <= 2
    assert b3 == a4 and 230 <= a4 <= 238 and b4 == 300 and o4 is None  # TCP 3 cm off by 235
    # a refined segmentation is a fixed point
    assert _refine(refined, tcp, thumb, obj, quat, SIZE) == out


def test_a_last_pick_up_that_never_lifts_is_part_of_the_move() -> None:
    tcp, thumb, obj, quat = _scene()
    obj[0, 100:] = obj[0, 99]  # the object never leaves the table
    drafts = _drafts(("move", 0, 150, 0), ("pick_up", 150, 300, 0))
    assert _refine(drafts, tcp, thumb, obj, quat, SIZE) == [("move", 0, 300, 0)]


def test_a_first_move_that_never_left_the_object_is_part_of_the_pick_up() -> None:
    tcp, thumb, obj, quat = _scene()
    tcp[:80] = tcp[80]  # the hand is at the object from the start
    drafts = _drafts(("move", 0, 40, None), ("pick_up", 40, 120, 0), ("move_with", 120, 300, 0))
    out = _refine(drafts, tcp, thumb, obj, quat, SIZE, ContactParams())
    assert [s for s, *_ in out][:2] == ["pick_up", "move_with"]
    assert out[0][1] == 0


@pytest.mark.skipif(not REALMOTION.is_dir(), reason=f"no real motion capture at {REALMOTION}")
def test_real_crops_segment_at_their_contact_events() -> None:
    """The default segmentation of the eight one-hand crops of real motion capture (never copied
    into the repository): at least 6 exact skill sequences and 0.9 mean frame accuracy
    (docs/segmentation.md "Real motion capture"; 7/8 and 0.956 when this was written)."""
    from lfd.segmentation.metrics import all_metrics

    crops = sorted(REALMOTION.glob("manip_*_*s.mcap"))
    assert len(crops) == 8
    exact, frames = 0, []
    for path in crops:
        demo = lfd.load(path)
        result = lfd.segment(demo)
        exact += result.skill_sequence == demo.skill_sequence
        frames.append(all_metrics(result.segments, demo.labels)["frame_accuracy"])
    assert exact >= 6
    assert np.mean(frames) >= 0.9


@pytest.mark.parametrize(
    "bad", [{"approach_m": float("nan")}, {"lift_m": -0.01}, {"min_move": 0}, {"rest_samples": 1.5}]
)
def test_bad_contact_parameters_are_refused(bad: dict[str, float]) -> None:
    from lfd.errors import InvalidParameterError

    with pytest.raises(InvalidParameterError, match="contacts"):
        ContactParams(**bad)  # type: ignore[arg-type]
