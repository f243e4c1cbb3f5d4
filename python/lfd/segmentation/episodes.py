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
from itertools import pairwise

import numpy as np

from ..contact import lift_off
from ..preprocessing.filters import finite_runs
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
    moved_m, rest_samples : float, int
        The lift begins after the last ``rest_samples`` samples in which the object moved less
        than ``moved_m`` (it rested).
    lifted_m : float
        The object is off the table (in flight) this high above where it rests.
    place_m : float
        A Place begins where the object was last this far above where it is let go.
    regrip_s : float
        A hand that lets go of an object in flight (the other hand holding it), its TCP
        ``release_m`` off it for less than this long, and grasps it again carries on (a regrip).
    thumb_m : float
        A hand resting on a set-down object has let go once its thumb tip is this much farther
        from the box (or its TCP ``release_m`` farther).
    still_s, still_m : float
        A grasp of an object on the table (never in flight during it) that lasts this long (s)
        or longer while the object moves less than ``still_m`` (m) holds it still: a Pick up,
        a Move with of the still object and a Place (its last ``let_go_s`` before the hand lets
        go), as a hand holding an object still while the other acts.
    moved_off_m : float
        A hand holding an object in the air with the other hand has let go once its TCP's
        signed distance from the box is this much (m) above where it held it, for good.
    handover_s, let_go_s : float
        A hand that lets go of an object in the air which the other hand has held for at most
        ``handover_s`` gives it (a handover: its Place lasts from the other hand's grasp);
        after a longer two-handed carry its Place is the last ``let_go_s`` before it lets go.
    """

    hold_m: float = 0.02
    gap_s: float = 0.5
    min_hold_s: float = 0.2
    release_m: float = 0.03
    approach_m: float = 0.08
    moved_m: float = 0.002
    rest_samples: int = 3
    lifted_m: float = 0.03
    place_m: float = 0.05
    regrip_s: float = 1.0
    take_s: float = 0.5
    thumb_m: float = 0.01
    handover_s: float = 3.0
    let_go_s: float = 0.5
    still_s: float = 1.0
    moved_off_m: float = 0.012
    still_m: float = 0.015


def _grasps(dist: np.ndarray, dt: float, p: CarryParams) -> list[tuple[int, int]]:
    """The grasps ``[a, b)``: holds with short lapses (the TCP staying within ``release_m``)
    closed, short touches dropped."""
    gap = max(1, round(p.gap_s / dt))
    merged: list[tuple[int, int]] = []
    for a, b in finite_runs(dist <= p.hold_m):
        if merged and a - merged[-1][1] <= gap and (dist[merged[-1][1] : a] < p.release_m).all():
            merged[-1] = (merged[-1][0], b)
        else:
            merged.append((a, b))
    return [(a, b) for a, b in merged if b - a >= max(1, round(p.min_hold_s / dt))]


def _aloft(z: np.ndarray, dt: float, p: CarryParams) -> list[tuple[int, int]]:
    """The runs ``[u, v)`` in which the object is off the table (short dips closed)."""
    with np.errstate(invalid="ignore"):
        runs = finite_runs(np.nan_to_num(z, nan=0.0) >= p.lifted_m)
    gap = max(1, round(p.gap_s / dt))
    out: list[tuple[int, int]] = []
    for u, v in runs:
        if out and u - out[-1][1] <= gap:
            out[-1] = (out[-1][0], v)
        else:
            out.append((u, v))
    return out


def _holds_aloft(
    grasps: list[tuple[int, int]], u: int, v: int, dt: float, p: CarryParams, dist: np.ndarray
) -> list[tuple[int, int]]:
    """The grasps that hold the object during its flight ``[u, v)``, regrips joined: between
    them the hand was never ``release_m`` off the object for ``regrip_s`` or longer."""
    regrip = max(1, round(p.regrip_s / dt))
    out: list[tuple[int, int]] = []
    for a, b in grasps:
        if b <= u or a >= v:
            continue
        if out and a < v:
            off = finite_runs(dist[out[-1][1] : a] >= p.release_m)
            if not off or max(y - x for x, y in off) < regrip:
                out[-1] = (out[-1][0], b)
                continue
        out.append((a, b))
    return out


def _released(dist: np.ndarray, thumb: np.ndarray | None, k: int, stop: int, p: CarryParams) -> int:
    """Where a hand resting on a set-down object at ``k`` lets go (before ``stop``): its TCP
    ``release_m`` farther from the box than at ``k``, or its thumb tip ``thumb_m`` farther."""
    ref = dist[k]
    off = dist[k:stop] > max(ref, 0.0) + p.release_m
    if thumb is not None:
        with np.errstate(invalid="ignore"):
            off |= thumb[k:stop] > max(float(np.nan_to_num(thumb[k])), 0.0) + p.thumb_m
    hit = np.flatnonzero(off)
    return k + int(hit[0]) if len(hit) else stop


def _at_rest(position: np.ndarray, v: int, stop: int, p: CarryParams) -> int:
    """Where an object set down at ``v`` (back on the table) has come to rest: the first
    sample in ``[v, stop)`` after ``rest_samples`` in which it moved less than ``moved_m``
    (``v`` if it never does, the last sample at most)."""
    n = len(position)
    k = p.rest_samples
    for i in range(max(v, k - 1), min(stop, n)):
        step = np.linalg.norm(position[i] - position[i - k + 1 : i], axis=1)
        if np.isfinite(step).all() and (step < p.moved_m).all():
            return i
    return min(v, n - 1)


def _let_go_in_air(depth: np.ndarray, took: int, b: int, dt: float, p: CarryParams) -> int:
    """Where a hand holding an object in the air with the other hand (since ``took``; its
    hold ending at ``b``, the TCP ``hold_m`` off the box) lets go: after the last sample at
    which its TCP's signed distance from the box (``depth``: negative inside) is less than
    ``moved_off_m`` above where it held the object (the median of its last ``let_go_s``
    before ``took``; a median of three samples: a one-sample jitter is no let-go), and
    before it is first ``release_m`` outside the box (the other hand may then carry the
    object past it). A hand turning with the object keeps its depth; one withdrawing from
    it does not. ``b`` when it never leaves before."""
    k = max(1, round(p.let_go_s / dt))
    ref = depth[max(took - k, 0) : took + 1]
    ref = ref[np.isfinite(ref)]
    if not len(ref) or b - took < 3:
        return b
    out = np.flatnonzero(depth[took:b] >= p.release_m)  # clearly off: let go before
    stop = took + int(out[0]) if len(out) else b
    d = depth[took:stop] - float(np.median(ref))
    if len(d) >= 3:
        d = np.median(np.stack([d, np.r_[d[1:], d[-1]], np.r_[d[0], d[:-1]]]), axis=0)
    near = np.flatnonzero(~(d >= p.moved_off_m))
    return took + int(near[-1]) + 1 if len(near) else stop


def carries(
    dist: np.ndarray,
    position: np.ndarray,
    table_z: float,
    dt: float,
    params: CarryParams | None = None,
    other_hold: np.ndarray | None = None,
    thumb: np.ndarray | None = None,
    depth: np.ndarray | None = None,
) -> list[tuple[str, int, int]]:
    """The carries of one hand and one object, as ``(skill, start, end)`` spans (samples,
    ``end`` exclusive): Pick up, Move with, Place for every flight of the object (off the
    table) that this hand holds it in. ``dist`` is the TCP's distance from the box (``inf``
    unknown), ``thumb`` the thumb tip's, ``position`` the object's centre ``(n, 3)``,
    ``table_z`` the lowest the object rests; ``other_hold``: where the other hand holds the
    object (a carry let go of in the air ends with a Place from the other hand's grasp: the
    handover); ``depth``: the TCP's signed distance from the box (negative inside; a giver
    has let go where its TCP last left the depth it held the object at,
    :func:`_let_go_in_air`)."""
    p = params or CarryParams()
    n = len(dist)
    z = position[:, 2] - table_z
    grasps = _grasps(dist, dt, p)
    flights = _aloft(z, dt, p)
    out: list[tuple[str, int, int]] = []
    last = 0
    for f, (u, v) in enumerate(flights):
        next_u = flights[f + 1][0] if f + 1 < len(flights) else n
        for a, b in _holds_aloft(grasps, u, v, dt, p, dist):
            a = max(a, last)
            if a <= u:  # this hand lifts it off the table: from where it last rested
                lift = lift_off(position, a, u, p.moved_m, p.rest_samples)
            elif b - a < round(p.take_s / dt):
                continue  # a touch of an object the other hand carries: not a grasp
            else:  # taken in the air
                lift = a
            far = np.flatnonzero(dist[last:a] >= p.approach_m)
            start = last + int(far[-1]) if len(far) else last
            start = min(start, lift)
            if b >= v == n:  # still carried when the recording ends
                if lift < n:
                    if start < lift:
                        out.append(("pick_up", start, lift))
                    elif out and out[-1][0] == "place" and out[-1][2] >= lift:
                        out.pop()
                        lift = out.pop()[1]
                    out.append(("move_with", lift, n))
                break
            held_on = other_hold is not None and bool(other_hold[b - 1])
            if b >= v:  # set down: the Place from the last 5 cm above the table
                high = np.flatnonzero(np.nan_to_num(z[lift:v]) >= p.place_m)
                place = lift + int(high[-1]) + 1 if len(high) else v
                release = _released(dist, thumb, _at_rest(position, v, next_u, p), next_u, p)
            elif not held_on:  # set down on something (another object): from 5 cm above it
                high = np.flatnonzero(np.nan_to_num(z[lift:b] - z[b - 1]) >= p.place_m)
                place = lift + int(high[-1]) + 1 if len(high) else b - 1
                release = _released(dist, thumb, b - 1, next_u, p)
            else:  # let go in the air, the other hand holding it: a handover
                place = b - max(1, round(p.let_go_s / dt))
                took = np.flatnonzero(~other_hold[lift : b - 1])  # type: ignore[index]
                took_at = lift + int(took[-1]) + 1 if len(took) else lift + 1
                release = b
                if b - took_at <= round(p.handover_s / dt):
                    place = took_at
                    if depth is not None:
                        release = _let_go_in_air(depth, took_at, b, dt, p)
            place = min(max(place, lift + 1), release - 1)
            if not lift < place < release:
                continue
            if start < lift:
                out.append(("pick_up", start, lift))
            elif out and out[-1][0] == "place" and out[-1][2] >= lift:
                # grasped again as it let go, without a reach: one carry (no Place between)
                out.pop()
                lift = out.pop()[1]
            out += [("move_with", lift, place), ("place", place, release)]
            last = release
    return out


def still_holds(
    dist: np.ndarray,
    position: np.ndarray,
    table_z: float,
    dt: float,
    params: CarryParams | None = None,
    thumb: np.ndarray | None = None,
    *,
    complete: bool = True,
) -> list[tuple[str, int, int]]:
    """The holds of one hand on one object that stays on the table, as ``(skill, start, end)``
    spans like :func:`carries` (``dist``: the nearer of the TCP and the thumb tip, a hand
    holding an object down with its thumb and another finger): a grasp of ``still_s`` or longer, the object never in flight
    and moving less than ``still_m`` during it, is a Pick up (from where the TCP was last
    ``approach_m`` off), a Move with of the still object and a Place (its last ``let_go_s``
    before the hand lets go: its TCP ``release_m`` or thumb tip ``thumb_m`` farther off than
    while it held). A grasp that turns or slides the object is not one (the Pick up of a later
    lift, as for one hand). In a recording still being made (``complete`` False) a grasp held at
    its end is no hold yet: it may still lift the object."""
    p = params or CarryParams()
    n = len(dist)
    z = np.nan_to_num(position[:, 2] - table_z, nan=0.0)
    out: list[tuple[str, int, int]] = []
    last = 0
    grasps = _grasps(dist, dt, p)
    for j, (a, b) in enumerate(grasps):
        if b - a < round(p.still_s / dt) or (z[a:b] >= p.lifted_m).any():
            continue
        seen = position[a:b][np.isfinite(position[a:b]).all(axis=1)]
        if not len(seen) or np.linalg.norm(seen - seen[0], axis=1).max() >= p.still_m:
            continue
        stop = grasps[j + 1][0] if j + 1 < len(grasps) else n
        release = _released(dist, thumb, a + (b - a) // 2, stop, p) if b < n else n
        far = np.flatnonzero(dist[last:a] >= p.approach_m)
        start = last + int(far[-1]) if len(far) else last
        if release >= n:  # still held when the recording ends
            if not complete:
                break
            out += [("pick_up", start, a)] if start < a else []
            out.append(("move_with", a, n))
            break
        place = max(a + 1, release - max(1, round(p.let_go_s / dt)))
        if not a < place < release:
            continue
        out += [("pick_up", start, a)] if start < a else []
        out += [("move_with", a, place), ("place", place, release)]
        last = release
    return out


_PAIRS: dict[str, tuple[frozenset[str], frozenset[str]]] = {
    "pick_up": (frozenset({"move", "locate"}), frozenset({"pick_up"})),
    "move_with": (frozenset({"pick_up"}), frozenset({"move_with"})),
    "place": (frozenset({"move_with"}), frozenset({"place", "stack"})),
    "end": (frozenset({"place", "stack"}), frozenset({"move"})),
}
"""The lane's boundary each carry boundary may snap to: where a span of this skill begins
(``end``: where a carry's Place ends), the skills before and after it."""


def snap(
    spans: list[tuple[str, int, int]],
    segments: list[Segment],
    name: str,
    tol: int,
    other_hold: np.ndarray | None = None,
) -> list[tuple[str, int, int]]:
    """The carries ``spans`` (of object ``name``) with each boundary moved to the lane's
    boundary between the same skills on the same object within ``tol`` samples, where there
    is one (the templates' boundaries, refined by the one-hand contact rules), keeping the
    spans in order. A Place the hand ends while ``other_hold`` (the other hand holds the
    object: a handover) keeps its contact boundaries."""
    found: dict[str, list[int]] = {k: [] for k in _PAIRS}
    for prev, nxt in pairwise(segments):
        for key, (before, after) in _PAIRS.items():
            obj = prev.object if key == "end" else nxt.object
            if prev.skill in before and nxt.skill in after and obj == name:
                found[key].append(nxt.start)
    starts = [a for _, a, _ in spans]
    ends = [b for _, _, b in spans]
    for i, (skill, a, b) in enumerate(spans):
        if skill == "place" and other_hold is not None and other_hold[b - 1]:
            continue
        edges: list[tuple[str, int, bool]] = [(skill, a, True)] if skill in _PAIRS else []
        if skill == "place" and (i + 1 == len(spans) or spans[i + 1][0] == "pick_up"):
            edges.append(("end", b, False))
        for key, at, is_start in edges:
            near = [x for x in found[key] if abs(x - at) <= tol]
            if not near:
                continue
            to = min(near, key=lambda x: abs(x - at))
            if is_start:
                lo, hi = (starts[i - 1] + 1 if i else 0), ends[i] - 1
            else:
                lo, hi = starts[i] + 1, (starts[i + 1] - 1 if i + 1 < len(spans) else to)
            if not lo <= to <= hi:
                continue
            if is_start:
                starts[i] = to
                if i and ends[i - 1] == at:
                    ends[i - 1] = to
            else:
                ends[i] = to
    return [(sk, a, b) for (sk, _, _), a, b in zip(spans, starts, ends, strict=True) if b > a]


def overlay(
    segments: list[Segment], spans: dict[str, list[tuple[str, int, int]]], times: np.ndarray
) -> list[Segment]:
    """``segments`` (a lane, covering samples ``0..n``) with the carries of ``spans`` (per
    object name) put on it: outside them no Pick up, Move with or Place of an object with a
    carry is left (a Move instead), inside them the carry's skills on its object; a Stack the templates found where
    a carry's Place is stays a Stack. ``times``: each sample's seconds, and the end's."""
    n = segments[-1].end
    skill = np.empty(n, dtype=object)
    obj = np.empty(n, dtype=object)
    src = np.full(n, -1)
    for i, s in enumerate(segments):
        # the carries of an object contact finds none of are the templates' (the lanes check
        # that the hand touches it): contact may miss every grasp of a noisy hand
        keep = s.skill not in CARRY_SKILLS or not spans.get(s.object or "")
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
