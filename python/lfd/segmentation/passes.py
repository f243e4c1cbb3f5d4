"""The passes over the search's segments (:func:`lfd.segmentation.pipeline.segment_trajectory`):
implicit Moves inserted, the boundaries of the skills that touch an object put where contact
says, every Move given the object it goes towards."""

from __future__ import annotations

import dataclasses
from bisect import bisect_left, bisect_right
from collections.abc import Callable
from itertools import pairwise

import numpy as np

from ..contact import ContactParams, refine
from ..trajectory import Trajectory
from .drafts import _Draft, _make_segments
from .grammar import needs_move_between
from .result import Segment


def insert_implicit_moves(traj: Trajectory, segments: list[Segment], length: int) -> list[Segment]:
    """Insert the Move that a release -> skill transition, or a Locate followed by a skill on
    another object, stands for (see :func:`~lfd.segmentation.grammar.needs_move_between`):
    ``length`` samples centred on the TCP's highest point in the last ``length`` samples of the
    first skill and the first ``length`` of the next, taken from both (each keeps at least one
    sample)."""
    names = list(traj.object_names)
    out: list[_Draft] = []
    z = traj.tcp[:, 2]
    for seg in segments:
        prev = out[-1] if out else None
        if prev is None or not needs_move_between(
            prev.skill, prev.object_name(names), seg.skill, seg.object
        ):
            out.append(_Draft.of(seg, names))
            continue
        lo, hi = max(prev.start + 1, seg.start - length), min(seg.end - 1, seg.start + length)
        peak = lo + int(np.argmax(z[lo:hi])) if hi > lo else seg.start
        a = min(max(lo, peak - length // 2), seg.start)
        b = max(min(hi, a + length), seg.start)
        a = min(a, b - 1)
        nxt = _Draft.of(seg, names)
        out[-1] = prev.resized(prev.start, a)
        out.append(_Draft("move", a, b, nxt.obj))
        out.append(nxt.resized(b, seg.end))
    return _make_segments(traj, [d for d in out if d.end > d.start])


def refine_contacts(
    traj: Trajectory, segments: list[Segment], params: ContactParams, *, complete: bool = True
) -> list[Segment]:
    """The segments with the boundaries of the skills that touch an object put where contact
    says (:func:`lfd.contact.refine`, ``complete`` as there); unchanged segments are kept as
    they are."""
    names = list(traj.object_names)
    spans = [
        (s.skill, s.start, s.end, names.index(s.object) if s.object in names else None)
        for s in segments
    ]
    refined = refine(
        spans,
        traj.tcp,
        traj.keypoints[:, 4],
        traj.object_position,
        traj.object_quaternion,
        traj.object_size,
        params,
        opening=traj.opening,
        complete=complete,
    )
    if refined == spans:
        return segments
    source = _overlapping(segments)
    out: list[_Draft] = []
    for skill, a, b, o in refined:
        # the segment of the search it came from: the same skill, overlapping it most (its
        # score, confidence and margin are the search's; an inserted Move has none)
        best, src = 0, None
        for s in source(a, b):
            if s.skill == skill and (ov := min(b, s.end) - max(a, s.start)) > best:
                best, src = ov, s
        if src is not None:
            d = _Draft.of(src, names)
            out.append(d if (src.start, src.end) == (a, b) else d.resized(a, b))
        else:
            out.append(_Draft(skill, a, b, o))
    return _make_segments(traj, out)


def _overlapping(segments: list[Segment]) -> Callable[[int, int], list[Segment]]:
    """``of(a, b)``: the ``segments`` that share a sample with ``a..b``, in their order (a
    bisection when they are in time order without overlaps, as the search gives them; else
    all of them)."""
    starts = [s.start for s in segments]
    ends = [s.end for s in segments]
    ordered = all(s.start <= s.end <= nxt.start for s, nxt in pairwise(segments))
    if not ordered:
        return lambda a, b: segments

    def of(a: int, b: int) -> list[Segment]:
        return segments[bisect_right(ends, a) : bisect_left(starts, b)]

    return of


MOVE_OBJECT_S = 1.0
"""A Move's object is the one nearest the hand this long (s) after the Move ends
(:func:`label_moves`)."""


def nearest_object(tcp: np.ndarray, positions: np.ndarray) -> int | None:
    """Index of the object (rows of ``positions``, ``(O, 3)``) nearest ``tcp`` (None if no
    position is finite)."""
    d = np.linalg.norm(np.asarray(positions) - np.asarray(tcp), axis=-1)
    return int(np.nanargmin(d)) if np.isfinite(d).any() else None


def object_after(tcp: np.ndarray, positions: np.ndarray, end: int, k: int) -> int | None:
    """The object a Move ending at sample ``end`` goes towards (:func:`label_moves`' rule): the
    one nearest the hand ``k`` samples later, or at the last sample if that is sooner. ``tcp``
    ``(n, 3)``, ``positions`` ``(n, O, 3)``: the samples so far (live) or all of them."""
    e = min(end + k, len(tcp) - 1)
    return nearest_object(tcp[e], positions[e])


def label_moves(
    traj: Trajectory, segments: list[Segment], after_s: float = MOVE_OBJECT_S
) -> list[Segment]:
    """Give every Move the object it goes towards: the one nearest the hand ``after_s`` after
    the Move ends (then the hand is at, or carrying, the object of the skill after the Move,
    the ground truth's convention, in 160 of 165 Moves of the evaluation demos); a Move that
    ends the demonstration has none. The object that best explains a Move's own samples is
    ambiguous (the hand is near no box, or near several); decided this way the label depends
    on positions only, so the live segmentation, which knows them by then, gives the same."""
    out = list(segments)
    k = max(0, round(after_s / traj.dt)) if traj.dt > 0 else 0
    moves = [i for i, seg in enumerate(out) if seg.skill == "move"]
    # object_after of every Move but a last one, at once
    inner = [i for i in moves if i + 1 < len(out)]
    e = np.minimum(np.array([out[i].end for i in inner], dtype=np.intp) + k, len(traj.tcp) - 1)
    positions = np.asarray(traj.object_position)[:, e].transpose(1, 0, 2)  # (m, O, 3)
    d = np.linalg.norm(positions - np.asarray(traj.tcp)[e][:, None, :], axis=-1)
    some = np.isfinite(d).any(axis=-1)
    nearest = np.nanargmin(np.where(some[:, None], d, 0.0), axis=-1) if some.any() else some
    after = {i: int(j) for i, j, ok in zip(inner, nearest, some, strict=True) if ok}
    for i in moves:
        seg = out[i]
        obj = after.get(i)
        name = traj.object_names[obj] if obj is not None else None
        if name != seg.object:
            out[i] = dataclasses.replace(seg, object=name)
    return out
