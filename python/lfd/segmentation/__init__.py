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

from typing import TypedDict

from ..demo import Demonstration
from ..trajectory import Trajectory
from .baselines import gripper_segmentation, proximity_segmentation
from .changepoint import changepoint_segmentation
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
from .result import Segment, Segmentation
from .stage1 import Stage1Params
from .templates import TemplateChoice, Templates, resolve_templates, train_templates


def segment(
    demo_or_traj: Demonstration | Trajectory,
    templates: Templates | TemplateChoice | None = None,
    *,
    search: Search = "dp",
    grammar: GrammarUse = "enforce",
    params: SegmentParams | None = None,
) -> Segmentation:
    """Segment a demonstration into skills.

    Parameters
    ----------
    demo_or_traj : Demonstration or Trajectory
        A recording (preprocessed here) or an already preprocessed trajectory.
    templates : Templates or {"default", "paper"}, optional
        Skill templates; the ones shipped with the package if omitted (``"default"``);
        ``"paper"``: the shipped templates of the paper's recipe (:data:`PAPER`).
    search : {"dp", "greedy"}
        ``dp`` (default): the globally optimal segmental DP; ``greedy``: the paper's greedy cut
        loop (Eq. 3-5).
    grammar : {"enforce", "warn", "off"}
        ``enforce`` (default): consider only allowed skill transitions; ``warn``: keep the best
        result and warn about impossible transitions (the paper, Fig. 6); ``off``: ignore the
        grammar. The paper's algorithm is ``search="greedy", grammar="warn"``, with the paper-recipe
        templates and pipeline (:data:`PAPER`).
    params : SegmentParams, optional
        Stage-1 and stage-2 parameters.

    Returns
    -------
    Segmentation
        Ordered segments covering the demonstration, and warnings.

    Raises
    ------
    DemonstrationError
        No hand data, no tracked object, or too short for any skill.
    ModelFormatError
        The template file cannot be used.
    """
    from .pipeline import as_trajectory

    templates = resolve_templates(templates)
    p = params or SegmentParams()
    wanted = templates.preprocessing
    traj = as_trajectory(demo_or_traj, wanted)
    result = segment_trajectory(traj, templates, search=search, grammar=grammar, params=p)
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
            + "; preprocess with lfd.preprocess(demo, **templates.preprocessing) for best results",
        )
    return result


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
    "train_templates",
]
