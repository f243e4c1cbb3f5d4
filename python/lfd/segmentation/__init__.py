"""Two-stage skill segmentation of a demonstration (paper Sec. III-B).

>>> import lfd
>>> result = lfd.segment(lfd.load("recordings/exp1.mcap"))      # doctest: +SKIP
>>> result.skill_sequence                                        # doctest: +SKIP
['pick_up', 'move_with', 'place', 'move', ...]

Stage 1 over-segments at threshold crossings of the fingertip distance, hand speed and TCP
rise/fall; stage 2 merges the data sections into skills by HMM template matching, with the
TCP-rise decision tree (Fig. 5) and the skill grammar (Fig. 6), either by a globally optimal
segmental DP under the grammar (``search="dp", grammar="enforce"``, the default and the most
accurate) or by the paper's greedy cut loop with grammar warnings (``search="greedy",
grammar="warn"``; with the paper-recipe templates and pipeline, :data:`PAPER`).
"""

from __future__ import annotations

import dataclasses
import os
from typing import TypedDict

from ..demo import Demonstration
from ..errors import DemonstrationError, InvalidParameterError
from ..trajectory import Trajectory
from .baselines import gripper_segmentation, proximity_segmentation
from .changepoint import changepoint_segmentation
from .hands import HandsSegmentation
from .method import Method
from .metrics import all_metrics
from .pipeline import (
    DEFAULT_GRAMMAR,
    DEFAULT_SEARCH,
    PAPER_GRAMMAR,
    PAPER_PARAMS,
    PAPER_SEARCH,
    GrammarUse,
    Search,
    SegmentParams,
    segment_trajectory,
)
from .result import Run, Segment, Segmentation
from .stage1 import Stage1Params
from .templates import TemplateChoice, Templates, resolve_templates, train_templates


def segment(
    demo_or_traj: Demonstration | Trajectory,
    templates: Templates | TemplateChoice | None = None,
    *,
    method: Method | str | None = None,
    search: Search | None = None,
    grammar: GrammarUse | None = None,
    params: SegmentParams | None = None,
    complete: bool = True,
) -> Segmentation:
    """Segment a demonstration into skills.

    Parameters
    ----------
    demo_or_traj : Demonstration or Trajectory
        A recording (preprocessed here, once, with the method's preprocessing) or an already
        preprocessed trajectory.
    templates : Templates or {"default", "paper"}, optional
        Skill templates, with the method saved in them or else the default one (``"paper"``:
        the paper-recipe templates with the default search). Give ``templates`` or ``method``.
    method : Method or str, optional
        The whole method (templates, their preprocessing, parameters, search, grammar), or its
        name / template file (:meth:`Method.load`). Default: :meth:`Method.default`.
    search : {"dp", "greedy"}, optional
        Overrides the method's: ``dp`` (default) the globally optimal segmental DP; ``greedy``
        the paper's greedy cut loop (Eq. 3-5).
    grammar : {"enforce", "warn", "off"}, optional
        Overrides the method's: ``enforce`` (default) consider only allowed skill transitions;
        ``warn`` keep the best result and warn about impossible transitions (the paper, Fig. 6);
        ``off`` ignore the grammar.
    params : SegmentParams, optional
        Overrides the method's stage-1 and stage-2 parameters.
    complete : bool
        The recording is complete (default). False for a recording still being made (the live
        segmentation): the contact rules about how a demonstration ends are not applied
        (:func:`lfd.contact.refine`), the skill under way need not have finished, and an
        object hidden since the hand reached it follows the hand (:func:`lfd.preprocess`).

    Returns
    -------
    Segmentation
        Ordered segments covering the demonstration, warnings, and the :class:`Run`
        (``result.run``: the segmented trajectory, its features, the scores, the method).

    Raises
    ------
    DemonstrationError
        No hand data, no tracked object, or too short for any skill; two hands
        (:func:`segment_hands` segments both, ``demo.one_hand(side)`` one of them).
    ModelFormatError
        The template file cannot be used.
    """
    from .pipeline import as_trajectory

    if isinstance(demo_or_traj, Demonstration) and demo_or_traj.other_hand is not None:
        raise DemonstrationError(
            "the demonstration has two hands: lfd.segment_hands segments both, "
            "lfd.segment(demo.one_hand(side)) one of them"
        )
    m = resolve_method(templates, method).with_options(
        search=search, grammar=grammar, params=params
    )
    wanted = m.preprocessing
    traj = as_trajectory(demo_or_traj, wanted if complete else {**wanted, "complete": False})
    result = segment_trajectory(
        traj, m.templates, search=m.search, grammar=m.grammar, params=m.params, complete=complete
    )
    if result.run is not None:
        result.run = dataclasses.replace(result.run, method=m)
    differ = [
        f"{key}={traj.meta.get(key)!r} (templates: {value!r})"
        for key, value in wanted.items()
        if key in traj.meta and traj.meta[key] != value
    ]
    if differ:
        result.warnings.insert(
            0,
            "the trajectory was preprocessed differently from the templates' examples: "
            + ", ".join(differ)
            + "; preprocess with lfd.preprocess(demo, **method.preprocessing) for best results",
        )
    return result


def segment_hands(
    demo: Demonstration,
    templates: Templates | TemplateChoice | None = None,
    *,
    method: Method | str | None = None,
    complete: bool = True,
) -> HandsSegmentation:
    """Segment every hand of ``demo`` (one or two), each in its own lane
    (:class:`~lfd.segmentation.hands.HandsSegmentation`); ``templates``, ``method`` and
    ``complete`` as for :func:`segment`. A one-hand demonstration gives one lane, equal to
    :func:`segment`'s result.

    Each hand is segmented on the demonstration as it sees it (the other hand's carrying
    taken out: :func:`~lfd.segmentation.attribution.hand_view`); a skill on an object the hand
    never touches becomes a Move; a carry one hand ends in the air while the other holds the
    object is a handover; the grammar is checked per hand and across hands
    (:mod:`lfd.segmentation.lanes`). Each lane keeps its :class:`Run`; the method is
    ``result.method`` (once).
    """
    from .lanes import segment_lanes

    m = resolve_method(templates, method)
    result = segment_lanes(
        demo, lambda one: segment(one, method=m, complete=complete), complete=complete
    )
    result.method = m
    return result


def resolve_method(
    templates: Templates | TemplateChoice | None = None,
    method: Method | str | os.PathLike[str] | None = None,
) -> Method:
    """The method of :func:`segment`'s ``templates`` or ``method`` argument (not both)."""
    if method is not None:
        if templates is not None:
            raise InvalidParameterError("give templates or method, not both")
        return Method.load(method)
    if templates is None or templates == "default":
        return Method.default()
    name = templates if isinstance(templates, str) else "templates"
    return Method.of_templates(resolve_templates(templates), name=name)


class SearchOptions(TypedDict):
    """A segmentation method as keyword arguments of :func:`segment`."""

    search: Search
    grammar: GrammarUse
    templates: TemplateChoice
    params: SegmentParams


PAPER: SearchOptions = {
    "search": PAPER_SEARCH,
    "grammar": PAPER_GRAMMAR,
    "templates": "paper",
    "params": PAPER_PARAMS,
}
"""The paper's method as keyword arguments, ``lfd.segment(demo, **PAPER)``: the greedy cut loop
that only warns about impossible transitions, on templates of the paper's recipe (careful
demos, 2 Hz filters, Table I's thumb-index opening) and stage 1 on the hand signals only."""

__all__ = [
    "DEFAULT_GRAMMAR",
    "DEFAULT_SEARCH",
    "PAPER",
    "GrammarUse",
    "HandsSegmentation",
    "Method",
    "Run",
    "Search",
    "SearchOptions",
    "Segment",
    "SegmentParams",
    "Segmentation",
    "Stage1Params",
    "Templates",
    "all_metrics",
    "changepoint_segmentation",
    "gripper_segmentation",
    "proximity_segmentation",
    "segment",
    "segment_hands",
    "train_templates",
]
