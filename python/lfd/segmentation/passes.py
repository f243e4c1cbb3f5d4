"""The passes over the search's segments (:func:`lfd.segmentation.pipeline.segment_trajectory`),
each taking and returning drafts (:class:`lfd.skills.Draft`): implicit Moves inserted, the
boundaries of the skills that touch an object put where contact says, every Move given the object
it goes towards."""

from __future__ import annotations

import dataclasses
from bisect import bisect_left, bisect_right
from collections.abc import Callable, Sequence
from itertools import pairwise

import numpy as np

from ..contact import ContactParams, refine
from ..skills import Draft
from ..trajectory import Trajectory
from .grammar import needs_move_between


def insert_implicit_moves(traj: Trajectory, drafts: Sequence[Draft], length: int) -> list[Draft]:
    """Insert the Move that a release -> skill transition, or a Locate followed by a skill on
    another object, stands for (see :func:`~lfd.segmentation.grammar.needs_move_between`):
    ``length`` samples centred on the TCP's highest point in the last ``length`` samples of the
    first skill and the first ``length`` of the next, taken from both (each keeps at least one
    sample)."""
    names = list(traj.object_names)
    out: list[Draft] = []
    z = traj.tcp[:, 2]
    for d in drafts:
        prev = out[-1] if out else None
        if prev is None or not needs_move_between(
            prev.skill, prev.object_name(names), d.skill, d.object_name(names)
        ):
            out.append(d)
            continue
        lo, hi = max(prev.start + 1, d.start - length), min(d.end - 1, d.start + length)
        peak = lo + int(np.argmax(z[lo:hi])) if hi > lo else d.start
        a = min(max(lo, peak - length // 2), d.start)
        b = max(min(hi, a + length), d.start)
        a = min(a, b - 1)
        out[-1] = prev.resized(prev.start, a)
        out.append(Draft("move", a, b, d.obj))
        out.append(d.resized(b, d.end))
    return [d for d in out if d.end > d.start]


def refine_contacts(
    traj: Trajectory, drafts: list[Draft], params: ContactParams, *, complete: bool = True
) -> list[Draft]:
    """The drafts with the boundaries of the skills that touch an object put where contact
    says (:func:`lfd.contact.refine`, ``complete`` as there). A refined draft keeps the target
    and the scores of the search's draft of its skill it overlaps most (a Pick up merged from
    two keeps the longer one's); an inserted Move has none."""
    refined = refine(
        drafts,
        traj.tcp,
        traj.keypoints[:, 4],
        traj.object_position,
        traj.object_quaternion,
        traj.object_size,
        params,
        opening=traj.opening,
        complete=complete,
    )
    if [d.span for d in refined] == [d.span for d in drafts]:
        return drafts
    source = _overlapping(drafts)
    out: list[Draft] = []
    for r in refined:
        best, src = 0, None
        for d in source(r.start, r.end):
            if d.skill == r.skill and (ov := min(r.end, d.end) - max(r.start, d.start)) > best:
                best, src = ov, d
        if src is not None:
            out.append(src.resized(r.start, r.end))
        else:
            out.append(Draft(r.skill, r.start, r.end, r.obj))
    return out


def _overlapping(drafts: Sequence[Draft]) -> Callable[[int, int], Sequence[Draft]]:
    """``of(a, b)``: the ``drafts`` that share a sample with ``a..b``, in their order (a
    bisection when they are in time order without overlaps, as the search gives them; else
    all of them)."""
    starts = [d.start for d in drafts]
    ends = [d.end for d in drafts]
    ordered = all(d.start <= d.end <= nxt.start for d, nxt in pairwise(drafts))
    if not ordered:
        return lambda a, b: drafts

    def of(a: int, b: int) -> Sequence[Draft]:
        return drafts[bisect_right(ends, a) : bisect_left(starts, b)]

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
    traj: Trajectory, drafts: Sequence[Draft], after_s: float = MOVE_OBJECT_S
) -> list[Draft]:
    """Give every Move the object it goes towards: the one nearest the hand ``after_s`` after
    the Move ends (then the hand is at, or carrying, the object of the skill after the Move,
    the ground truth's convention, in 160 of 165 Moves of the evaluation demos); a Move that
    ends the demonstration has none. The object that best explains a Move's own samples is
    ambiguous (the hand is near no box, or near several); decided this way the label depends
    on positions only, so the live segmentation, which knows them by then, gives the same."""
    out = list(drafts)
    k = max(0, round(after_s / traj.dt)) if traj.dt > 0 else 0
    moves = [i for i, d in enumerate(out) if d.skill == "move"]
    # object_after of every Move but a last one, at once
    inner = [i for i in moves if i + 1 < len(out)]
    e = np.minimum(np.array([out[i].end for i in inner], dtype=np.intp) + k, len(traj.tcp) - 1)
    positions = np.asarray(traj.object_position)[:, e].transpose(1, 0, 2)  # (m, O, 3)
    d = np.linalg.norm(positions - np.asarray(traj.tcp)[e][:, None, :], axis=-1)
    some = np.isfinite(d).any(axis=-1)
    nearest = np.nanargmin(np.where(some[:, None], d, 0.0), axis=-1) if some.any() else some
    after = {i: int(j) for i, j, ok in zip(inner, nearest, some, strict=True) if ok}
    for i in moves:
        obj = after.get(i)
        if obj != out[i].obj:
            out[i] = dataclasses.replace(out[i], obj=obj)
    return out
