"""A segment's one shape while it is being made, :class:`lfd.skills.Draft`: the search's chosen
segments become drafts once (:func:`search_drafts`), the passes take and return them
(:mod:`~lfd.segmentation.passes`), and they become :class:`~lfd.segmentation.result.Segment`
once (:func:`make_segments`: times and skill parameters in one vectorised pass); the
baselines make theirs the same way (:func:`_make_segment`)."""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence

import numpy as np

from .. import _hmmseg
from ..skills import Draft
from ..trajectory import Trajectory
from .band import StageTwoScores
from .params import skill_params_batch
from .result import Segment


def search_drafts(
    st: StageTwoScores, cuts: Sequence[_hmmseg.Cut], skills: Sequence[str]
) -> list[Draft]:
    """The segments the search chose (``cuts``, over the score band ``st`` of the templates'
    ``skills``) as drafts: skill, samples, the target object of the band's entry, the scores."""
    return [
        Draft(skills[c.skill], c.start, c.end, _target(st, c), c.score, c.confidence, c.margin)
        for c in cuts
    ]


def _target(st: StageTwoScores, cut: _hmmseg.Cut) -> int:
    """The target object of a chosen segment (a run of the band: the search picks no other)."""
    i, j = cut.start_section, cut.end_section
    r = st.band.index(i, j)
    if r is None:
        raise AssertionError(f"the search chose sections {i}..{j}, outside the score band")
    return int(st.target[r, cut.skill])


def make_segments(traj: Trajectory, drafts: Sequence[Draft]) -> list[Segment]:
    """The segments of ``drafts`` on ``traj``, their times and skill parameters computed in one
    vectorised pass."""
    if not drafts:
        return []
    n = len(traj)
    t_ns = np.asarray(traj.t_ns)
    start = np.array([d.start for d in drafts], dtype=np.intp)
    end = np.minimum(np.array([d.end for d in drafts], dtype=np.intp), n - 1)
    # as Trajectory.t_s at these samples (an end past the last sample: the last sample)
    start_s = ((t_ns[start] - t_ns[0]).astype(np.float64) * 1e-9).tolist()
    end_s = ((t_ns[end] - t_ns[0]).astype(np.float64) * 1e-9).tolist()
    start_ns, end_ns = t_ns[start].tolist(), t_ns[end].tolist()
    params = skill_params_batch(
        traj,
        [d.skill for d in drafts],
        [d.start for d in drafts],
        [d.end for d in drafts],
        [d.obj for d in drafts],
    )
    return [
        Segment(
            skill=d.skill,
            start=int(d.start),
            end=int(d.end),
            start_s=float(start_s[i]),
            end_s=float(end_s[i]),
            start_ns=int(start_ns[i]),
            end_ns=int(end_ns[i]),
            object=traj.object_names[d.obj] if d.obj is not None else None,
            score=float(d.score),
            confidence=float(d.confidence),
            margin=float(d.margin),
            params=params[i],
        )
        for i, d in enumerate(drafts)
    ]


def _make_segment(
    traj: Trajectory,
    skill: str,
    start: int,
    end: int,
    target: np.ndarray | int | None,
    score: float = float("nan"),
    confidence: float = float("nan"),
    margin: float = float("nan"),
) -> Segment:
    """One segment (:func:`make_segments`); ``target``: the object index, or per-sample
    object indices whose most common one on ``start..end`` is the target."""
    obj: int | None = None
    if isinstance(target, int):
        obj = target
    elif target is not None and end > start:
        obj = Counter(target[start:end].tolist()).most_common(1)[0][0]
    return make_segments(traj, [Draft(skill, start, end, obj, score, confidence, margin)])[0]
