"""Segmentation metrics, as in the action-segmentation literature.

Every function takes a predicted and a ground-truth segmentation as sequences of objects with
``skill``, ``start_ns`` and ``end_ns`` (e.g. :class:`lfd.SkillLabel` or
:class:`lfd.segmentation.Segment`), in time order.

* :func:`sequence_match` -- the skill sequences are identical;
* :func:`edit_distance` -- Levenshtein distance between the skill sequences divided by the longer
  length (0 = identical, 1 = nothing in common);
* :func:`frame_accuracy` -- share of time (sampled on a uniform grid over the ground truth's span)
  where the predicted skill equals the true one;
* :func:`boundary_error` -- mean over the true interior boundaries of the distance (seconds) to
  the nearest predicted interior boundary;
* :func:`f1_at` -- segmental F1 at an IoU threshold (Lea et al. 2017, MS-TCN): a predicted
  segment is a true positive if its IoU with a not-yet-matched true segment of the same skill is
  at least the threshold.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import numpy as np


class Span(Protocol):
    """Anything with a skill name and a time span in integer nanoseconds."""

    @property
    def skill(self) -> str: ...
    @property
    def start_ns(self) -> int: ...
    @property
    def end_ns(self) -> int: ...


def _levenshtein(a: Sequence[str], b: Sequence[str]) -> int:
    """Edit distance, one row of the table at a time in numpy (exact integers): the insertion
    chain ``cur[j] = min(c[j], cur[j - 1] + 1)`` is ``min_{k <= j} (c[k] + j - k)``."""
    codes = {s: n for n, s in enumerate(dict.fromkeys([*a, *b]))}
    bb = np.array([codes[y] for y in b], dtype=np.int64)
    ramp = np.arange(len(b) + 1, dtype=np.int64)
    prev = ramp.copy()
    for i, x in enumerate(a, 1):
        c = np.empty_like(prev)
        c[0] = i
        c[1:] = np.minimum(prev[1:] + 1, prev[:-1] + (bb != codes[x]))
        prev = np.minimum.accumulate(c - ramp) + ramp
    return int(prev[-1])


def sequence_match(pred: Sequence[Span], truth: Sequence[Span]) -> bool:
    """True if the predicted skill sequence equals the true one."""
    return [p.skill for p in pred] == [t.skill for t in truth]


def edit_distance(pred: Sequence[Span], truth: Sequence[Span]) -> float:
    """Levenshtein distance of the skill sequences / the longer length, in [0, 1]."""
    a = [p.skill for p in pred]
    b = [t.skill for t in truth]
    if not a and not b:
        return 0.0
    return _levenshtein(a, b) / max(len(a), len(b))


def _labels_at(spans: Sequence[Span], t_ns: np.ndarray) -> np.ndarray:
    """The skill of each instant of ``t_ns`` (ascending): later spans overwrite earlier ones."""
    out = np.full(t_ns.shape, "", dtype=object)
    for s in spans:
        lo, hi = np.searchsorted(t_ns, [s.start_ns, s.end_ns], side="left")
        out[lo:hi] = s.skill  # start_ns <= t < end_ns
    if spans:  # the last segment includes its end
        out[t_ns == spans[-1].end_ns] = spans[-1].skill
    return out


def frame_accuracy(pred: Sequence[Span], truth: Sequence[Span], *, step_s: float = 0.01) -> float:
    """Share of the ground truth's time span where the predicted skill is the true one.

    Time is sampled every ``step_s`` seconds from the first true start to the last true end;
    instants no true segment covers (gaps between labels) are left out.
    """
    if not truth:
        raise ValueError("frame accuracy needs a non-empty ground truth")
    t0, t1 = truth[0].start_ns, truth[-1].end_ns
    t_ns = np.arange(t0, t1 + 1, max(int(step_s * 1e9), 1), dtype=np.int64)
    want = _labels_at(truth, t_ns)
    got = _labels_at(pred, t_ns)
    keep = want != ""
    if not keep.any():
        return 0.0
    return float(np.mean(want[keep] == got[keep]))


def _interior(spans: Sequence[Span]) -> np.ndarray:
    return np.array([s.start_ns for s in spans[1:]], dtype=np.float64) * 1e-9


def boundary_error(pred: Sequence[Span], truth: Sequence[Span]) -> float:
    """Mean distance (s) from each true interior boundary to the nearest predicted one.

    0 if the truth has a single segment; ``inf`` if the truth has boundaries but the prediction
    has none.
    """
    want = _interior(truth)
    if want.size == 0:
        return 0.0
    got = _interior(pred)
    if got.size == 0:
        return float("inf")
    # the nearest predicted boundary is a neighbour in sorted order (linear, not |want| x |got|)
    got = np.sort(got)
    at = np.searchsorted(got, want)
    below = np.abs(want - got[np.maximum(at - 1, 0)])
    above = np.abs(want - got[np.minimum(at, got.size - 1)])
    return float(np.mean(np.minimum(below, above)))


def f1_at(pred: Sequence[Span], truth: Sequence[Span], iou: float) -> float:
    """Segmental F1 score at IoU threshold ``iou`` (e.g. 0.10, 0.25, 0.50)."""
    if not pred and not truth:
        return 1.0
    matched = [False] * len(truth)
    tp = 0
    # only overlapping spans have a positive IoU: with the truth in time order (starts and ends
    # ascending) they are a window found by bisection, else every span is looked at
    starts = np.array([t.start_ns for t in truth], dtype=np.int64)
    ends = np.array([t.end_ns for t in truth], dtype=np.int64)
    ordered = bool(np.all(np.diff(starts) >= 0) and np.all(np.diff(ends) >= 0))
    for p in pred:
        best, best_j = 0.0, -1
        lo, hi = 0, len(truth)
        if ordered:
            lo = int(np.searchsorted(ends, p.start_ns, side="right"))  # ends after p starts
            hi = int(np.searchsorted(starts, p.end_ns, side="left"))  # starts before p ends
        for j in range(lo, hi):
            t = truth[j]
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
    fp = len(pred) - tp
    fn = len(truth) - tp
    precision = tp / (tp + fp) if pred else 0.0
    recall = tp / (tp + fn) if truth else 0.0
    if precision + recall == 0:
        return 0.0
    return 2 * precision * recall / (precision + recall)


METRIC_NAMES: tuple[str, ...] = (
    "sequence_match",
    "edit_distance",
    "frame_accuracy",
    "boundary_error_s",
    "f1@10",
    "f1@25",
    "f1@50",
)
"""Keys of :func:`all_metrics`, in display order."""


def all_metrics(pred: Sequence[Span], truth: Sequence[Span]) -> dict[str, float]:
    """Every metric above as a dict (``sequence_match`` as 0.0 / 1.0)."""
    return {
        "sequence_match": float(sequence_match(pred, truth)),
        "edit_distance": edit_distance(pred, truth),
        "frame_accuracy": frame_accuracy(pred, truth),
        "boundary_error_s": boundary_error(pred, truth),
        "f1@10": f1_at(pred, truth, 0.10),
        "f1@25": f1_at(pred, truth, 0.25),
        "f1@50": f1_at(pred, truth, 0.50),
    }
