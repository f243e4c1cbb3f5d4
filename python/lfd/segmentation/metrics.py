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
  at least the threshold;
* :func:`segment_ratio` -- predicted segments per true segment (over- or under-segmentation).

Excluded time. A recording may say when its hand is not the only one handling the objects
(:data:`EXCLUDE_KEYS` in its metadata, e.g. a bimanual recording where the other hand holds or
shares the object). Such time is scored by nobody: :func:`excluded_spans` reads it, and every
metric above takes it as ``exclude`` (spans ``[start_ns, end_ns)``, sorted and disjoint):

* frame accuracy leaves the instants inside them out (:func:`outside` is the mask);
* a boundary (the start of a segment after the first) counts only outside them, for the truth
  and the prediction alike;
* the sequence, edit distance, segment count and F1 compare both segmentations as seen from
  outside (:func:`restrict`): each segment cut to its first and last instant outside the spans,
  dropped if it has none, and two segments of the same skill with only excluded time between
  them merged into one (what the other hand did there is not the demonstrator's skill).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, Protocol

import numpy as np

from ..demo import SkillLabel
from ..errors import DemonstrationError

EXCLUDE_KEYS: tuple[str, ...] = ("other_hand_spans", "shared_spans")
"""Metadata keys of the time to leave out of every score: ``[[start_s, end_s], ...]`` in seconds
from the recording's first sample (``other_hand_spans``: only another hand handles the object;
``shared_spans``: both hands do)."""

Excluded = Sequence[tuple[int, int]]
"""Spans ``[start_ns, end_ns)`` on the recording's clock, sorted and disjoint."""


class Span(Protocol):
    """Anything with a skill name and a time span in integer nanoseconds."""

    @property
    def skill(self) -> str: ...
    @property
    def start_ns(self) -> int: ...
    @property
    def end_ns(self) -> int: ...


def excluded_spans(metadata: Mapping[str, Any], start_ns: int) -> list[tuple[int, int]]:
    """The spans a score leaves out (:data:`EXCLUDE_KEYS` of a recording's metadata).

    Parameters
    ----------
    metadata : mapping
        A recording's metadata (:attr:`lfd.Demonstration.metadata`).
    start_ns : int
        Its first sample (:attr:`lfd.Demonstration.start_ns`), where the seconds count from.

    Returns
    -------
    list of (int, int)
        ``[start_ns, end_ns)`` on the recording's clock, sorted, overlapping ones merged; empty
        when the metadata names none.

    Raises
    ------
    DemonstrationError
        A key that is not a list of ``[start_s, end_s]`` pairs of finite numbers, start <= end.
    """
    spans: list[tuple[int, int]] = []
    for key in EXCLUDE_KEYS:
        value = metadata.get(key)
        if value is None:
            continue
        if not isinstance(value, list | tuple):
            raise DemonstrationError(f"metadata {key} must be a list of [start_s, end_s] pairs")
        for item in value:
            ok = isinstance(item, list | tuple) and len(item) == 2
            try:
                a, b = (float(x) for x in item) if ok else (np.nan, np.nan)
            except (TypeError, ValueError):
                a, b = np.nan, np.nan
            if not (np.isfinite(a) and np.isfinite(b) and a <= b):
                raise DemonstrationError(
                    f"metadata {key}: {item!r} is not a [start_s, end_s] pair (seconds from "
                    "the first sample, start <= end)"[:200]
                )
            if b > a:
                spans.append((start_ns + round(a * 1e9), start_ns + round(b * 1e9)))
    spans.sort()
    merged: list[tuple[int, int]] = []
    for a, b in spans:
        if merged and a <= merged[-1][1]:
            merged[-1] = (merged[-1][0], max(merged[-1][1], b))
        else:
            merged.append((a, b))
    return merged


def outside(t_ns: np.ndarray, exclude: Excluded) -> np.ndarray:
    """Mask of the instants ``t_ns`` outside every excluded span ``[start_ns, end_ns)``."""
    t = np.asarray(t_ns, dtype=np.int64)
    keep = np.ones(t.shape, dtype=bool)
    for a, b in exclude:
        keep &= (t < a) | (t >= b)
    return keep


def _clip(start: int, end: int, exclude: Excluded) -> tuple[int, int] | None:
    """``[start, end)`` cut to its first and last instant outside ``exclude`` (None: none)."""
    for a, b in exclude:  # sorted and disjoint: a start inside a span moves to its end
        if a <= start < b:
            start = b
    for a, b in reversed(exclude):  # an end inside a span (or at its end) moves to its start
        if a < end <= b:
            end = a
    if end <= start:
        return None
    return start, end


def restrict(spans: Sequence[Span], exclude: Excluded) -> list[SkillLabel]:
    """A segmentation as seen from outside the ``exclude`` spans.

    Every segment is cut to its first and last instant outside them (one that lies wholly
    inside is dropped); then two segments in a row of the same skill with only excluded time
    between them become one (from the first one's start to the last one's end; the object is
    the first one's). Segments that touch outside the spans stay apart, as without exclusion.
    With no ``exclude`` the segments are returned as they are (as :class:`lfd.SkillLabel`).
    """
    out: list[SkillLabel] = []
    for s in spans:
        cut = _clip(s.start_ns, s.end_ns, exclude) if exclude else (s.start_ns, s.end_ns)
        if cut is None:
            continue
        obj = getattr(s, "object", None)
        prev = out[-1] if out else None
        if prev is not None and prev.skill == s.skill and _excluded(prev.end_ns, cut[0], exclude):
            out[-1] = SkillLabel(s.skill, prev.start_ns, cut[1], prev.object)
            continue
        out.append(SkillLabel(s.skill, cut[0], cut[1], obj))
    return out


def _excluded(start: int, end: int, exclude: Excluded) -> bool:
    """``[start, end)`` is non-empty and wholly excluded time (so inside one span: the spans of
    :func:`excluded_spans` neither overlap nor touch)."""
    return start < end and any(a <= start and end <= b for a, b in exclude)


def segment_ratio(pred: Sequence[Span], truth: Sequence[Span]) -> float:
    """Predicted segments per true segment (1 = as many; ``inf`` with no true segment and some
    predicted, 1 with neither)."""
    if not truth:
        return float("inf") if pred else 1.0
    return len(pred) / len(truth)


def _levenshtein(a: Sequence[str], b: Sequence[str]) -> int:
    """Edit distance by Myers' bit-parallel algorithm (Hyyrö's form for the Levenshtein
    distance, H. Hyyrö, "A bit-vector algorithm for computing Levenshtein and Damerau edit
    distances", 2003): one column of the table per symbol of ``a``, the whole column of
    ``len(b)`` cells as the bits of two Python integers (exact, O(len(a) len(b) / 64))."""
    m = len(b)
    if m == 0:
        return len(a)
    peq: dict[str, int] = {}
    for j, y in enumerate(b):
        peq[y] = peq.get(y, 0) | (1 << j)
    mask = (1 << m) - 1
    top = 1 << (m - 1)
    pv, mv, score = mask, 0, m
    for x in a:
        eq = peq.get(x, 0)
        xv = eq | mv
        xh = (((eq & pv) + pv) ^ pv) | eq
        ph = mv | (~(xh | pv) & mask)
        mh = pv & xh
        if ph & top:
            score += 1
        elif mh & top:
            score -= 1
        ph = ((ph << 1) | 1) & mask
        mh = (mh << 1) & mask
        pv = mh | (~(xv | ph) & mask)
        mv = ph & xv
    return score


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


def frame_accuracy(
    pred: Sequence[Span], truth: Sequence[Span], *, step_s: float = 0.01, exclude: Excluded = ()
) -> float:
    """Share of the ground truth's time span where the predicted skill is the true one.

    Time is sampled every ``step_s`` seconds from the first true start to the last true end;
    instants no true segment covers (gaps between labels) and instants inside the ``exclude``
    spans are left out (0 when nothing is left).
    """
    if not truth:
        raise ValueError("frame accuracy needs a non-empty ground truth")
    t0, t1 = truth[0].start_ns, truth[-1].end_ns
    t_ns = np.arange(t0, t1 + 1, max(int(step_s * 1e9), 1), dtype=np.int64)
    want = _labels_at(truth, t_ns)
    got = _labels_at(pred, t_ns)
    keep = (want != "") & outside(t_ns, exclude)
    if not keep.any():
        return 0.0
    return float(np.mean(want[keep] == got[keep]))


def _interior(spans: Sequence[Span], exclude: Excluded = ()) -> np.ndarray:
    """The segments' starts after the first, outside ``exclude``, in seconds."""
    t = np.array([s.start_ns for s in spans[1:]], dtype=np.int64)
    return t[outside(t, exclude)].astype(np.float64) * 1e-9


def boundary_error(pred: Sequence[Span], truth: Sequence[Span], *, exclude: Excluded = ()) -> float:
    """Mean distance (s) from each true interior boundary to the nearest predicted one.

    Boundaries (true and predicted) inside the ``exclude`` spans do not count. 0 if the truth
    has no boundary; ``inf`` if the truth has boundaries but the prediction has none.
    """
    want = _interior(truth, exclude)
    if want.size == 0:
        return 0.0
    got = _interior(pred, exclude)
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


def all_metrics(
    pred: Sequence[Span], truth: Sequence[Span], *, exclude: Excluded = ()
) -> dict[str, float]:
    """Every metric of :data:`METRIC_NAMES` as a dict (``sequence_match`` as 0.0 / 1.0), with
    the ``exclude`` spans left out as the module documentation says."""
    seq_pred, seq_truth = (
        (restrict(pred, exclude), restrict(truth, exclude)) if exclude else (pred, truth)
    )
    return {
        "sequence_match": float(sequence_match(seq_pred, seq_truth)),
        "edit_distance": edit_distance(seq_pred, seq_truth),
        "frame_accuracy": frame_accuracy(pred, truth, exclude=exclude),
        "boundary_error_s": boundary_error(pred, truth, exclude=exclude),
        "f1@10": f1_at(seq_pred, seq_truth, 0.10),
        "f1@25": f1_at(seq_pred, seq_truth, 0.25),
        "f1@50": f1_at(seq_pred, seq_truth, 0.50),
    }


HANDOVER_TOLERANCE_S = 0.3
"""A predicted handover matches a true one when giver and taker agree and their ends (the
giver's release) are at most this far apart (docs/skills.md, "Two hands")."""


class HandoverLike(Protocol):
    """Anything with a handover's giver, taker and end (:class:`lfd.Handover`)."""

    @property
    def giver(self) -> str: ...
    @property
    def taker(self) -> str: ...
    @property
    def end_ns(self) -> int: ...


def handover_scores(
    pred: Sequence[HandoverLike],
    truth: Sequence[HandoverLike],
    *,
    tolerance_s: float = HANDOVER_TOLERANCE_S,
) -> dict[str, float]:
    """The handovers found: ``found`` true ones matched (one to one, the nearest end first),
    ``missed`` true ones not, ``false`` predicted ones that match none, ``true`` and
    ``predicted`` the counts, and ``end_error_s`` the mean end error of the matches (NaN if
    none)."""
    pairs = sorted(
        (abs(p.end_ns - t.end_ns), i, j)
        for i, p in enumerate(pred)
        for j, t in enumerate(truth)
        if p.giver == t.giver and p.taker == t.taker
        and abs(p.end_ns - t.end_ns) <= tolerance_s * 1e9
    )  # fmt: skip
    used_p: set[int] = set()
    used_t: set[int] = set()
    errors: list[float] = []
    for d, i, j in pairs:
        if i in used_p or j in used_t:
            continue
        used_p.add(i)
        used_t.add(j)
        errors.append(d * 1e-9)
    return {
        "true": float(len(truth)),
        "predicted": float(len(pred)),
        "found": float(len(used_t)),
        "missed": float(len(truth) - len(used_t)),
        "false": float(len(pred) - len(used_p)),
        "end_error_s": float(np.mean(errors)) if errors else float("nan"),
    }
