"""What the live segmentation reads in a run about whether a skill can settle yet
(:mod:`lfd.segmentation.live`): the run's evidence, and when a candidate is ready to settle
(:class:`Settling`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from itertools import pairwise
from typing import Protocol

import numpy as np

from ..geometry import box_distance
from ..skills import RELEASES
from .result import Run, Segment, Segmentation

GRASP_M = 0.001
"""The TCP (the midpoint of thumb and index tips) this close to an object's box, or inside it,
has the object between its fingers: a hand that passes by or rests beside a box stays outside
it (perceived natural exp1 seed 9417: 0.8-5 cm from box_3 for 2 s before it grasped box_1)."""


def _above(run: Segmentation, name: str | None, column: str, a: int, b: int | None) -> bool | None:
    """Whether feature ``column`` of object ``name`` went above its threshold in samples
    ``a:b`` of ``run``; None if the run does not say (no such object, no features)."""
    from .stage1 import OBJECT_COLUMNS

    if name is None or run.run is None:
        return None
    try:
        feats = run.run.object_features[run.object_names.index(name)]
    except (ValueError, IndexError):
        return None
    k = OBJECT_COLUMNS[column]
    return bool((feats.values[a:b, k] > feats.thresholds[a:b, k]).any())


def _carry_lifted(run: Segmentation, seg: Segment) -> bool | None:
    """Whether the object of ``seg`` (a Move with) rose above its rest height (the features'
    lift threshold) within ``seg`` in ``run``; None if the run does not say."""
    a, b = int(seg.start), max(int(seg.end), int(seg.start) + 1)
    return _above(run, seg.object, "object_height", a, b)


def unlifted(run: Segmentation, seg: Segment) -> bool:
    """Whether ``seg`` is a Move with whose object never rose above its rest height (the
    features' lift threshold) in ``run``: a turn or slide on the table that the next grasp of
    the object may yet make part of one Pick up (:func:`lfd.contact.refine`), so it settles
    as an uncertain one."""
    return seg.skill == "move_with" and _carry_lifted(run, seg) is False


def lifts(run: Segmentation, seg: Segment, after: Segment) -> bool:
    """Whether ``seg`` is a Pick up followed in ``run`` by the Move with of its object that
    has lifted it above its rest height (the features' lift threshold): whatever its
    confidence, the grammar allows nothing else before a carry, and its end is the lift-off
    (:func:`lfd.contact.refine`)."""
    if seg.skill != "pick_up" or after.skill != "move_with" or after.object != seg.object:
        return False
    return _carry_lifted(run, after) is True


def lifted_after(run: Segmentation, seg: Segment) -> bool:
    """Whether the object ``seg`` is named after rose above its rest height (the features' lift
    threshold) in ``run`` after ``seg`` ended: for a Move, the skill after it is a Pick up of
    that object that has lifted it, however long the run takes to find the carry after it."""
    return _above(run, seg.object, "object_height", int(seg.end), None) is True


def handled_after(run: Segmentation, prev: Segment | None, seg: Segment, skill: str) -> bool:
    """Whether the skill after the Move ``seg`` (``skill``, on the Move's object; ``prev`` the
    skill before the Move) has shown in ``run`` what it does to the object, so the Move's end
    (where that skill's reach begins) and name are known: a Pick up that lifted the object
    (:func:`lifted_after`) or, after a release, grasped it (:func:`grasped_after`); after a
    release, a Push that moved it (:func:`pushed_after`)."""
    if skill == "pick_up":
        return lifted_after(run, seg) or grasped_after(run, prev, seg)
    return skill == "push" and pushed_after(run, prev, seg)


def _run_after_release(run: Segmentation, prev: Segment | None, seg: Segment) -> Run | None:
    """What ``run`` ran on and computed (``run.run``: None without it) if ``seg`` is a Move
    after a release (``prev`` a Place or Stack), else None. Not after another skill: after a
    Push or Locate the hand is still at, or beside, an object it does not go on to lift
    (perceived natural exp2 seed 9409, exp3 seed 9413)."""
    after = prev is not None and prev.skill in RELEASES and seg.skill == "move"
    return run.run if after else None


def grasped_after(run: Segmentation, prev: Segment | None, seg: Segment) -> bool:
    """Whether ``seg`` is a Move after the release of its own object (a re-grasp: the box put
    down and taken again) whose object has been between the hand's fingers (the TCP within
    :data:`GRASP_M` of its box) after ``seg`` ended in ``run``: the Pick up after it has
    grasped it again, and its reach, which ends the Move, is behind it
    (:func:`lfd.contact._reach_start`). Not for another box: a natural hand may hold its open
    fingers around a box for seconds and then go to another (simulated natural exp5 seed 305:
    2.5 s around box_3 after putting box_2 down, then box_2 again)."""
    if prev is None or prev.object != seg.object:
        return False
    ran = _run_after_release(run, prev, seg)
    if ran is None:
        return False
    tr = ran.trajectory
    if seg.object not in tr.object_names:
        return False
    o, a = tr.object_names.index(seg.object), int(seg.end)
    d = box_distance(
        tr.tcp[a:], tr.object_position[o][a:], tr.object_quaternion[o][a:], tr.object_size[o]
    )
    return bool((d <= GRASP_M).any())


def pushed_after(run: Segmentation, prev: Segment | None, seg: Segment) -> bool:
    """Whether ``seg`` is a Move after a release whose object has moved (its speed above the
    features' threshold) after ``seg`` ended in ``run``: the Push after it has begun."""
    moved = _above(run, seg.object, "object_velocity", int(seg.end), None)
    return _run_after_release(run, prev, seg) is not None and moved is True


def landed(seg: Segment, after: Segment) -> bool:
    """Whether ``seg`` is a Move with that the run follows with the Place or Stack of its
    object. The run finds the set-down once the hand lets go, when the box has come to rest;
    the Move with ends where the box was last ``place_h_m`` above that rest height
    (:func:`lfd.contact.refine`), measured on samples the next runs do not change, so it
    settles without waiting ``stable_s`` for them to agree (the check run still must)."""
    return (
        seg.skill == "move_with"
        and after.skill in RELEASES
        and seg.object is not None
        and after.object == seg.object
    )


def set_down_unseen(
    seg: Segment, poses: dict[str, list[tuple[int, np.ndarray, np.ndarray]]]
) -> bool:
    """Whether ``seg`` is a Place or Stack whose object has not been seen (``poses``: the
    sightings so far, per object) since before it ended: where the object came to rest (on
    the table or on another, and when) is not known yet."""
    seen = poses.get(seg.object or "") or []
    return seg.skill in ("place", "stack") and bool(seen) and seen[-1][0] < int(seg.end_ns)


@dataclass
class Candidate:
    """An unsettled segment of the newest run and the recording time it first came out so."""

    segment: Segment
    since_ns: int


class Waits(Protocol):
    """A live segmenter's thresholds (:class:`lfd.segmentation.live.LiveSegmentation`)."""

    min_confidence: float
    stable_ns: int
    uncertain_ns: int
    followers: int


@dataclass
class Settling:
    """When the candidates of one run can settle
    (:meth:`lfd.segmentation.live.LiveSegmentation.settle`): its times (ns), its thresholds
    (``waits``: the segmenter) and its own lists, read as they change: ``cands`` the candidates
    still open (the first popped as it settles), ``emitted`` the segments settled."""

    run: Segmentation
    cands: list[Candidate]
    emitted: list[Segment]
    poses: dict[str, list[tuple[int, np.ndarray, np.ndarray]]]
    """The objects' sightings so far (:func:`set_down_unseen`)."""
    now: int
    limit: int
    """The latest end that may settle (``lag_s`` before the newest hand frame, and the objects
    the hand may have moved unseen seen since)."""
    shared: Callable[[Segment], bool] | None
    waits: Waits
    _grasps: set[int] = field(init=False)
    _down: set[int] = field(init=False)
    _handled: set[int] = field(init=False)
    _lifting: set[int] = field(init=False)

    def __post_init__(self) -> None:
        # a Pick up is as uncertain as the Move with after it that has not lifted its object;
        # a Move with whose set-down the run has found needs no stable_s (landed), nor a Move
        # whose next skill has shown what it does to the Move's object (handled_after)
        cands, run = self.cands, self.run
        self._grasps = {id(a) for a, b in pairwise(cands) if unlifted(run, b.segment)}
        self._down = {id(a) for a, b in pairwise(cands) if landed(a.segment, b.segment)}
        self._handled = {id(c) for i, c in enumerate(cands) if self.handled_next(i)}
        self._lifting = {id(a) for a, b in pairwise(cands) if lifts(run, a.segment, b.segment)}

    def uncertain(self, c: Candidate) -> bool:
        """Whether ``c`` is a guess that settles only after ``uncertain_s``: a low confidence
        (not a Pick up whose Move with has lifted its object: :func:`lifts`), an object the
        other hand has (``shared``), a Move with that has not lifted its object, or the Pick up
        before one."""
        # NaN confidence (an implied Move) counts as certain
        guess = c.segment.confidence < self.waits.min_confidence and id(c) not in self._lifting
        return (
            guess
            or (self.shared is not None and self.shared(c.segment))
            or unlifted(self.run, c.segment)
            or id(c) in self._grasps
        )

    def ready(self, c: Candidate) -> bool:
        """Whether ``c`` ended by :attr:`limit` and has come out the same for long enough
        (``uncertain_s`` if :meth:`uncertain`; no wait for a Move with whose set-down the run
        has found, nor for a Move whose next skill has lifted, grasped or pushed its object:
        the Move's end, where that skill's reach begins, lies before evidence later runs keep;
        else ``stable_s``), and, a set-down, its object has been seen since."""
        if self.uncertain(c):
            wait = self.waits.uncertain_ns
        else:
            known = id(c) in self._down or id(c) in self._handled
            wait = 0 if known else self.waits.stable_ns
        return (
            int(c.segment.end_ns) <= self.limit
            and self.now - c.since_ns >= wait
            and not set_down_unseen(c.segment, self.poses)
        )

    def handled_next(self, i: int) -> bool:
        """Whether candidate ``i`` is a Move whose next skill has shown in the run what it
        does to the Move's object (:func:`handled_after`)."""
        cands = self.cands
        if cands[i].segment.skill != "move" or len(cands) <= i + 1:
            return False
        move, after = cands[i].segment, cands[i + 1].segment
        if after.object != move.object:
            return False
        prev = cands[i - 1].segment if i else next(reversed(self.emitted), None)
        return handled_after(self.run, prev, move, after.skill)

    def next_known(self, i: int) -> bool:
        """Whether the skill after candidate ``i`` is known, if ``i`` is a Move."""
        # a Move ends where the reach of the skill after it begins and is named after its
        # object (lfd.contact): it settles once that skill ended in the run and is no guess,
        # or is a guess that has waited its uncertain_s (else it would hold all after it)
        cands = self.cands
        if cands[i].segment.skill != "move":
            return True
        if id(cands[i]) in self._handled:
            return True  # a Pick up lifted it (or grasped it), a Push moved it
        return len(cands) > i + 1 + self.waits.followers and (
            not self.uncertain(cands[i + 1]) or self.ready(cands[i + 1])
        )
