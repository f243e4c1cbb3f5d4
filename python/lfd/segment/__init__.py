"""Two-stage skill segmentation of a demonstration (paper Sec. III-B).

>>> import lfd
>>> from lfd.segment import segment
>>> result = segment(lfd.load("recordings/exp1.mcap"))          # doctest: +SKIP
>>> result.skill_sequence                                        # doctest: +SKIP
['pick_up', 'move_with', 'place', 'move', ...]

Stage 1 over-segments at threshold crossings of the fingertip distance, hand speed and TCP
rise/fall; stage 2 merges the data sections into skills by HMM template matching, with the
TCP-rise decision tree (Fig. 5) and the skill grammar (Fig. 6), either by the paper's greedy cut
loop (``search="greedy"``) or by a globally optimal segmental DP (``search="dp"``).
"""

from __future__ import annotations

import sys
import types
from typing import Any

from ..demo import Demonstration
from ..trajectory import Trajectory
from .baselines import gripper_segmentation, proximity_segmentation
from .metrics import all_metrics
from .pipeline import GrammarUse, Search, SegmentParams, segment_trajectory
from .result import Segment, Segmentation
from .stage1 import Stage1Params
from .templates import Templates, train_templates


def segment(
    demo_or_traj: Demonstration | Trajectory,
    templates: Templates | None = None,
    *,
    search: Search = "greedy",
    grammar: GrammarUse = "warn",
    params: SegmentParams | None = None,
) -> Segmentation:
    """Segment a demonstration into skills.

    Parameters
    ----------
    demo_or_traj : Demonstration or Trajectory
        A recording (preprocessed here) or an already preprocessed trajectory.
    templates : Templates, optional
        Skill templates; the ones shipped with the package if omitted.
    search : {"greedy", "dp"}
        The paper's greedy cut loop, or the globally optimal segmental DP.
    grammar : {"warn", "enforce", "off"}
        ``warn``: keep the best result and warn about impossible skill transitions (the paper);
        ``enforce``: consider only allowed transitions; ``off``: ignore the grammar.
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

    templates = templates or Templates.default()
    p = params or SegmentParams()
    cutoff = float(templates.meta.get("feature_cutoff_hz", p.feature_cutoff_hz))
    traj = as_trajectory(demo_or_traj, feature_cutoff_hz=cutoff)
    result = segment_trajectory(traj, templates, search=search, grammar=grammar, params=p)
    used = traj.meta.get("feature_cutoff_hz")
    if isinstance(used, int | float) and abs(float(used) - cutoff) > 1e-9:
        result.warnings.insert(
            0,
            f"the trajectory was filtered at {used} Hz but the templates were trained on "
            f"{cutoff} Hz features; preprocess with feature_cutoff_hz={cutoff} for best results",
        )
    return result


__all__ = [
    "Segment",
    "SegmentParams",
    "Segmentation",
    "Stage1Params",
    "Templates",
    "all_metrics",
    "gripper_segmentation",
    "proximity_segmentation",
    "segment",
    "train_templates",
]


class _CallableModule(types.ModuleType):
    """Lets ``lfd.segment(demo)`` call :func:`segment` while ``lfd.segment`` stays a package."""

    def __call__(
        self,
        demo_or_traj: Demonstration | Trajectory,
        templates: Templates | None = None,
        **kwargs: Any,
    ) -> Segmentation:
        return segment(demo_or_traj, templates, **kwargs)


sys.modules[__name__].__class__ = _CallableModule
