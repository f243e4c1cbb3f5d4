"""Contact rules: where a skill that touches an object begins and ends, from geometry alone.

The templates say *which* skill a stretch of motion is; where exactly a reach becomes a grasp, a
grasp a carry and a release a withdrawal is a matter of contact, which positions show better than
any template (docs/skills.md, "Boundaries"). These rules are shared by the segmentation
(:func:`lfd.segmentation.pipeline.segment_trajectory` refines the search's boundaries with them)
and the simulator's ground truth, so both speak of the same skill boundaries:

- **approach**: a Pick up begins at the last sample before its grasp at which the TCP is at least
  ``approach_m`` (8 cm) from the object's bounding box; what comes before it is a Move;
- **lift**: a Pick up ends, and the Move with begins, where the grasp that lifts the object
  starts to move it (back from ``lift_h_m`` of lift to where it last rested);
- **release**: a Place or Stack ends when the hand lets go of the set-down object: the thumb tip
  ``release_thumb_m`` (1 cm) or the TCP ``release_tcp_m`` (3 cm) farther from its box than while
  it held it, or the grasp aperture ``release_open_m`` (1.5 cm) wider;
  what follows is a Move.

A segment is a :class:`lfd.skills.Draft`: a skill on samples ``start..end`` (end exclusive), its
object ``obj`` an index into the object arrays or None; which skills release their object is
:data:`lfd.skills.RELEASES`. Everything here is numpy on arrays of the preprocessed samples;
nothing depends on a later stage.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from .geometry import box_distance
from .rules import Number, Rule, Whole, check_fields
from .skills import RELEASES, Draft


@dataclass(frozen=True)
class ContactParams:
    """Distances of the contact rules (metres; docs/skills.md "Boundaries").

    Attributes
    ----------
    approach_m : float
        A Pick up begins where the TCP was last this far from the object's box.
    lift_m : float
        A set-down object is within this much of its lowest height (the release is looked for
        from there).
    lift_h_m, rest_m, rest_samples : float, float, int
        The object is lifted once it is ``lift_h_m`` above its height when the grasp began; the
        motion that lifts it starts after the last ``rest_samples`` samples in which it moved
        less than ``rest_m``.
    place_h_m : float
        A Place or Stack begins where the carried object was last this far above the height at
        which it comes to rest.
    release_thumb_m, release_tcp_m, release_open_m : float
        The hand has let go once the thumb tip or the TCP is this much farther from the object's
        box than when the object came to rest, or the grasp aperture this much wider (a thumb
        on a mug's handle stays inside its bounding box).
    min_move : int
        A Move inserted before the first Pick up or after the last release has at least this
        many samples (shorter: the boundary is noise).
    """

    approach_m: float = 0.08
    lift_m: float = 0.005
    lift_h_m: float = 0.01
    rest_m: float = 0.002
    rest_samples: int = 3
    place_h_m: float = 0.05
    release_thumb_m: float = 0.01
    release_open_m: float = 0.015
    release_tcp_m: float = 0.03
    min_move: int = 3

    def __post_init__(self) -> None:
        check_fields(self, CONTACT_RULES, "contacts.")


CONTACT_RULES: dict[str, Rule] = {
    **dict.fromkeys(
        ("approach_m", "lift_m", "lift_h_m", "rest_m", "place_h_m", "release_thumb_m",
         "release_open_m", "release_tcp_m"),
        Number(0.0, 10.0, "m"),
    ),
    "rest_samples": Whole(1, 10_000),
    "min_move": Whole(1, 10_000),
}  # fmt: skip
"""What each :class:`ContactParams` field holds (:mod:`lfd.rules`; docs/method-files.md)."""


def refine(
    drafts: list[Draft],
    tcp: np.ndarray,
    thumb: np.ndarray,
    object_position: np.ndarray,
    object_quaternion: np.ndarray,
    object_size: np.ndarray,
    params: ContactParams | None = None,
    opening: np.ndarray | None = None,
    *,
    complete: bool = True,
) -> list[Draft]:
    """The contiguous ``drafts`` with their contact boundaries put where the rules above say
    (``tcp``, ``thumb`` ``(n, 3)``; ``object_position`` ``(O, n, 3)``, ``object_quaternion``
    ``(O, n, 4)``, ``object_size`` ``(O, 3)``; ``opening`` ``(n,)`` the grasp aperture, if known):

    - a Pick up, a Move with that never lifts the object, its Place and the next Pick up of the
      same object, the hand staying within ``approach_m``, are one Pick up (a turn or slide on
      the table before the grasp that lifts);
    - a Pick up followed by its Move with ends where the object first moves (lift);
    - a Pick up begins where the TCP was last ``approach_m`` from the object (after a release:
      since the release, and ``min_move`` samples after it when the hand never was that far);
      a Move is inserted before a first Pick up that began farther, and a first Move whose
      hand never was that far becomes part of the Pick up;
    - a Place or Stack followed by a Move ends where the hand lets go (release), when it does
      before the Move ends; a Move is inserted after one that ends the demonstration when the
      hand lets go before the end;
    - a Pick up that ends the demonstration whose object never moves afterwards was no grasp:
      it becomes part of the Move before it.

    The rules about the end of the demonstration (the Move after the last release, the
    never-lifted last Pick up) say how it ends: with ``complete`` False (a recording still
    being made, the live segmentation's runs) they are not applied.

    Boundaries only move between the two segments they separate, and every segment keeps at
    least one sample. The drafts given are not changed: the result holds changed copies (with
    their scores), the Moves inserted have none.
    """
    p = params or ContactParams()
    out = [dataclasses.replace(d) for d in drafts]
    n = len(tcp)
    used = {s.obj for s in out if s.obj is not None}
    d_tcp = {
        o: box_distance(tcp, object_position[o], object_quaternion[o], object_size[o]) for o in used
    }
    d_thumb = {
        o: box_distance(thumb, object_position[o], object_quaternion[o], object_size[o])
        for o in used
    }
    if complete:
        _drop_unlifted_end(out, object_position, n, p)
    _merge_table_turns(out, object_position, d_tcp, p)
    _lift_and_set_down(out, object_position, p)
    _approach(out, d_tcp, p)
    _releases(out, d_tcp, d_thumb, opening, object_position, n, p, complete)
    _reaches_after_release(out, d_tcp, p)
    return out


def _drop_unlifted_end(
    out: list[Draft], object_position: np.ndarray, n: int, p: ContactParams
) -> None:
    """A Pick up that ends the demonstration and never lifts its object was no grasp: it
    becomes part of the Move before it."""
    end = out[-1] if out else None
    if end is not None and len(out) > 1 and end.skill == "pick_up" and out[-2].skill == "move":
        if end.obj is not None and _lift(object_position[end.obj], end.start, n, p) is None:
            out[-2].end = end.end
            del out[-1]


def _merge_table_turns(
    out: list[Draft], object_position: np.ndarray, d_tcp: dict[int, np.ndarray], p: ContactParams
) -> None:
    """A turn or slide on the table: a "carry" that never lifts its object, and the grasp
    after it, are one Pick up."""
    k = 0
    while k + 3 < len(out):
        run = out[k : k + 5]
        o = run[0].obj
        skills = [s.skill for s in run]
        j = 4 if skills[3:5] == ["move", "pick_up"] else 3
        if (
            o is not None
            and skills[:2] == ["pick_up", "move_with"]
            and skills[2] in RELEASES
            and j < len(run)
            and run[j].skill == "pick_up"
            and all(s.obj in (o, None) for s in run[: j + 1])
            and _lift(object_position[o], run[0].start, run[2].end, p) is None
            and not (d_tcp[o][run[2].end : run[j].start] >= p.approach_m).any()
        ):
            run[0].end = run[j].end
            del out[k + 1 : k + j + 1]
            continue
        k += 1


def _lift_and_set_down(out: list[Draft], object_position: np.ndarray, p: ContactParams) -> None:
    """A Pick up followed by its Move with ends where the object first moves (lift); a Move
    with followed by its release where the object comes to rest (set down)."""
    for k in range(len(out) - 1):
        cur, nxt = out[k], out[k + 1]
        o = cur.obj
        if o is None or nxt.obj != o:
            continue
        t: int | None
        if cur.skill == "pick_up" and nxt.skill == "move_with":  # lift
            t = _lift(object_position[o], cur.start, nxt.end, p)
        elif cur.skill == "move_with" and nxt.skill in RELEASES:  # set down
            t = _descent(object_position[o], cur.start, nxt.end, p)
        else:
            continue
        if t is not None:
            _move_boundary(out, k, t)


def _approach(out: list[Draft], d_tcp: dict[int, np.ndarray], p: ContactParams) -> None:
    """Approach: where the reach of a Pick up begins (a Move inserted before a first Pick up
    that began farther; a first Move that never left the object joins the Pick up)."""
    k = -1
    while k + 1 < len(out):
        k += 1
        cur = out[k]
        o = cur.obj
        if cur.skill != "pick_up" or o is None:
            continue
        prev = out[k - 1] if k > 0 else None
        if prev is not None and (prev.skill != "move" or (k > 1 and out[k - 2].skill in RELEASES)):
            continue  # after a Locate, or a re-grasp: the hand stayed at the object
        lo = prev.start if prev is not None else 0
        far = d_tcp[o][lo : cur.end] >= p.approach_m
        if far.any():
            t = lo + int(np.flatnonzero(far)[-1]) + 1
            if prev is None:
                if t - cur.start >= p.min_move and t < cur.end:
                    out.insert(k, Draft("move", cur.start, t))
                    cur.start = t
            else:
                _move_boundary(out, k - 1, t)
        elif prev is not None and k == 1:  # a first Move that never left the object
            cur.start = prev.start
            del out[0]
            k -= 1


def _releases(
    out: list[Draft],
    d_tcp: dict[int, np.ndarray],
    d_thumb: dict[int, np.ndarray],
    opening: np.ndarray | None,
    object_position: np.ndarray,
    n: int,
    p: ContactParams,
    complete: bool,
) -> None:
    """Every release ends where the hand lets go (:func:`_release`): a Place or Stack followed
    by a Move ends there when the hand lets go before the Move ends; one that ends the
    demonstration (``complete``) gets a Move after it when the hand lets go before the end."""
    for k, cur in enumerate(out):
        if cur.skill not in RELEASES or cur.obj is None:
            continue
        o = cur.obj
        last = k + 1 == len(out)
        if last and complete:
            t = _release(d_tcp[o], d_thumb[o], opening, object_position[o], cur.start, n, p)
            if t is not None and cur.start < t <= n - p.min_move:
                cur.end = t
                out.append(Draft("move", t, n))
            return
        if not last and out[k + 1].skill == "move":
            hi = out[k + 1].end - 1
            t = _release(d_tcp[o], d_thumb[o], opening, object_position[o], cur.start, hi, p)
            if t is not None:
                _move_boundary(out, k, t)


def _reaches_after_release(
    out: list[Draft], d_tcp: dict[int, np.ndarray], p: ContactParams
) -> None:
    """The reach of a Pick up that follows a release (release, Move, Pick up): from the last
    sample the TCP was ``approach_m`` from the Pick up's object after the release; a hand that
    never was that far (a re-grasp at the object) reaches from ``min_move`` samples after the
    release, the shortest Move."""
    for k in range(2, len(out)):
        cur, move = out[k], out[k - 1]
        if cur.skill != "pick_up" or cur.obj is None or move.skill != "move":
            continue
        if out[k - 2].skill not in RELEASES:
            continue
        _move_boundary(
            out, k - 1, move.start + _reach_start(d_tcp[cur.obj][move.start : cur.end], p)
        )


BACK_OFF_M = 0.02
"""A hand that never goes ``approach_m`` from the object after a release but backs off this much
farther than where it let go reaches from the farthest point of its back-off."""

BACK_OFF_TOL_M = 0.005
"""The farthest point of a back-off: its last sample within this of the largest distance."""


def _reach_start(d: np.ndarray, p: ContactParams) -> int:
    """Where the reach of a Pick up after a release begins, in samples from the release, given
    ``d``, the TCP's distance to the object's box from the release to the Pick up's end: after
    the last sample at least ``approach_m`` away; a hand that never was that far but backed off
    ``BACK_OFF_M`` reaches from the farthest point of its back-off (its last sample within
    ``BACK_OFF_TOL_M`` of the largest distance); one that stayed at the object from
    ``min_move`` samples after the release, the shortest Move."""
    far = np.flatnonzero(d >= p.approach_m)
    if len(far):
        return int(far[-1]) + 1
    if len(d) == 0 or not np.isfinite(d).any():
        return p.min_move
    top = float(np.nanmax(d))
    if top - float(np.nan_to_num(d[0], nan=top)) < BACK_OFF_M:
        return p.min_move
    return max(int(np.flatnonzero(d >= top - BACK_OFF_TOL_M)[-1]) + 1, p.min_move)


def lift_off(pos: np.ndarray, a: int, u: int, rest_m: float = 0.002, rest_samples: int = 3) -> int:
    """Where the grasp that lifts an object takes it off (docs/skills.md "Boundaries"), given
    ``u``, a sample at which it is lifted: back from ``u`` to where it last rested, the last
    sample in ``a..u`` at which it had moved no more than ``rest_m`` over ``rest_samples``
    (``pos`` ``(n, 3)``; ``a`` if it never rested there). The one definition of lift-off: the
    one-hand (:func:`refine`) and the two-hand segmentation
    (:func:`lfd.segmentation.episodes.carries`) use it."""
    t, w = u, rest_samples
    while t - w >= a and not np.linalg.norm(pos[t] - pos[t - w]) <= rest_m:
        t -= 1
    return t if t - w >= a else a


def _lift(pos: np.ndarray, a: int, b: int, p: ContactParams) -> int | None:
    """Where the grasp that lifts the object takes it off in ``a..b`` (:func:`lift_off`, from
    the first sample ``lift_h_m`` above its height at ``a``); None if it is never lifted that
    high there. A turn or slide on the table before that grasp stays in the Pick up."""
    z = pos[a:b, 2]
    up = z > z[0] + p.lift_h_m
    if not up.any():
        return None
    return lift_off(pos, a, a + int(np.argmax(up)), p.rest_m, p.rest_samples)


def _descent(pos: np.ndarray, a: int, b: int, p: ContactParams) -> int | None:
    """Where a carried object starts its final descent in ``a..b``: the last sample before it
    comes to rest at which it was ``place_h_m`` above where it rests (the set-down height at
    ``b``); None if it never was."""
    z = pos[a:b, 2]
    above = z >= z[-1] + p.place_h_m
    if not above.any():
        return None
    return a + int(np.flatnonzero(above)[-1]) + 1


def _move_boundary(out: list[Draft], k: int, t: int) -> None:
    """Put the boundary between ``out[k]`` and ``out[k + 1]`` at ``t``, keeping both non-empty."""
    t = min(max(t, out[k].start + 1), out[k + 1].end - 1)
    if t > out[k].start:
        out[k].end = t
        out[k + 1].start = t


def _release(
    d_tcp: np.ndarray,
    d_thumb: np.ndarray,
    opening: np.ndarray | None,
    pos: np.ndarray,
    a: int,
    hi: int,
    p: ContactParams,
) -> int | None:
    """The first sample in ``a..hi``, once the object is set down (within ``lift_m`` of its
    lowest point there), at which the hand has let go of it; None if it never does."""
    if hi - a < 2:
        return None
    z = pos[a:hi, 2]
    rest = a + int(np.argmax(z <= np.nanmin(z) + p.lift_m))  # set down: near its lowest point
    # farther than while it held the object: a fingertip keypoint may sit off the surface
    tcp0, thumb0 = np.nan_to_num(d_tcp[rest]), np.nan_to_num(d_thumb[rest])
    gone = (d_tcp[rest:hi] > tcp0 + p.release_tcp_m) | (
        d_thumb[rest:hi] > thumb0 + p.release_thumb_m
    )
    if opening is not None and np.isfinite(opening[rest]):
        gone |= opening[rest:hi] > opening[rest] + p.release_open_m
    if not gone.any():
        return None
    return rest + int(np.argmax(gone))
