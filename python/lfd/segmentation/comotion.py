"""Object and hand motion, and the co-motion evidence of stage 2: the penalty of object motion a
segment's skill cannot explain (:func:`co_motion_penalty`, :func:`co_motion_per_object`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import InvalidParameterError
from ..skills import CARRIED, NO_LIFT, NO_SET_DOWN, TARGET_STILL
from ..trajectory import Trajectory

if TYPE_CHECKING:
    from .band import Band


def moving_objects(traj: Trajectory, window_s: float, displacement: float) -> np.ndarray:
    """``(O, n)``: object ``o`` moves at sample ``t`` if it is displaced by more than
    ``displacement`` (m) between ``t - window_s`` and ``t + window_s`` (NaN-free input)."""
    return _moving(traj, np.asarray(traj.object_position, dtype=np.float64), window_s, displacement)


def moving_hand(traj: Trajectory, window_s: float, displacement: float) -> np.ndarray:
    """``(n,)``: the TCP moves at sample ``t``, by the rule of :func:`moving_objects`."""
    return _moving(traj, np.asarray(traj.tcp, dtype=np.float64), window_s, displacement)


def _moving(traj: Trajectory, pos: np.ndarray, window_s: float, displacement: float) -> np.ndarray:
    """The rule of :func:`moving_objects` on positions ``(..., n, 3)`` of ``traj``'s samples."""
    n = len(traj)
    w = motion_window(traj.dt, window_s)
    idx = np.arange(n)
    a, b = np.clip(idx - w, 0, n - 1), np.clip(idx + w, 0, n - 1)
    return displaced(pos[..., a, :], pos[..., b, :], displacement)


def motion_window(dt: float, window_s: float) -> int:
    """Half-width in samples of the window of :func:`moving_objects`."""
    return max(1, round(window_s / dt)) if dt > 0 else 1


def displaced(before: np.ndarray, after: np.ndarray, displacement: float) -> np.ndarray:
    """Is an object displaced by more than ``displacement`` (m) between two positions (``(...,
    3)`` each)? The co-motion rule of :func:`moving_objects`."""
    return np.asarray(np.linalg.norm(after - before, axis=-1) > displacement)


def _next_true(mask: np.ndarray) -> np.ndarray:
    """``(O, n + 1)``: the first index ``>= t`` where ``mask[o]`` is true (``n`` if none)."""
    n_obj, n = mask.shape
    out = np.full((n_obj, n + 1), n, dtype=np.int64)
    at = np.where(mask, np.arange(n), n)  # t where true
    out[:, :n] = np.minimum.accumulate(at[:, ::-1], axis=1)[:, ::-1]  # smallest from t on
    return out


def _cumulative(mask: np.ndarray) -> np.ndarray:
    """``(n + 1,)``: how many samples of ``mask`` (n,) come before each index."""
    cum = np.zeros(len(mask) + 1)
    np.cumsum(mask, out=cum[1:])
    return cum


def _count_from(
    cum: np.ndarray, first: np.ndarray | None, lo: np.ndarray, hi: np.ndarray
) -> np.ndarray:
    """Samples of a mask in ``[max(lo, first[lo]), hi)`` per run, from its
    :func:`_cumulative` counts ``cum``, for sample indices ``lo`` and ``hi`` of broadcastable
    shapes (one pair per run); ``first`` (n + 1,): the first index ``>= t`` where the mask is
    true (:func:`_next_true`; None: ``t`` itself)."""
    start = lo if first is None else first[lo]
    d = cum[hi] - cum[start]
    np.maximum(d, 0.0, out=d)
    return np.asarray(np.where(hi > start, d, 0.0))


def co_motion_penalty(
    moving: np.ndarray,
    bounds: np.ndarray,
    skills: list[str],
    weight: float,
    *,
    lifted: np.ndarray | None = None,
    grace: int = 0,
    slide: float = -1.0,
    hand: np.ndarray | None = None,
    left: float = -1.0,
    band: Band | None = None,
) -> np.ndarray | None:
    """Penalty ``(O, N, S)`` over the runs of ``band``, or ``(O, K, K + 1, S)`` over every run
    without one (quadratic in ``K``), of object motion a segment cannot explain.

    ``moving`` (O, n) says where each object moves, ``lifted`` (O, n) where it is above its
    resting height. A segment from section ``i`` to ``j`` with target ``o`` and skill ``s`` is
    charged ``weight`` per sample

    - in which another object moves (a skill acts on its own object only);
    - in which ``o`` moves, if ``s`` keeps its target still (:data:`lfd.skills.TARGET_STILL`;
      the skills' properties are :data:`lfd.skills.TRAITS`);
    - in which ``o`` rests after it was lifted in the segment, if ``s`` does not put it down
      (:data:`~lfd.skills.NO_SET_DOWN`), or is lifted after it rested, if ``s`` does not lift it
      (:data:`~lfd.skills.NO_LIFT`): repeated cycles on one object come out as separate segments;
    - beyond the first ``slide`` (samples, negative: none charged) in which ``o`` moves while it
      rests, if ``s`` carries it lifted (:data:`~lfd.skills.CARRIED`): that is a Push;
    - beyond the first ``left`` (samples, negative: none charged) in which the hand moves
      (``hand`` (n,), :func:`moving_hand`) while ``o`` stays, if ``s`` carries ``o``: the hand
      has left it behind.

    ``grace`` samples at each end of a segment are free. ``None`` if ``weight`` is 0.
    """
    of = co_motion_per_object(
        moving,
        bounds,
        skills,
        weight,
        lifted=lifted,
        grace=grace,
        slide=slide,
        hand=hand,
        left=left,
        band=band,
    )
    return None if of is None else np.stack([of(o) for o in range(moving.shape[0])])


def co_motion_per_object(
    moving: np.ndarray,
    bounds: np.ndarray,
    skills: list[str],
    weight: float,
    *,
    lifted: np.ndarray | None = None,
    grace: int = 0,
    slide: float = -1.0,
    hand: np.ndarray | None = None,
    left: float = -1.0,
    band: Band | None = None,
) -> CoMotion | None:
    """:func:`co_motion_penalty` one target object at a time: ``of(o)`` is its ``[o]``, and
    with a ``band`` ``of.rows(o, r0, r1)`` its rows ``r0:r1`` (the sample counts behind it are
    computed per object and run, without the skill axis, when asked for)."""
    if np.isnan(slide):
        raise InvalidParameterError("co_motion_slide_s must be a number (negative: off), got nan")
    if np.isnan(left):
        raise InvalidParameterError("co_motion_left_s must be a number (negative: off), got nan")
    if weight == 0 or moving.size == 0:
        return None
    n_obj, n = moving.shape
    b = np.asarray(bounds, dtype=np.int64)
    lo = np.minimum(b[:-1] + grace, n)  # (K,)
    hi = np.maximum(b - grace, 0)  # (K + 1,)
    if band is None:  # every run: (K, 1) x (1, K + 1)
        lo, hi = lo[:, None], hi[None, :]
    else:  # the band's runs: (N,)
        lo, hi = lo[band.start], hi[band.end]
    h = np.asarray(hand, dtype=bool)[:n] if hand is not None and left >= 0 else None
    lift = None
    if lifted is not None:  # (lifted, resting, next lifted, next resting)
        resting = ~lifted
        lift = (lifted, resting, _next_true(lifted), _next_true(resting))
    charged = _charged(skills, lifted is not None, slide, h is not None)
    # each mask's cumulative counts, computed once, when first asked for
    mask_of = _masks(moving, lift, h)
    cums: dict[tuple[str, int], np.ndarray] = {}

    def cum(kind: str, o: int) -> np.ndarray:
        if (kind, o) not in cums:
            cums[kind, o] = _cumulative(mask_of[kind](o))
        return cums[kind, o]

    last: list[Any] = []  # [(lo, hi) as asked, their key, (own, total)]

    def own_counts(lo: np.ndarray, hi: np.ndarray) -> tuple[list[np.ndarray], np.ndarray]:
        # every object's own motion over the runs lo..hi and their sum: the same for every
        # target, so kept for the last runs asked for (the rows of one piece, object by object;
        # the arrays asked with are held, so equal buffers are the same indices)
        key = [(a.__array_interface__["data"][0], a.shape, a.strides) for a in (lo, hi)]
        if not last or last[1] != key:
            own = [_count_from(cum("moving", q), None, lo, hi) for q in range(n_obj)]
            total = own[0].copy()
            for q in range(1, n_obj):
                total += own[q]
            last[:] = [(lo, hi), key, (own, total)]
        result: tuple[list[np.ndarray], np.ndarray] = last[2]
        return result

    def of(o: int, lo: np.ndarray, hi: np.ndarray, into: np.ndarray | None = None) -> np.ndarray:
        # object o's counts over the runs lo..hi, in the order of ``masks``; the other
        # objects' motion is the objects' summed own motion less o's (exact: sample counts)
        own, total = own_counts(lo, hi)
        counts: list[np.ndarray | None] = [own[o], None, None, None, None]
        if lift is not None:
            counts[1] = _count_from(cum("resting", o), lift[2][o], lo, hi)
            counts[2] = _count_from(cum("lifted", o), lift[3][o], lo, hi)
            if slide >= 0:
                sliding = _count_from(cum("sliding", o), None, lo, hi) - slide
                counts[3] = np.maximum(sliding, 0.0)
        if h is not None:
            counts[4] = np.maximum(_count_from(cum("left", o), None, lo, hi) - left, 0.0)
        out = np.empty((*total.shape, len(skills))) if into is None else into
        done: dict[tuple[int, ...], np.ndarray] = {}
        for s, which in enumerate(charged):
            if which not in done:  # skills charged for the same counts share a column
                col = total - own[o]
                for k in which:
                    count = counts[k]
                    assert count is not None
                    col += count
                col *= -weight
                done[which] = col
            if into is None:
                out[..., s] = done[which]
            else:
                out[..., s] += done[which]
        return out

    return CoMotion(of, lo, hi, band is not None)


def _charged(skills: list[str], lifted: bool, slide: float, hand: bool) -> list[tuple[int, ...]]:
    """Per skill, the counts of :func:`co_motion_per_object` it is charged for (indices into
    still, not set down, not lifted, slid, left behind), in the order they are summed (a count
    times 0 adds nothing: every count is finite and >= 0)."""
    still = _skill_mask(skills, TARGET_STILL)
    no_set_down, no_lift = _skill_mask(skills, NO_SET_DOWN), _skill_mask(skills, NO_LIFT)
    carried = _skill_mask(skills, CARRIED)
    masks = [still, no_set_down, no_lift, carried, carried]
    present = [True, lifted, lifted, lifted and slide >= 0, hand]
    return [
        tuple(k for k, mask in enumerate(masks) if present[k] and mask[s])
        for s in range(len(skills))
    ]


def _masks(
    moving: np.ndarray,
    lift: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None,
    hand: np.ndarray | None,
) -> dict[str, Callable[[int], np.ndarray]]:
    """The sample masks of :func:`co_motion_per_object` per target object ``o``: it moves,
    rests, is lifted, slides (moves resting), the hand moves without it."""
    mask_of: dict[str, Callable[[int], np.ndarray]] = {"moving": lambda o: moving[o]}
    if lift is not None:
        lifted_, resting_ = lift[0], lift[1]
        mask_of["resting"] = lambda o: resting_[o]
        mask_of["lifted"] = lambda o: lifted_[o]
        mask_of["sliding"] = lambda o: moving[o] & resting_[o]
    if hand is not None:
        hand_ = hand
        mask_of["left"] = lambda o: hand_ & ~moving[o]
    return mask_of


@dataclass(frozen=True, eq=False)
class CoMotion:
    """The co-motion penalty of :func:`co_motion_per_object`: ``self(o)`` that of target
    object ``o`` over all runs, ``self.rows(o, r0, r1)`` its rows ``r0:r1`` of a band's table
    (each computed when asked for)."""

    of: Callable[[int, np.ndarray, np.ndarray, np.ndarray | None], np.ndarray]
    lo: np.ndarray
    hi: np.ndarray
    banded: bool

    def __call__(self, o: int) -> np.ndarray:
        return self.of(o, self.lo, self.hi, None)

    def rows(self, o: int, r0: int, r1: int) -> np.ndarray:
        """Rows ``r0:r1`` of ``self(o)``."""
        if not self.banded:
            return self(o)[r0:r1]
        return self.of(o, self.lo[r0:r1], self.hi[r0:r1], None)

    def add_rows(self, o: int, r0: int, r1: int, table: np.ndarray) -> None:
        """``table += self.rows(o, r0, r1)``, without the rows as an array of their own."""
        if not self.banded:
            table += self.rows(o, r0, r1)
        else:
            self.of(o, self.lo[r0:r1], self.hi[r0:r1], table)


def _skill_mask(skills: list[str], which: frozenset[str]) -> np.ndarray:
    return np.array([s in which for s in skills], dtype=np.float64)
