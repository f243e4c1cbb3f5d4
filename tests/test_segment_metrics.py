"""Segmentation metrics on hand-made label sequences."""

import math

import pytest
from lfd.demo import SkillLabel
from lfd.segmentation.metrics import (
    all_metrics,
    boundary_error,
    edit_distance,
    f1_at,
    frame_accuracy,
    sequence_match,
)

S = 1_000_000_000


def labels(*spec: tuple[str, float, float]) -> list[SkillLabel]:
    return [SkillLabel(k, int(a * S), int(b * S)) for k, a, b in spec]


TRUTH = labels(("pick_up", 0, 2), ("move_with", 2, 5), ("place", 5, 6), ("move", 6, 10))


def test_identical_segmentation_is_perfect() -> None:
    m = all_metrics(TRUTH, TRUTH)
    assert m == {
        "sequence_match": 1.0,
        "edit_distance": 0.0,
        "frame_accuracy": 1.0,
        "boundary_error_s": 0.0,
        "f1@10": 1.0,
        "f1@25": 1.0,
        "f1@50": 1.0,
    }


def test_shifted_boundaries() -> None:
    pred = labels(("pick_up", 0, 2.5), ("move_with", 2.5, 5), ("place", 5, 6.5), ("move", 6.5, 10))
    assert sequence_match(pred, TRUTH)
    assert boundary_error(pred, TRUTH) == pytest.approx((0.5 + 0 + 0.5) / 3)
    assert frame_accuracy(pred, TRUTH) == pytest.approx(0.9, abs=0.002)
    # place: IoU 1 / 1.5 = 0.67 -> still a hit at 50 %
    assert f1_at(pred, TRUTH, 0.5) == 1.0


def test_wrong_and_missing_skills() -> None:
    # place missed (merged into move_with), and move_with called move
    pred = labels(("pick_up", 0, 2), ("move", 2, 6), ("move", 6, 10))
    assert not sequence_match(pred, TRUTH)
    assert edit_distance(pred, TRUTH) == pytest.approx(2 / 4)
    assert frame_accuracy(pred, TRUTH) == pytest.approx(0.6, abs=0.002)
    # tp: pick_up, move(6-10); fp: move(2-6); fn: move_with, place
    p, r = 2 / 3, 2 / 4
    assert f1_at(pred, TRUTH, 0.5) == pytest.approx(2 * p * r / (p + r))
    assert boundary_error(pred, TRUTH) == pytest.approx((0 + 1 + 0) / 3)


def test_edge_cases() -> None:
    one = labels(("move", 0, 3))
    assert boundary_error(one, one) == 0.0
    assert math.isinf(boundary_error(one, TRUTH))
    assert edit_distance([], []) == 0.0
    assert f1_at([], TRUTH, 0.1) == 0.0
    with pytest.raises(ValueError):
        frame_accuracy(TRUTH, [])
