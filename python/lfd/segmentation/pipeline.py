"""The two-stage segmentation of one demonstration (paper Sec. III-B, Fig. 4), orchestrated.

trajectory -> gap filling (:mod:`~lfd.segmentation.gaps`) -> Table I features -> stage 1
(section boundaries: :mod:`~lfd.segmentation.stage1`) -> stage 2 (the score table over the
engine's band: :mod:`~lfd.segmentation.stage2` beside :mod:`~lfd.segmentation.band`, with the
co-motion evidence of :mod:`~lfd.segmentation.comotion`) -> TCP rise decision, greedy loop or
segmental DP under the grammar (the engine) -> drafts (:class:`lfd.skills.Draft`:
:mod:`~lfd.segmentation.drafts`) -> the passes (implicit Moves, contact boundaries, Move
objects: :mod:`~lfd.segmentation.passes`) -> :class:`~lfd.segmentation.result.Segmentation`
with target objects and skill parameters. What it is set to is
:mod:`~lfd.segmentation.settings` (:class:`SegmentParams`, the searches and grammar uses).
"""

from __future__ import annotations

from typing import Any, get_args

import numpy as np

from .. import _hmmseg
from .._hmmseg import EndState, GrammarMode
from ..demo import Demonstration
from ..errors import DemonstrationError, InvalidParameterError
from ..skills import Draft
from ..trajectory import Trajectory
from .band import StageTwoScores
from .cycles import carries_by_contact, grasps_and_pushes, hovers_and_turns
from .drafts import make_segments, search_drafts
from .gaps import fill_gaps
from .grammar import compiled_grammar
from .passes import insert_implicit_moves, label_moves, refine_contacts
from .result import Run, Segmentation
from .settings import (
    DEFAULT_GRAMMAR,
    DEFAULT_SEARCH,
    PAPER_GRAMMAR,
    PAPER_PARAMS,
    PAPER_SEARCH,
    GrammarUse,
    Search,
    SegmentParams,
)
from .stage1 import section_boundaries
from .stage2 import stage2_scores
from .templates import Templates

__all__ = [
    "DEFAULT_GRAMMAR",
    "DEFAULT_SEARCH",
    "PAPER_GRAMMAR",
    "PAPER_PARAMS",
    "PAPER_SEARCH",
    "GrammarUse",
    "Search",
    "SegmentParams",
    "as_trajectory",
    "fill_gaps",
    "segment_trajectory",
    "stage2_scores",
]


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
    _check(traj, search, grammar, p)
    filled, warnings = fill_gaps(traj)
    feats = compute_features(filled)
    per_object = [compute_features(filled, target=o) for o in range(len(filled.object_names))]
    bounds = section_boundaries(
        np.ascontiguousarray(feats.values, dtype=np.float64),
        feats.thresholds,
        traj.dt,
        p.stage1,
        objects=[(f.values, f.thresholds) for f in per_object],
    )
    st = stage2_scores(filled, templates, bounds, p, per_object, complete=complete)
    drafts, warn = _search(filled, templates.skills, st, bounds, search, grammar, p)
    drafts = _passes(filled, drafts, p, complete=complete)
    return Segmentation(
        segments=make_segments(filled, drafts),
        warnings=warnings + list(warn),
        method=search,
        sections=[int(b) for b in bounds],
        object_names=list(filled.object_names),
        run=Run(filled, feats, per_object, st),
    )


def _check(traj: Trajectory, search: str, grammar: str, p: SegmentParams) -> None:
    """Refuse an unknown search, grammar use or end state, and a demonstration too short for
    any skill (one line each)."""
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


def _search(
    filled: Trajectory,
    skills: list[str],
    st: StageTwoScores,
    bounds: np.ndarray,
    search: Search,
    grammar: GrammarUse,
    p: SegmentParams,
) -> tuple[list[Draft], list[str]]:
    """The engine's search over the score band ``st`` under the TCP-rise decision and the
    grammar: the segments it chose as drafts, and its warnings."""
    max_len = st.band.max_len
    rising = _hmmseg.rising_band(
        np.ascontiguousarray(filled.tcp[:, 2]), bounds, max_len, p.min_rise, p.dominance
    )
    rules = compiled_grammar(tuple(skills), p.implicit_moves)
    if search == "greedy":
        cuts, warn = _hmmseg.segment_greedy(
            st.scores, bounds, rules, rising, grammar, p.lookahead, max_len
        )
    else:
        cuts, warn = _hmmseg.segment_dp(
            st.scores, bounds, rules, rising, grammar, p.penalty, max_len
        )
    return search_drafts(st, cuts, skills), list(warn)


def _passes(
    filled: Trajectory, drafts: list[Draft], p: SegmentParams, *, complete: bool
) -> list[Draft]:
    """The passes over the search's drafts, in their order: carries by contact, reach
    hesitations and table turns (:mod:`~lfd.segmentation.cycles`), implicit Moves, contact boundaries, Move objects
    (:mod:`~lfd.segmentation.passes`)."""
    if p.contacts is not None:
        drafts = carries_by_contact(filled, drafts, min_move=p.contacts.min_move)
        drafts = hovers_and_turns(filled, drafts, p.contacts.approach_m)
        drafts = grasps_and_pushes(filled, drafts)
    if p.implicit_moves:
        drafts = insert_implicit_moves(filled, drafts, max(1, round(p.implicit_move_s / filled.dt)))
    if p.contacts is not None:
        drafts = refine_contacts(filled, drafts, p.contacts, complete=complete)
    return label_moves(filled, drafts)


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
