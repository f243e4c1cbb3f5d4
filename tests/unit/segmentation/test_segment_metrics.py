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


def lev(a: list[str], b: list[str]) -> int:
    """The edit distance by its definition (the full table, one row at a time)."""
    prev = list(range(len(b) + 1))
    for i, x in enumerate(a, 1):
        cur = [i]
        for j, y in enumerate(b, 1):
            cur.append(min(prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (x != y)))
        prev = cur
    return prev[-1]


@pytest.mark.parametrize("seed", range(4))
def test_edit_distance_equals_the_full_table(seed: int) -> None:
    # long sequences (columns of many 64-bit words), few and many symbols, one side empty
    import random

    rng = random.Random(seed)
    skills = ["pick_up", "place", "locate", "stack", "push", "move", "move_with"]
    for _ in range(60):
        k = rng.randint(1, len(skills))
        a = [rng.choice(skills[:k]) for _ in range(rng.randint(0, 300))]
        b = [rng.choice(skills[:k]) for _ in range(rng.randint(0, 300))]
        if not a and not b:
            continue
        pred = [SkillLabel(s, n, n + 1) for n, s in enumerate(a)]
        truth = [SkillLabel(s, n, n + 1) for n, s in enumerate(b)]
        assert edit_distance(pred, truth) == lev(a, b) / max(len(a), len(b)), (a, b)


def _naive(pred: list[SkillLabel], truth: list[SkillLabel]) -> dict[str, float]:
    """The metrics by their definitions, quadratic (the reference for the linear versions)."""
    import numpy as np

    def at(spans: list[SkillLabel], t: np.ndarray) -> np.ndarray:
        out = np.full(t.shape, "", dtype=object)
        for s in spans:
            out[(t >= s.start_ns) & (t < s.end_ns)] = s.skill
        if spans:
            out[t == spans[-1].end_ns] = spans[-1].skill
        return out

    def f1(iou: float) -> float:
        matched, tp = [False] * len(truth), 0
        for p in pred:
            best, best_j = 0.0, -1
            for j, t in enumerate(truth):
                if t.skill != p.skill:
                    continue
                inter = min(p.end_ns, t.end_ns) - max(p.start_ns, t.start_ns)
                union = max(p.end_ns, t.end_ns) - min(p.start_ns, t.start_ns)
                v = inter / union if union > 0 else 0.0
                if v > best:
                    best, best_j = v, j
            if best_j >= 0 and best >= iou and not matched[best_j]:
                matched[best_j] = True
                tp += 1
        prec, rec = tp / len(pred), tp / len(truth)
        return 0.0 if prec + rec == 0 else 2 * prec * rec / (prec + rec)

    t = np.arange(truth[0].start_ns, truth[-1].end_ns + 1, 10_000_000, dtype=np.int64)
    want, got = at(truth, t), at(pred, t)
    keep = want != ""
    wb = np.array([s.start_ns for s in truth[1:]], dtype=np.float64) * 1e-9
    gb = np.array([s.start_ns for s in pred[1:]], dtype=np.float64) * 1e-9
    a, b = [s.skill for s in pred], [s.skill for s in truth]
    return {
        "sequence_match": float(a == b),
        "edit_distance": lev(a, b) / max(len(a), len(b)),
        "frame_accuracy": float(np.mean(want[keep] == got[keep])),
        "boundary_error_s": float(np.mean(np.min(np.abs(wb[:, None] - gb[None, :]), axis=1))),
        "f1@10": f1(0.10),
        "f1@25": f1(0.25),
        "f1@50": f1(0.50),
    }


@pytest.mark.parametrize("seed", range(6))
def test_linear_metrics_equal_their_quadratic_definitions(seed: int) -> None:
    import numpy as np

    rng = np.random.default_rng(seed)
    skills = ["pick_up", "move_with", "place", "move"]

    def spans(n: int, gaps: bool) -> list[SkillLabel]:
        ends = np.cumsum(rng.integers(1, 40, 2 * n)) * 50_000_000
        out = []
        for k in range(n):
            a, b = (ends[2 * k], ends[2 * k + 1]) if gaps else (ends[2 * k - 1] if k else 0, ends[2 * k + 1])  # fmt: skip
            out.append(SkillLabel(skills[int(rng.integers(0, 4))], int(a), int(b)))
        return out

    truth = spans(int(rng.integers(2, 60)), gaps=seed % 2 == 1)
    pred = spans(int(rng.integers(2, 60)), gaps=False)
    if seed == 5:  # out of time order: the f1 window does not apply
        truth = truth[::-1]
        truth.sort(key=lambda s: s.end_ns - s.start_ns)
        truth = [*truth[1:], truth[0]]
    got, want = all_metrics(pred, truth), _naive(pred, truth)
    assert got == want


# --- excluded spans (another hand handles the object) ----------------------------------------
def test_excluded_spans_from_metadata() -> None:
    from lfd.errors import DemonstrationError
    from lfd.segmentation.metrics import excluded_spans

    t0 = 5 * S  # seconds count from the recording's first sample
    meta = {"other_hand_spans": [[2.0, 3.0], [2.5, 4.0]], "shared_spans": [[0.0, 1.0], [7, 7]]}
    assert excluded_spans(meta, t0) == [(t0, t0 + S), (t0 + 2 * S, t0 + 4 * S)]
    assert excluded_spans({"other_hand_spans": [], "task": "x"}, t0) == []
    for bad in ([[1.0]], [[2.0, 1.0]], [["a", 1.0]], "1-2", [[0.0, float("nan")]]):
        with pytest.raises(DemonstrationError, match="other_hand_spans"):
            excluded_spans({"other_hand_spans": bad}, t0)


def test_restrict_cuts_drops_and_merges() -> None:
    from lfd.segmentation.metrics import restrict

    ex = [(3 * S, 4 * S), (7 * S, 8 * S)]
    spans = labels(
        ("move", 0, 3.5),  # ends inside: cut to 3
        ("pick_up", 3.5, 3.9),  # wholly inside: dropped
        ("move", 3.9, 6),  # starts inside: from 4, merged with the first move
        ("move", 6, 7.5),  # touches the previous one outside the spans: stays apart
        ("place", 7.5, 10),  # from 8
    )
    got = [(s.skill, s.start_ns / S, s.end_ns / S) for s in restrict(spans, ex)]
    assert got == [("move", 0, 6), ("move", 6, 7), ("place", 8, 10)]
    assert restrict(spans, []) == [
        SkillLabel(s.skill, s.start_ns, s.end_ns, s.object) for s in spans
    ]


def test_metrics_leave_the_excluded_spans_out() -> None:
    from lfd.segmentation.metrics import segment_ratio

    ex = [(6 * S, 8 * S)]
    truth = labels(("pick_up", 0, 2), ("move_with", 2, 5), ("place", 5, 6), ("move", 6, 10))
    # the other hand's time (6-8 s) holds a wrong Push; outside it the prediction is the truth
    pred = labels(
        ("pick_up", 0, 2), ("move_with", 2, 5), ("place", 5, 6.5), ("push", 6.5, 7.5), ("move", 7.5, 10)
    )  # fmt: skip
    plain = all_metrics(pred, truth)
    assert plain["sequence_match"] == 0.0 and plain["frame_accuracy"] < 0.9
    m = all_metrics(pred, truth, exclude=ex)
    assert m == {
        "sequence_match": 1.0,
        "edit_distance": 0.0,
        "frame_accuracy": 1.0,
        "boundary_error_s": 0.0,  # 6.5 and 7.5 lie inside the span; 2 and 5 are exact
        "f1@10": 1.0,
        "f1@25": 1.0,
        "f1@50": 1.0,
    }
    assert frame_accuracy(pred, truth, exclude=[(0, 11 * S)]) == 0.0  # nothing left
    # without the 2 s boundaries: true 5 and 6 against predicted 5, 6.5 and 7.5
    assert boundary_error(pred, truth, exclude=[(1 * S, 3 * S)]) == pytest.approx(0.25)
    assert segment_ratio(pred, truth) == 5 / 4 and segment_ratio([], []) == 1.0
    assert math.isinf(segment_ratio(pred, []))
