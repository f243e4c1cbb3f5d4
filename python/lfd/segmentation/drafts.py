"""Segments being built (:class:`_Draft`) and made (:func:`_make_segments`: times and skill
parameters in one vectorised pass), shared by the search, its passes and the baselines."""

from __future__ import annotations

import dataclasses
from collections import Counter
from dataclasses import dataclass

import numpy as np

from ..trajectory import Trajectory
from .params import skill_params_batch
from .result import Segment


@dataclass
class _Draft:
    """A segment being built: ``skill`` on ``start..end`` with target object index ``obj``
    (its parameters are computed once, for all drafts together, by :func:`_make_segments`);
    ``source``: the finished segment it is, unchanged."""

    skill: str
    start: int
    end: int
    obj: int | None
    score: float = float("nan")
    confidence: float = float("nan")
    margin: float = float("nan")
    source: Segment | None = None

    @classmethod
    def of(cls, seg: Segment, names: list[str]) -> _Draft:
        """``seg`` as it is (its target object looked up by name in ``names``)."""
        obj = names.index(seg.object) if seg.object in names else None
        return cls(seg.skill, seg.start, seg.end, obj, seg.score, seg.confidence, seg.margin, seg)

    def resized(self, start: int, end: int) -> _Draft:
        """The same skill, target and scores on ``start..end`` (a new segment)."""
        return dataclasses.replace(self, start=start, end=end, source=None)

    def object_name(self, names: list[str]) -> str | None:
        """The target object's name."""
        if self.source is not None:
            return self.source.object
        return names[self.obj] if self.obj is not None else None


def _make_segments(traj: Trajectory, drafts: list[_Draft]) -> list[Segment]:
    """The segments of ``drafts`` (a draft of a finished segment is that segment), their times
    and skill parameters computed in one vectorised pass."""
    new = [d for d in drafts if d.source is None]
    made: list[Segment] = []
    if new:
        n = len(traj)
        t_ns = np.asarray(traj.t_ns)
        start = np.array([d.start for d in new], dtype=np.intp)
        end = np.minimum(np.array([d.end for d in new], dtype=np.intp), n - 1)
        # as Trajectory.t_s at these samples (an end past the last sample: the last sample)
        start_s = ((t_ns[start] - t_ns[0]).astype(np.float64) * 1e-9).tolist()
        end_s = ((t_ns[end] - t_ns[0]).astype(np.float64) * 1e-9).tolist()
        start_ns, end_ns = t_ns[start].tolist(), t_ns[end].tolist()
        params = skill_params_batch(
            traj,
            [d.skill for d in new],
            [d.start for d in new],
            [d.end for d in new],
            [d.obj for d in new],
        )
        made = [
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
            for i, d in enumerate(new)
        ]
    it = iter(made)
    return [d.source if d.source is not None else next(it) for d in drafts]


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
    """One segment (:func:`_make_segments`); ``target``: the object index, or per-sample
    object indices whose most common one on ``start..end`` is the target."""
    obj: int | None = None
    if isinstance(target, int):
        obj = target
    elif target is not None and end > start:
        obj = Counter(target[start:end].tolist()).most_common(1)[0][0]
    return _make_segments(traj, [_Draft(skill, start, end, obj, score, confidence, margin)])[0]
