"""Which hand moves an object: contact and co-motion of two hands (docs/skills.md, "Two hands").

An object is held only by the hand(s) touching it. :func:`hand_view` gives the demonstration as
one hand sees it: every object's motion that the other hand alone caused (while this hand was
away from it) is taken out, so that the one-hand segmentation does not read the other hand's
carrying as this hand's. Near this hand every object keeps its true pose, so the approach, grasp
and release distances of the contact rules (:mod:`lfd.contact`) are the true ones; the
difference the other hand made is put back in one step while this hand is farthest from the
object.

:func:`holding` says on which samples a hand holds an object (its TCP, the midpoint of the thumb
and index tips, on or inside the object's box, or both tips on it), the evidence the lanes are
reconciled with (:mod:`lfd.segmentation.lanes`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..demo import Demonstration, HandTrack, ObjectTrack
from ..geometry import box_distance
from ..preprocessing.filters import finite_runs
from ..rules import Number, Rule, check_fields

THUMB_TIP, INDEX_TIP = 4, 8
"""MediaPipe-21 keypoints of the thumb and index tips (the TCP is their midpoint)."""


@dataclass(frozen=True)
class AttributionParams:
    """Distances of the two-hand attribution (metres).

    Attributes
    ----------
    near_m : float
        A hand farther than this from an object's box (TCP) is away from it: the object's
        motion there is not this hand's (above the contact rules' 8 cm approach distance).
    hold_m : float
        A hand holds an object when its TCP is within this of the box, or both its thumb and
        index tips are.
    moved_m : float
        An object displaced less than this while a hand is away keeps its true pose in that
        hand's view (nothing to take out).
    """

    near_m: float = 0.10
    hold_m: float = 0.015
    moved_m: float = 0.01

    def __post_init__(self) -> None:
        check_fields(self, ATTRIBUTION_RULES, "hands.")


ATTRIBUTION_RULES: dict[str, Rule] = dict.fromkeys(
    ("near_m", "hold_m", "moved_m"), Number(0.0, 10.0, "m")
)
"""What each :class:`AttributionParams` field holds (:mod:`lfd.rules`)."""


def _nearest(hand: HandTrack, t_ns: np.ndarray) -> np.ndarray:
    """The index of ``hand``'s sample nearest each of ``t_ns`` (``hand`` not empty)."""
    i = np.clip(np.searchsorted(hand.t_ns, t_ns), 0, len(hand) - 1)
    prev = np.maximum(i - 1, 0)
    return np.where(np.abs(hand.t_ns[prev] - t_ns) <= np.abs(hand.t_ns[i] - t_ns), prev, i)


def _at(hand: HandTrack, t_ns: np.ndarray, k: int, i: np.ndarray | None = None) -> np.ndarray:
    """Keypoint ``k`` of ``hand`` at times ``t_ns`` (the nearest hand sample, or the samples
    ``i``; NaN if none)."""
    if not len(hand):
        return np.full((len(t_ns), 3), np.nan)
    return np.asarray(hand.keypoints[_nearest(hand, t_ns) if i is None else i, k])


def tip_distances(hand: HandTrack, obj: ObjectTrack, how_many: int = 3) -> tuple[np.ndarray, ...]:
    """Distances (m) of the hand's TCP, thumb tip and index tip (the first ``how_many`` of
    them) from the object's box at the object's samples (NaN where either is unknown)."""
    i = _nearest(hand, obj.t_ns) if len(hand) else None
    thumb = _at(hand, obj.t_ns, THUMB_TIP, i)
    index = _at(hand, obj.t_ns, INDEX_TIP, i)
    points = (0.5 * (thumb + index), thumb, index)[:how_many]
    return tuple(box_distance(p, obj.position, obj.quaternion, obj.size) for p in points)


def hand_distance(hand: HandTrack, obj: ObjectTrack, t_ns: np.ndarray | None = None) -> np.ndarray:
    """The distance (m) of the hand's nearest keypoint from the object's box at times ``t_ns``
    (default: the object's samples; the object's nearest sample): a Push touches with the back
    of the fingers, not the TCP. ``inf`` where unknown."""
    t = obj.t_ns if t_ns is None else np.asarray(t_ns)
    i = np.clip(np.searchsorted(obj.t_ns, t), 0, max(len(obj) - 1, 0))
    pos, quat = obj.position[i], obj.quaternion[i]
    at = _nearest(hand, t) if len(hand) else None
    d = np.stack([box_distance(_at(hand, t, k, at), pos, quat, obj.size) for k in range(21)])
    with np.errstate(invalid="ignore"):
        return np.asarray(np.min(np.where(np.isfinite(d), d, np.inf), axis=0))


def holding(
    hand: HandTrack, obj: ObjectTrack, params: AttributionParams | None = None
) -> np.ndarray:
    """``(m,)`` bool at the object's samples: the hand holds the object (see the module)."""
    p = params or AttributionParams()
    tcp, thumb, index = tip_distances(hand, obj)
    with np.errstate(invalid="ignore"):
        return np.asarray((tcp <= p.hold_m) | ((thumb <= p.hold_m) & (index <= p.hold_m)))


def _object_view(obj: ObjectTrack, tcp_d: np.ndarray, p: AttributionParams) -> ObjectTrack:
    """``obj`` as a hand at TCP distance ``tcp_d`` sees it (see :func:`hand_view`)."""
    with np.errstate(invalid="ignore"):
        away = tcp_d > p.near_m
    pos, quat = obj.position.copy(), obj.quaternion.copy()
    known = np.isfinite(pos).all(axis=1) & np.isfinite(quat).all(axis=1)
    for a, b in finite_runs(away):
        ok = np.isfinite(pos[a:b]).all(axis=1)
        if ok.sum() < 2:
            continue
        seen = pos[a:b][ok]
        if np.linalg.norm(seen - seen[0], axis=1).max() < p.moved_m:
            continue
        # the object stands still where the hand left it and where it finds it again; the
        # step between the two falls where the hand is farthest from it
        k = a + int(np.nanargmax(np.where(ok, tcp_d[a:b], -np.inf)))
        # the reference poses are seen ones: the last before the run (else its first), the
        # first after it (else the last before)
        before = np.flatnonzero(known[:a])
        after = b + np.flatnonzero(known[b:])
        first_in = a + int(np.argmax(ok))
        left = int(before[-1]) if len(before) else (int(after[0]) if len(after) else first_in)
        right = int(after[0]) if len(after) else left
        pos[a:k], quat[a:k] = obj.position[left], obj.quaternion[left]
        pos[k:b], quat[k:b] = obj.position[right], obj.quaternion[right]
        hidden = a + np.flatnonzero(~obj.visible[a:b])
        pos[hidden], quat[hidden] = np.nan, np.nan
    return dataclasses.replace(obj, position=pos, quaternion=quat)


def filled(obj: ObjectTrack) -> ObjectTrack:
    """``obj`` with the poses it was not seen at filled in (positions interpolated, the nearest
    seen orientation before, else after): contact is measured through short occlusions (a
    hand hides what it holds)."""
    ok = np.isfinite(obj.position).all(axis=1) & np.isfinite(obj.quaternion).all(axis=1)
    if ok.all() or not ok.any():
        return obj
    t = obj.t_ns.astype(np.float64)
    pos = np.stack([np.interp(t, t[ok], obj.position[ok, k]) for k in range(3)], axis=1)
    seen = np.maximum.accumulate(np.where(ok, np.arange(len(obj)), -1))
    first = int(np.argmax(ok))
    quat = obj.quaternion[np.where(seen >= 0, seen, first)]
    return dataclasses.replace(obj, position=pos, quaternion=quat)


def hand_view(
    demo: Demonstration,
    side: str,
    params: AttributionParams | None = None,
    tcp: dict[str, np.ndarray] | None = None,
) -> Demonstration:
    """The ``side`` hand alone (:meth:`Demonstration.one_hand`), with every object standing
    still while this hand is away from it and the other hand moves it (see the module). A
    one-hand demonstration is returned as that hand alone, unchanged. ``tcp``: the hand's TCP
    distances from each object at its samples, when known (:func:`tip_distances`)."""
    alone = demo.one_hand(side)
    if len(demo.sides) < 2:
        return alone
    p = params or AttributionParams()
    hand = demo.hands[side]
    objects = {
        name: _object_view(obj, tcp[name] if tcp else tip_distances(hand, obj, 1)[0], p)
        if len(obj)
        else obj
        for name, obj in demo.objects.items()
    }
    return dataclasses.replace(alone, objects=objects)
