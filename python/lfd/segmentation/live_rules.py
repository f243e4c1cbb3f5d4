"""What the live segmentation reads in a run about whether a skill can settle yet
(:mod:`lfd.segmentation.live`)."""

from __future__ import annotations

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


def unlifted(run: Segmentation, seg: Segment) -> bool:
    """Whether ``seg`` is a Move with whose object never rose above its rest height (the
    features' lift threshold) in ``run``: a turn or slide on the table that the next grasp of
    the object may yet make part of one Pick up (:func:`lfd.contact.refine`), so it settles
    as an uncertain one."""
    if seg.skill != "move_with":
        return False
    a, b = int(seg.start), max(int(seg.end), int(seg.start) + 1)
    return _above(run, seg.object, "object_height", a, b) is False


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
