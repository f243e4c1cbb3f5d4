"""The two-stage segmentation of one demonstration (paper Sec. III-B, Fig. 4).

trajectory -> gap filling -> Table I features -> stage 1 (section boundaries) -> stage 2 (score
table from the templates, TCP rise decision, greedy loop or segmental DP under the grammar)
-> :class:`~lfd.segmentation.result.Segmentation` with target objects and skill parameters.

The pieces are modules of their own: the score table over the engine's band
(:mod:`~lfd.segmentation.stage2`, with the co-motion evidence of
:mod:`~lfd.segmentation.comotion`), the passes over the search's segments (implicit Moves,
contact boundaries, Move objects: :mod:`~lfd.segmentation.passes`) and the segments being made
(:mod:`~lfd.segmentation.drafts`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal, get_args

import numpy as np

from .. import _hmmseg
from .._hmmseg import EndState, GrammarMode
from ..contact import ContactParams
from ..demo import Demonstration
from ..errors import DemonstrationError, InvalidParameterError
from ..trajectory import Trajectory

if TYPE_CHECKING:
    from ..features import Features
from .band import Band, StageTwoScores
from .comotion import CoMotion, co_motion_per_object, moving_hand, moving_objects
from .drafts import make_segments, search_drafts
from .gaps import fill_gaps
from .grammar import compiled_grammar
from .passes import insert_implicit_moves, label_moves, refine_contacts
from .result import Run, Segmentation
from .stage1 import OBJECT_COLUMNS, Stage1Params, section_boundaries
from .stage2 import scores_over_objects, shared_features
from .templates import Templates

Search = Literal["dp", "greedy"]
"""The stage-2 search: the segmental DP or the paper's greedy loop."""
GrammarUse = GrammarMode
"""How the skill grammar is used (the engine's ``GrammarMode``: "off", "warn", "enforce")."""

DEFAULT_SEARCH: Search = "dp"
"""The default stage-2 search: the segmental DP (11/12 exact sequences on held-out demos, against
6/12 for the paper's greedy loop; docs/segmentation.md)."""
DEFAULT_GRAMMAR: GrammarUse = "enforce"
"""The default grammar use: only allowed skill transitions are considered."""
PAPER_SEARCH: Search = "greedy"
"""The paper's algorithm: the greedy cut loop of Eq. 3-5..."""
PAPER_GRAMMAR: GrammarUse = "warn"
"""...keeping the best result and warning about impossible transitions (Fig. 6)."""


@dataclass(frozen=True)
class SegmentParams:
    """Parameters of the segmentation beyond the templates.

    Attributes
    ----------
    stage1 : Stage1Params
        Stage-1 hysteresis and minimum section length.
    end : {"final", "any"}
        ``final``: a segment must end in the last state of the skill's left-right HMM (a
        complete execution); ``any``: the plain forward likelihood of Eq. 3.
    min_rise : float
        A run of sections is "rising" (Fig. 5: only Move / Move with) if the TCP climbs at least
        this much (metres) in one go (largest rise inside the run)...
    dominance : float
        ...and its summed climb is at least ``dominance`` times its summed descent (0: off).
    max_segment_s : float
        Longest skill segment considered (seconds; the template skills last 1-4 s); bounds the
        forward passes.
    lookahead : bool
        Greedy search: value each candidate cut by its per-sample score together with the best
        segment that may follow it, instead of its own per-sample score alone (measured in
        docs/segmentation.md: 14 -> 19 of 24 exact sequences with the grammar enforced).
    penalty : float
        Per-segment penalty of the DP (nats).
    min_duration_s : float
        A demonstration shorter than this cannot hold a skill (DemonstrationError).
    co_motion : float
        Co-motion evidence (beyond the paper): a skill acts on its own object only, so every
        sample of a segment in which another object moves (speed above ``v_th``), or in which
        the target itself moves during a Move or Locate, costs this many nats
        (:func:`co_motion_penalty`; 0: off). Without it a segment can explain a real carry of
        one box as an empty-hand Move "relative to" a box that stays put.
    co_motion_grace_s : float
        Object motion this close to a segment's ends is not charged (boundaries are uncertain
        by about this much).
    co_motion_slide_s : float
        A carried target (Move with) moves while it still rests on the table only as it is
        lifted off (0.07-0.23 s in the ground truth of the tuning demos; a Push slides its box
        0.37-1 s): beyond this much sliding, every sliding sample costs ``co_motion`` nats
        (:data:`CARRIED`; negative: off). Without it a Push is read live as Pick up -> Move with
        until the missing Place shows it.
    co_motion_left_s : float
        A carried target moves with the hand: beyond this many seconds in which the hand moves
        (:func:`moving_hand`) while the target stays (at most 0.4 s in the ground truth of
        the tuning demos, median 0), every such sample of a Move with costs ``co_motion`` nats
        (negative: off). Without it a Push, or a Move away from a box, is read live as a Move with
        that is never put down.
    implicit_moves : bool
        A Move between a release (Place, Stack) and the next skill may be shorter than a stage-1
        section: when the hand re-grasps the object it has just put down, it opens a little,
        rises a few millimetres and closes again in 0.1-0.3 s. With this on the search may go
        from the release straight to the next skill and the Move is inserted around the
        TCP's highest point between them (:func:`insert_implicit_moves`).
    implicit_move_s : float
        Length of an inserted Move (seconds).
    contacts : ContactParams or None
        Put the boundaries of the skills that touch an object where contact says
        (:func:`lfd.contact.refine`: a Pick up from the last sample the hand was 8 cm from the
        object to its first motion, a Place or Stack to the release, the Moves around them);
        None: the search's boundaries as they are (the paper).
    co_motion_window_s, co_motion_displacement : float
        An object moves at a sample when it is displaced by more than ``co_motion_displacement``
        metres between ``co_motion_window_s`` before and after it (:func:`moving_objects`;
        a displacement, unlike a speed threshold, ignores tag noise and interpolated gaps).
    """

    stage1: Stage1Params = field(default_factory=Stage1Params)
    end: EndState = "final"
    min_rise: float = 0.025
    dominance: float = 0.0
    max_segment_s: float = 10.0
    lookahead: bool = True
    penalty: float = 10.0
    min_duration_s: float = 0.5
    co_motion: float = 20.0
    co_motion_grace_s: float = 0.0
    co_motion_slide_s: float = 0.25
    co_motion_left_s: float = 0.4
    co_motion_window_s: float = 1.0 / 6.0
    implicit_moves: bool = True
    implicit_move_s: float = 0.2
    co_motion_displacement: float = 0.015
    contacts: ContactParams | None = field(default_factory=ContactParams)

    def __post_init__(self) -> None:
        from ..rules import check_fields
        from .schema import SEGMENT_RULES

        check_fields(self, SEGMENT_RULES, "params.")


PAPER_PARAMS = SegmentParams(
    stage1=Stage1Params(object_criteria=False, min_section_s=0.2),
    min_rise=0.02,
    co_motion=0.0,
    implicit_moves=False,
    contacts=None,
)
"""The paper's pipeline around the search (with :data:`PAPER_SEARCH`, :data:`PAPER_GRAMMAR` and the
paper-recipe templates, ``lfd segment --paper``): stage 1 on the hand signals only (sections
>= 0.2 s), a 2 cm rise threshold, no co-motion evidence, no implicit moves."""


def segment_trajectory(
    traj: Trajectory,
    templates: Templates,
    *,
    search: Search = "dp",
    grammar: GrammarUse = "enforce",
    params: SegmentParams | None = None,
    complete: bool = True,
) -> Segmentation:
    """Segment a preprocessed trajectory (see :func:`lfd.segment`)."""
    from ..features import compute_features

    p = params or SegmentParams()
    for option, value, allowed in (
        ("search", search, get_args(Search)),
        ("grammar", grammar, get_args(GrammarMode)),
        ("end", p.end, get_args(EndState)),
    ):
        if value not in allowed:
            raise InvalidParameterError(
                f"{option} must be one of {', '.join(map(repr, allowed))}, got {value!r}"
            )
    if len(traj) < 2 or traj.dt <= 0 or (len(traj) - 1) * traj.dt < p.min_duration_s:
        dur = max(len(traj) - 1, 0) * max(traj.dt, 0.0)
        raise DemonstrationError(
            f"the demonstration lasts {dur:.2f} s, too short for any skill "
            f"(at least {p.min_duration_s} s)"
        )
    filled, warnings = fill_gaps(traj)
    feats = compute_features(filled)
    values = np.ascontiguousarray(feats.values, dtype=np.float64)
    per_object = [compute_features(filled, target=o) for o in range(len(filled.object_names))]
    bounds = section_boundaries(
        values,
        feats.thresholds,
        traj.dt,
        p.stage1,
        objects=[(f.values, f.thresholds) for f in per_object],
    )
    st = stage2_scores(filled, templates, bounds, p, per_object, complete=complete)
    max_len = st.band.max_len
    rising = _hmmseg.rising_band(
        np.ascontiguousarray(filled.tcp[:, 2]), bounds, max_len, p.min_rise, p.dominance
    )
    skills = templates.skills
    rules = compiled_grammar(tuple(skills), p.implicit_moves)
    if search == "greedy":
        cuts, warn = _hmmseg.segment_greedy(
            st.scores, bounds, rules, rising, grammar, p.lookahead, max_len
        )
    else:
        cuts, warn = _hmmseg.segment_dp(
            st.scores, bounds, rules, rising, grammar, p.penalty, max_len
        )
    drafts = search_drafts(st, cuts, skills)
    if p.implicit_moves:
        drafts = insert_implicit_moves(filled, drafts, max(1, round(p.implicit_move_s / traj.dt)))
    if p.contacts is not None:
        drafts = refine_contacts(filled, drafts, p.contacts, complete=complete)
    segments = make_segments(filled, label_moves(filled, drafts))
    return Segmentation(
        segments=segments,
        warnings=warnings + list(warn),
        method=search,
        sections=[int(b) for b in bounds],
        object_names=list(filled.object_names),
        run=Run(filled, feats, per_object, st),
    )


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
    relative to each object in turn, the co-motion evidence (:func:`co_motion_penalty`) is
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


def as_trajectory(
    demo_or_traj: Demonstration | Trajectory, preprocessing: dict[str, Any] | None = None
) -> Trajectory:
    """Preprocess a demonstration (a trajectory passes through) with the keyword arguments
    ``preprocessing`` of :func:`lfd.preprocess` (default: those of the shipped templates)."""
    if isinstance(demo_or_traj, Trajectory):
        return demo_or_traj
    if isinstance(demo_or_traj, Demonstration):
        from ..preprocessing import preprocess

        if len(demo_or_traj.hand) == 0 or not np.isfinite(demo_or_traj.hand.keypoints).any():
            raise DemonstrationError("the demonstration has no hand data")
        if preprocessing is None:
            from .templates import preprocessing_options

            preprocessing = preprocessing_options()
        return preprocess(demo_or_traj, **preprocessing)
    raise TypeError(f"expected a Demonstration or Trajectory, got {type(demo_or_traj).__name__}")
