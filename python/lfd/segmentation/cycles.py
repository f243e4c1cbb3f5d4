"""Every carry contact shows is one carry (docs/skills.md "Boundaries"; issue 41): a hand's
repeated pick-carry-place cycles, one hand.

The templates may read a short low lift as part of a long Pick up or Place, or two carries of one
object as one Move with. Contact does not: an object is carried while the hand holds it (TCP
within 2 cm of its box) and it is off the table (3 cm or more above where it rests;
:func:`lfd.segmentation.episodes.carries`, the rules the two-hand lanes use). Where a carry is in no
Move with of its object, or shares one with another carry, the carries replace the search's
skills of that object around them (Pick up, Move with, Place, a Move between two carries); the
contact rules (:func:`lfd.contact.refine`) then put their boundaries. Elsewhere nothing
changes: the search keeps its skills, its scores and its Stacks.
"""

from __future__ import annotations

from itertools import pairwise

import numpy as np

from ..geometry import box_distance
from ..preprocessing.filters import finite_runs
from ..skills import RELEASES, Draft, allowed
from ..trajectory import Trajectory
from .episodes import CarryParams

PUSHED_M = 0.01
"""A Push moves its object this far or more (docs/skills.md: 5-12 cm); an object that stays
where it is was not pushed: the hand only passed near it (a Move). The two-hand lanes use it
too (:class:`lfd.segmentation.lanes.LaneParams`)."""

LIFTED_M = 0.01
"""An object lower than this above where it rests lowest is set down (it rises 3 cm in a
carry): noise and a slow last descent do not split a carry."""

CARRY = frozenset({"pick_up", "move_with", *RELEASES})
"""The skills of a carry."""


def carries_by_contact(
    traj: Trajectory, drafts: list[Draft], params: CarryParams | None = None, min_move: int = 3
) -> list[Draft]:
    """``drafts`` (contiguous, covering ``traj``) with every object's flights held by the hand
    made carries where one is in no Move with of the object or shares one with another, or one
    Move with of it is split (see the module); a Move of at least ``min_move`` samples is put
    between a release and what follows it."""
    p = params or CarryParams()
    out = list(drafts)
    if not out or traj.dt <= 0:
        return out
    for o in range(len(traj.object_names)):
        pos = np.asarray(traj.object_position[o], dtype=float)
        if not np.isfinite(pos[:, 2]).any():
            continue
        dist = box_distance(traj.tcp, pos, traj.object_quaternion[o], traj.object_size[o])
        flights = _flights(pos[:, 2] - np.nanmin(pos[:, 2]), dist, p)
        if all(_one_to_one(out, o, flights, i) for i in range(len(flights))):
            continue
        got = _overlaid(out, o, flights, min_move)
        if got is not None:
            out = got
    return out


def _flights(z: np.ndarray, dist: np.ndarray, p: CarryParams) -> list[tuple[int, int]]:
    """The runs ``[u, v)`` in which the object is ``LIFTED_M`` or more above where it rests
    lowest (``z``) and rises ``lifted_m`` or more, the hand's TCP within ``release_m`` of its
    box for half of it or more (the hand carries it): the object set down between two of them (lower than ``LIFTED_M``),
    they are two carries."""
    up = np.nan_to_num(z, nan=0.0) >= LIFTED_M
    return [
        (u, v)
        for u, v in finite_runs(up)
        if np.nanmax(z[u:v]) >= p.lifted_m and np.mean(dist[u:v] <= p.release_m) >= 0.5
    ]


def _one_to_one(drafts: list[Draft], o: int, flights: list[tuple[int, int]], i: int) -> bool:
    """Is flight ``i`` of object ``o`` in a Move with of it that holds no other flight? (A
    flight in two Move withs is no miss: contact joins two carries whose object rests less than
    ``gap_s`` between them.)"""
    a, b = flights[i]
    mine = [
        d for d in drafts if d.skill == "move_with" and d.obj == o and d.start < b and a < d.end
    ]
    return len(mine) == 1 and sum(mine[0].start < y and x < mine[0].end for x, y in flights) == 1


def _overlaid(
    drafts: list[Draft], o: int, flights: list[tuple[int, int]], min_move: int
) -> list[Draft] | None:
    """The drafts with the stretch of their carries of ``o`` around the ``flights`` made one
    carry per flight (Pick up, Move with over the flight, Place, a Move to the next Pick up: the
    contact rules then put the boundaries); None when the result breaks the grammar."""
    n = drafts[-1].end
    skill = np.array([d.skill for d in drafts for _ in range(d.end - d.start)], dtype=object)
    obj = np.array([d.obj for d in drafts for _ in range(d.end - d.start)], dtype=object)
    src = np.array([k for k, d in enumerate(drafts) for _ in range(d.end - d.start)])
    lo, hi = flights[0][0], flights[-1][1]
    for d in drafts:  # the drafts' carries of o around the flights
        if d.skill in CARRY and d.obj == o and d.start < hi and lo < d.end:
            lo, hi = min(lo, d.start), max(hi, d.end)
    k0 = int(src[lo])
    while k0 > 0 and drafts[k0].skill in ("move_with", *RELEASES) and drafts[k0 - 1].obj == o:
        k0 -= 1  # the carry the stretch begins in, from its Pick up
    k1 = int(src[hi - 1])
    while k1 + 1 < len(drafts) and drafts[k1].skill in ("pick_up", "move_with"):
        k1 += 1  # the carry the stretch ends in, to its release
    lo, hi = drafts[k0].start, drafts[k1].end
    inside = [(u, v) for u, v in flights if lo <= u and v <= hi]
    if not inside:
        return None
    skill[lo:hi], obj[lo:hi], src[lo:hi] = "move", None, -1
    release = "stack" if drafts[k1].skill == "stack" else "place"
    prev = lo
    for j, (u, v) in enumerate(inside):
        nxt = inside[j + 1][0] if j + 1 < len(inside) else None
        skill[prev:u], obj[prev:u] = "pick_up", o
        skill[u:v], obj[u:v] = "move_with", o
        third = (nxt - v) // 3 if nxt is not None else None
        end = v + max(third, 1) if third is not None else hi
        skill[v:end], obj[v:end] = release, o
        prev = nxt - max(third or 0, 1) if nxt is not None else hi
    runs: list[Draft] = []
    k = 0
    while k < n:
        e = k + 1
        while e < n and skill[e] == skill[k] and obj[e] == obj[k] and src[e] == src[k]:
            e += 1
        runs.append(
            drafts[src[k]].resized(k, e) if src[k] >= 0 else Draft(str(skill[k]), k, e, obj[k])
        )
        k = e
    return _tidied(runs, min_move)


def _tidied(runs: list[Draft], min_move: int) -> list[Draft] | None:
    """``runs`` with neighbours of one skill and object joined and a Move put between a
    release and what may only follow a Move; None if it breaks the grammar."""
    out: list[Draft] = []
    for r in runs:
        prev = out[-1] if out else None
        if prev is not None and prev.skill == r.skill and (prev.obj == r.obj or r.skill == "move"):
            out[-1] = prev.resized(prev.start, r.end)
            continue
        if (
            prev is not None
            and prev.skill in RELEASES
            and r.skill != "move"
            and r.end - r.start > 1
        ):
            cut = r.start + min(min_move, r.end - r.start - 1)
            out += [Draft("move", r.start, cut), r.resized(cut, r.end)]
            continue
        out.append(r)
    ok = allowed(None, out[0].skill) and all(allowed(a.skill, b.skill) for a, b in pairwise(out))
    return out if ok else None


def is_reach_hesitation(skill: str, obj: object, nxt_skill: str, nxt_obj: object) -> bool:
    """Is ``skill`` on ``obj`` followed by ``nxt_skill`` on ``nxt_obj`` a Locate that is the
    hesitation of the reach into the Pick up after it (docs/skills.md: a Locate is not that;
    it is part of the Move before the Pick up)? One rule for one hand
    (:func:`hovers_and_turns`) and two (:mod:`lfd.segmentation.lanes`)."""
    return skill == "locate" and nxt_skill == "pick_up" and (nxt_obj == obj or obj is None)


def hovers_and_turns(traj: Trajectory, drafts: list[Draft], approach_m: float) -> list[Draft]:
    """``drafts`` with a Locate that is the hesitation of a reach (:func:`is_reach_hesitation`)
    made a Move, and a Push of an object followed by a Move and a Pick up of it, the TCP never
    ``approach_m`` from its box between them, made part of that Pick up (a turn or slide on the
    table before the grasp that lifts it, docs/skills.md); neighbouring Moves joined."""
    out = list(drafts)
    for k in range(len(out) - 1):
        d, nxt = out[k], out[k + 1]
        if is_reach_hesitation(d.skill, d.obj, nxt.skill, nxt.obj):
            out[k] = Draft("move", d.start, d.end, d.obj)
    k = 0
    while k + 2 < len(out):
        push, move, pick = out[k : k + 3]
        o = push.obj
        if (
            push.skill == "push"
            and move.skill == "move"
            and pick.skill == "pick_up"
            and o is not None
            and pick.obj == o
        ):
            pos, quat = traj.object_position[o], traj.object_quaternion[o]
            a, b = move.start, move.end
            dist = box_distance(traj.tcp[a:b], pos[a:b], quat[a:b], traj.object_size[o])
            if not (dist >= approach_m).any():
                out[k : k + 3] = [pick.resized(push.start, pick.end)]
                continue
        k += 1
    joined: list[Draft] = []
    for d in out:
        if joined and joined[-1].skill == d.skill == "move":
            joined[-1] = joined[-1].resized(joined[-1].start, d.end)
        else:
            joined.append(d)
    return joined


def displacement(pos: np.ndarray, a: int, b: int) -> float:
    """How far an object ``pos`` ``(n, 3)`` gets from where it was at sample ``a`` within
    ``a..b`` (0 when it is never seen there): the one measure of whether a Push pushed."""
    seg = np.asarray(pos[a:b], dtype=float)
    seen = np.isfinite(seg).all(axis=1)
    if not seen.any():
        return 0.0
    seg = seg[seen]
    return float(np.max(np.linalg.norm(seg - seg[0], axis=1)))


def grasps_and_pushes(traj: Trajectory, drafts: list[Draft]) -> list[Draft]:
    """``drafts`` with a Pick up directly followed by a Move with of another object made a Pick
    up of that object (the grasp is of the object it lifts), and a Push whose object moves less
    than ``PUSHED_M`` by the end of the skill after it made a Move (docs/skills.md: a Push
    displaces its object); neighbouring Moves joined."""
    out = list(drafts)
    for k, d in enumerate(out):
        nxt = out[k + 1] if k + 1 < len(out) else None
        if d.skill == "pick_up" and nxt is not None and nxt.skill == "move_with":
            if nxt.obj is not None and nxt.obj != d.obj:
                out[k] = Draft("pick_up", d.start, d.end, nxt.obj)
        elif d.skill == "push" and d.obj is not None:
            end = nxt.end if nxt is not None else d.end
            if displacement(traj.object_position[d.obj], d.start, end) < PUSHED_M:
                out[k] = Draft("move", d.start, d.end, d.obj)
    joined: list[Draft] = []
    for d in out:
        if joined and joined[-1].skill == d.skill == "move":
            joined[-1] = joined[-1].resized(joined[-1].start, d.end)
        else:
            joined.append(d)
    return joined
