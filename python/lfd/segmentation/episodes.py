"""A hand's carries from contact (docs/skills.md, "Two hands"): where a hand grasps an object
and lifts it (or takes it from the other hand in the air), carries it and lets it go.

Two hands make a lane's carries ambiguous to the templates (the object moves while this hand
rests on it, is held by both, changes hands); contact is not: a hand carries an object exactly
while it holds it and the object is off the table. :func:`carries` finds each carry's Pick up,
Move with and Place by the contact rules of docs/skills.md ("Boundaries": the approach from
8 cm, the lift where the object first moves in the grasp, the Place from the last 5 cm above
where it comes to rest, the release when the TCP is 3 cm off); :func:`overlay` puts them on a
lane the templates segmented (:mod:`lfd.segmentation.lanes`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from .result import Segment

CARRY_SKILLS: frozenset[str] = frozenset({"pick_up", "move_with", "place"})
"""The skills of a carry: outside the carries contact finds, a lane has none of them."""


@dataclass(frozen=True)
class CarryParams:
    """Distances (m) and times (s) of :func:`carries`.

    Attributes
    ----------
    hold_m : float
        The hand holds the object while its TCP is within this of the box.
    gap_s : float
        Shorter lapses of the hold are the same grasp.
    min_hold_s : float
        Shorter holds are touches, not grasps.
    release_m : float
        The grasp has let go once the TCP is this far from the box.
    approach_m : float
        A Pick up begins where the TCP was last this far from the box.
    moved_m : float
        The lift begins where the object has moved this far from where the grasp found it.
    lifted_m : float
        A grasp carries the object when it lifts it this high, or finds it this high above the
        table (taken from the other hand).
    place_m : float
        A Place begins where the object was last this far above where it is let go.
    regrip_s : float
        A hand that lets go of an object in the air (the other hand holding it) and grasps it
        again within this long, the object in the air all along, carries on (a regrip).
    """

    hold_m: float = 0.02
    gap_s: float = 0.5
    min_hold_s: float = 0.2
    release_m: float = 0.03
    approach_m: float = 0.08
    moved_m: float = 0.005
    lifted_m: float = 0.03
    place_m: float = 0.05
    regrip_s: float = 1.5


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    padded = np.concatenate(([False], mask, [False]))
    edges = np.flatnonzero(np.diff(padded.astype(np.int8)))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)]


def _grasps(dist: np.ndarray, z: np.ndarray, dt: float, p: CarryParams) -> list[tuple[int, int]]:
    """The grasps ``[a, b)``: holds with short lapses closed (and regrips of an object kept in
    the air), short touches dropped."""
    hold = dist <= p.hold_m
    runs = _runs(hold)
    gap, regrip = max(1, round(p.gap_s / dt)), max(1, round(p.regrip_s / dt))
    merged: list[tuple[int, int]] = []
    for a, b in runs:
        prev = merged[-1][1] if merged else -1
        lapse = a - prev <= gap and (dist[prev:a] < p.release_m).all()
        with np.errstate(invalid="ignore"):
            aloft = a - prev <= regrip and bool((z[max(prev - 1, 0) : a + 1] >= p.lifted_m).all())
        if merged and (lapse or aloft):
            merged[-1] = (merged[-1][0], b)
        else:
            merged.append((a, b))
    return [(a, b) for a, b in merged if b - a >= max(1, round(p.min_hold_s / dt))]


def carries(
    dist: np.ndarray,
    position: np.ndarray,
    table_z: float,
    dt: float,
    params: CarryParams | None = None,
    other_hold: np.ndarray | None = None,
) -> list[tuple[str, int, int]]:
    """The carries of one hand and one object, as ``(skill, start, end)`` spans (samples,
    ``end`` exclusive): Pick up, Move with, Place for every grasp that lifts the object or
    takes it in the air. ``dist`` is the TCP's distance from the box (``inf`` unknown),
    ``position`` the object's centre ``(n, 3)``, ``table_z`` the lowest the object rests;
    ``other_hold``: where the other hand holds the object (a carry let go of in the air ends
    with a Place from the other hand's grasp, the handover)."""
    p = params or CarryParams()
    n = len(dist)
    out: list[tuple[str, int, int]] = []
    z = position[:, 2] - table_z
    last_end = 0
    for a, b in _grasps(dist, z, dt, p):
        if not np.isfinite(z[a:b]).any():
            continue
        in_air = z[a] >= p.lifted_m
        if not in_air and np.nanmax(z[a:b]) - z[a] < p.lifted_m:
            continue  # turned or slid on the table: no carry
        off = np.flatnonzero(dist[b:] > p.release_m)
        release = min(b + int(off[0]) if len(off) else n, n)
        if in_air:
            lift = a
        else:
            moved = np.linalg.norm(position[a:b] - position[a], axis=1) > p.moved_m
            lift = a + int(np.argmax(moved)) if moved.any() else a
        far = np.flatnonzero(dist[last_end:a] >= p.approach_m)
        start = last_end + int(far[-1]) if len(far) else last_end
        start = min(start, lift - 1) if lift > last_end else lift
        high = np.flatnonzero(z[lift:release] - z[release - 1] >= p.place_m)
        place = lift + int(high[-1]) + 1 if len(high) else lift + 1
        if z[release - 1] >= p.lifted_m and other_hold is not None and other_hold[release - 1]:
            taken = np.flatnonzero(~other_hold[lift:release])
            place = lift + int(taken[-1]) + 1 if len(taken) else lift + 1
        place = min(max(place, lift + 1), release - 1)
        if not start < lift < place < release:
            continue
        out += [("pick_up", start, lift), ("move_with", lift, place), ("place", place, release)]
        last_end = release
    return out


def overlay(
    segments: list[Segment], spans: dict[str, list[tuple[str, int, int]]], times: np.ndarray
) -> list[Segment]:
    """``segments`` (a lane, covering samples ``0..n``) with the carries of ``spans`` (per
    object name) put on it: outside them no Pick up, Move with or Place is left (a Move
    instead), inside them the carry's skills on its object; a Stack the templates found where
    a carry's Place is stays a Stack. ``times``: each sample's seconds, and the end's."""
    n = segments[-1].end
    skill = np.empty(n, dtype=object)
    obj = np.empty(n, dtype=object)
    src = np.full(n, -1)
    for i, s in enumerate(segments):
        keep = s.skill not in CARRY_SKILLS
        skill[s.start : s.end] = s.skill if keep else "move"
        obj[s.start : s.end] = s.object
        src[s.start : s.end] = i if keep else -1
    for name, got in spans.items():
        for sk, a, b in got:
            stacked = sk == "place" and (skill[a:b] == "stack").any()
            skill[a:b] = "stack" if stacked else sk
            obj[a:b] = name
            src[a:b] = -1
    # a Move takes the object of the skill after it, as the lane's Moves do
    out: list[Segment] = []
    origin = segments[0].start_ns - round(segments[0].start_s * 1e9)
    k = 0
    while k < n:
        e = k + 1
        while e < n and skill[e] == skill[k] and obj[e] == obj[k] and src[e] == src[k]:
            e += 1
        if out and out[-1].skill == skill[k] == "move":
            e0 = out.pop()
            k = e0.start
        base = segments[src[k]] if src[k] >= 0 else None
        seg = Segment(
            str(skill[k]), k, e, float(times[k]), float(times[e]),
            origin + round(times[k] * 1e9), origin + round(times[e] * 1e9), obj[k],
        )  # fmt: skip
        if base is not None and base.start == k and base.end == e:
            seg = base
        elif base is not None:
            seg = dataclasses.replace(
                seg, score=base.score, confidence=base.confidence, margin=base.margin
            )
        out.append(seg)
        k = e
    for i, s in enumerate(out):
        if s.skill == "move" and i + 1 < len(out) and out[i + 1].object is not None:
            out[i] = dataclasses.replace(s, object=out[i + 1].object)
    return out
