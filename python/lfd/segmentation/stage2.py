"""Stage 2's score table over the runs of a :class:`~lfd.segmentation.band.Band`, as the search
sees it (:func:`stage2_scores`): every target object's table from the engine's templates plus the
co-motion evidence (:mod:`~lfd.segmentation.comotion`), maximised over the objects
(:func:`scores_over_objects`), built in pieces of the band."""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from .._hmmseg import EndState
from ..trajectory import Trajectory
from .band import Band, StageTwoScores
from .comotion import CoMotion, co_motion_per_object, moving_hand, moving_objects
from .settings import SegmentParams
from .stage1 import OBJECT_COLUMNS

if TYPE_CHECKING:
    from ..features import Features
    from .templates import Templates


SCORE_CHUNK = 1 << 15
"""The score band is built in pieces of the runs starting in about this many samples
(:func:`scores_over_objects`): only the maximum over the objects is held for all runs."""


def stage2_scores(
    traj: Trajectory,
    templates: Templates,
    bounds: np.ndarray,
    params: SegmentParams,
    per_object: list[Features] | None = None,
    *,
    complete: bool = True,
) -> StageTwoScores:
    """The score table of a gap-free trajectory's runs of sections as the search sees it, and
    the target object of each entry, over the runs of at most ``max_segment_s`` (a
    :class:`~lfd.segmentation.band.Band`: memory and time linear in the demonstration).

    The skills are object-centred: for every run of sections and skill the features are taken
    relative to each object in turn, the co-motion evidence (:func:`co_motion_per_object`) is
    added, and the best-explaining object is the segment's target (``c^{r,s} = max_o sum_f log
    P(O_f^{r,o} | lambda_f^s) + co-motion``). This replaces a fixed per-sample target labelling,
    which cannot know the target of skills that never move their object (Locate).
    ``per_object``: ``compute_features(traj, target=o)`` for every object (computed if None).
    ``complete`` False (a recording still being made): the runs that end with the recording so
    far are scored with ``end="any"``, as the skill under way need not have finished.
    """
    from ..features import compute_features

    p = params
    if per_object is None:
        per_object = [compute_features(traj, target=o) for o in range(len(traj.object_names))]
    band = Band.of(bounds, max(1, round(p.max_segment_s / traj.dt)))
    moving = moving_objects(traj, p.co_motion_window_s, p.co_motion_displacement)
    hand = moving_hand(traj, p.co_motion_window_s, p.co_motion_displacement)
    height = OBJECT_COLUMNS["object_height"]  # above the object's rest height + gamma: lifted

    values = [np.ascontiguousarray(f.values, dtype=np.float64) for f in per_object]
    shared = shared_features(values, templates)

    extra = co_motion_per_object(
        moving,
        bounds,
        templates.skills,
        p.co_motion,
        lifted=np.stack([f.values[:, height] > f.thresholds[:, height] for f in per_object]),
        grace=round(p.co_motion_grace_s / traj.dt),
        slide=p.co_motion_slide_s / traj.dt,
        hand=hand,
        left=p.co_motion_left_s / traj.dt,
        band=band,
    )
    st = scores_over_objects(values, templates, band, p.end, extra=extra, shared=shared)
    if complete or p.end == "any":
        return st
    k = band.n_sections
    last = [r for i in range(k) if (r := band.index(i, k)) is not None]
    if last:
        # only these runs are scored again: over the band of the sections from the first of
        # them on, whose rows are the band's from that section's on (a run's score depends on
        # its own samples only)
        i0 = int(band.start[last[0]])
        r0 = int(band.offsets[i0])
        tail = Band.of(band.bounds[i0:] - band.bounds[i0], band.max_len)
        same = (
            tail.n_runs == band.n_runs - r0
            and np.array_equal(tail.start + i0, band.start[r0:])
            and np.array_equal(tail.end + i0, band.end[r0:])
        )
        a = int(band.bounds[i0]) if same else 0
        st_any = scores_over_objects(
            [v[a:] for v in values] if same else values,
            templates,
            tail if same else band,
            "any",
            extra=_rows(extra, r0) if same else extra,
            shared=shared,
        )
        rows = np.asarray(last) - (r0 if same else 0)
        st.scores[last] = st_any.scores[rows]
        st.target[last] = st_any.target[rows]
    return st


def _rows(extra: Callable[[int], np.ndarray] | None, r0: int) -> Callable[[int], np.ndarray] | None:
    """``extra`` (:func:`co_motion_per_object`) from row ``r0`` on."""
    if extra is None:
        return None
    if isinstance(extra, CoMotion) and extra.banded:
        return dataclasses.replace(extra, lo=extra.lo[r0:], hi=extra.hi[r0:])
    return lambda o: extra(o)[r0:]


def scores_over_objects(
    values: list[np.ndarray],
    templates: Templates,
    band: Band,
    end: EndState,
    *,
    extra: np.ndarray | Callable[[int], np.ndarray] | None = None,
    shared: list[int] | None = None,
    chunk: int = SCORE_CHUNK,
) -> StageTwoScores:
    """The score table over the runs of ``band`` maximised over the target object, from the
    feature matrices, one (n, 10) array per target object; ``extra`` (O, N, S), or a function
    of the object giving its (N, S) (:func:`co_motion_per_object`), is added per target before
    the maximum (e.g. :func:`co_motion_penalty`). ``shared``: the features scored once for all
    objects (default: :func:`shared_features`).

    The runs starting in about ``chunk`` samples are scored at a time, each piece over its own
    samples (a run's score depends on its own samples only: the entries are those of the whole
    band), so besides the result only one piece's tables are held."""
    engine = templates.engine
    groups = getattr(templates, "features", None)
    max_len = band.max_len
    extra_of = extra if callable(extra) or extra is None else extra.__getitem__
    if shared is None:
        shared = shared_features(values, templates)
    if groups is None:  # a stand-in without feature metadata: a dense table per object
        bounds = band.bounds

        def dense_of(o: int) -> np.ndarray:
            cur = np.asarray(band.take(engine.score_table(values[o], bounds, max_len, end)))
            cur = np.asarray(cur, dtype=np.float64)
            if extra_of is not None:
                cur += extra_of(o)
            return cur

        best, target = max_over_objects(dense_of, len(values))
        return StageTwoScores(band, best, target)
    rest = [g for g in range(len(groups)) if g not in shared]
    n_obj = len(values) if rest or extra is not None else 1
    n_skills = len(templates.skills)
    best = np.empty((band.n_runs, n_skills))
    target = np.zeros(best.shape, dtype=np.min_scalar_type(n_obj - 1))
    for i0, i1, e in _pieces(band, chunk):
        a, b = int(band.bounds[i0]), int(band.bounds[e])
        r0, r1 = int(band.offsets[i0]), int(band.offsets[i1])
        if i0 == 0 and e == band.n_sections:  # the whole band
            piece, view = band.bounds, list(values)
        else:
            piece, view = band.bounds[i0 : e + 1] - a, [v[a:b] for v in values]
        add_extra: Callable[[int, np.ndarray], None] | None = None
        if isinstance(extra_of, CoMotion):
            add_extra = functools.partial(_add_co_motion, extra_of, r0, r1)
        elif extra_of is not None:
            add_extra = _AddRows(extra_of, r0, r1)
        base = _band_rows(engine, view[0], piece, max_len, end, shared, r1 - r0) if shared else 0.0
        scores_of = functools.partial(
            _piece_scores, engine, view, piece, max_len, end, base, rest, add_extra, r1 - r0
        )
        best[r0:r1], target[r0:r1] = max_over_objects(scores_of, n_obj)
    return StageTwoScores(band, best, target)


@dataclass(frozen=True)
class _AddRows:
    """Add rows ``r0:r1`` of ``of(o)`` to a table."""

    of: Callable[[int], np.ndarray]
    r0: int
    r1: int

    def __call__(self, o: int, table: np.ndarray) -> None:
        table += self.of(o)[self.r0 : self.r1]


def _add_co_motion(extra: CoMotion, r0: int, r1: int, o: int, table: np.ndarray) -> None:
    extra.add_rows(o, r0, r1, table)


def _band_rows(
    engine: Any,
    v: np.ndarray,
    piece: np.ndarray,
    max_len: int,
    end: EndState,
    feats: list[int],
    n_rows: int,
) -> np.ndarray:
    """The first ``n_rows`` rows of ``engine.score_band``."""
    t = np.asarray(engine.score_band(v, piece, max_len, end, feats))
    return t if len(t) == n_rows else t[:n_rows]


def _piece_scores(
    engine: Any,
    view: list[np.ndarray],
    piece: np.ndarray,
    max_len: int,
    end: EndState,
    base: np.ndarray | float,
    rest: list[int],
    add_extra: Callable[[int, np.ndarray], None] | None,
    n_rows: int,
    o: int,
) -> np.ndarray:
    """Target object ``o``'s rows of a piece of :func:`scores_over_objects`: the first
    ``n_rows`` rows of the band of ``max_len`` samples over the boundaries ``piece`` of the
    samples ``view[o]``, plus ``base`` (the shared features') and what ``add_extra(o, table)``
    adds."""
    # in place where the array is our own (a sum is the same either way round)
    if rest:
        cur = _band_rows(engine, view[o], piece, max_len, end, rest, n_rows)
        cur += base
    else:
        cur = np.array(base, dtype=np.float64)
    if add_extra is not None:
        add_extra(o, cur)
    return cur


def _pieces(band: Band, chunk: int) -> list[tuple[int, int, int]]:
    """The start sections ``i0:i1`` of :func:`scores_over_objects`' pieces, each spanning about
    ``chunk`` samples (at least one section), and the last end section ``e`` of their runs:
    the band over the boundaries ``i0..=e`` holds the runs of starts ``i0:i1`` as the whole band
    does, at its first rows."""
    out = []
    k, bounds = band.n_sections, band.bounds
    i0 = 0
    while i0 < k:
        i1 = max(i0 + 1, int(np.searchsorted(bounds, bounds[i0] + chunk, side="left")))
        i1 = min(i1, k)
        out.append((i0, i1, int(band.last[i1 - 1])))
        i0 = i1
    return out


def shared_features(values: list[np.ndarray], templates: Templates) -> list[int]:
    """The templates' features (indices into ``templates.features``) that do not depend on the
    target (fingertip distance, TCP rise, hand speed): equal in the feature matrices of all
    targets ``values``; these are scored once. ``[]`` without feature metadata."""
    groups = getattr(templates, "features", None)
    if groups is None:
        return []
    return [
        g
        for g, (_name, a, b) in enumerate(groups)
        if all(np.array_equal(values[0][:, a:b], v[:, a:b]) for v in values[1:])
    ]


def max_over_objects(
    scores_of: Callable[[int], np.ndarray], n_obj: int
) -> tuple[np.ndarray, np.ndarray]:
    """The maximum over the target objects of ``scores_of(o)`` and the first object reaching it
    (np.max / np.argmax over the objects; the scores are never NaN), one object's table at a
    time."""
    best = np.ascontiguousarray(scores_of(0))
    target = np.zeros(best.shape, dtype=np.min_scalar_type(n_obj - 1))
    better = np.empty(best.shape, dtype=bool) if n_obj > 1 else None
    for o in range(1, n_obj):
        cur = scores_of(o)
        np.greater(cur, best, out=better)
        np.copyto(best, cur, where=better)
        target[better] = o
        del cur
    return best, target
