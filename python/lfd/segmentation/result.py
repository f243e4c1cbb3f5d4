"""The result of a segmentation: ordered skill segments, warnings and a JSON task program."""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from ..demo import SkillLabel
from .metrics import all_metrics

if TYPE_CHECKING:
    from ..features import Features
    from ..trajectory import Trajectory
    from .band import StageTwoScores

RESULT_FORMAT_VERSION = 2
"""Version of the JSON written by :meth:`Segmentation.to_json` (2: ``confidence`` is a posterior
probability in [0, 1]; the raw score margin is ``margin``)."""


@dataclass
class Segment:
    """One skill segment.

    Attributes
    ----------
    skill : str
        Canonical skill name (:data:`lfd.skills.SKILLS`).
    start, end : int
        Sample indices into the trajectory, ``end`` exclusive.
    start_s, end_s : float
        Seconds since the first trajectory sample.
    start_ns, end_ns : int
        Absolute times (int64 ns, the recording's clock); ``end_ns`` is the next segment's start.
    object : str or None
        Target object name: the object that best explains the segment's samples; for a Move,
        the object it goes towards (:func:`lfd.segmentation.passes.label_moves`; None for a
        Move that ends the demonstration).
    score : float
        Summed feature log-likelihood per sample of the chosen skill (NaN for baselines and for
        an implicit re-grasp Move, which the grammar implies and no template scored; ``null``
        in JSON).
    confidence : float
        Posterior probability, in [0, 1], of the chosen skill among the candidate skills on the
        same samples (those the TCP-rise decision allows), from their per-sample scores with
        equal priors: ``exp(score) / sum(exp(score_o))``. 1 without a rival, at most 0.5 when a
        rival explains the samples at least as well (the grammar chose this skill). NaN for
        the baselines and implicit Moves.
    margin : float
        Raw margin of ``score`` over the best other candidate skill, in nats per sample (``inf``
        when no other skill was a candidate, negative when a rival is more likely, NaN for the
        baselines).
    params : dict
        Skill parameters (grasp pose, place pose, push displacement, ...), see
        :func:`lfd.segmentation.params.skill_params`.
    """

    skill: str
    start: int
    end: int
    start_s: float
    end_s: float
    start_ns: int
    end_ns: int
    object: str | None = None
    score: float = float("nan")
    confidence: float = float("nan")
    margin: float = float("nan")
    params: dict[str, Any] = field(default_factory=dict)

    @property
    def duration_s(self) -> float:
        """Length in seconds."""
        return self.end_s - self.start_s

    def to_label(self) -> SkillLabel:
        """The segment as a :class:`~lfd.demo.SkillLabel` (e.g. to save into a recording)."""
        return SkillLabel(self.skill, self.start_ns, self.end_ns, self.object)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict (non-finite numbers become ``None``)."""
        return {
            "skill": self.skill,
            "start_s": self.start_s,
            "end_s": self.end_s,
            "start_ns": self.start_ns,
            "end_ns": self.end_ns,
            "object": self.object,
            "score": _finite(self.score),
            "confidence": _finite(self.confidence),
            "margin": _finite(self.margin),
            "params": self.params,
        }


def _finite(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


@dataclass(frozen=True)
class Run:
    """What one segmentation ran on and computed: everything a viewer, ``reproduce --segment``,
    the LeRobot export or ``--json`` needs, so that nothing is preprocessed or scored twice.

    Attributes
    ----------
    trajectory : Trajectory
        The samples that were segmented (preprocessed with the method's preprocessing, gaps
        filled); the segments' ``start``/``end`` index it.
    features : Features
        The Table I features of ``trajectory`` (target: the nearest object).
    object_features : list[Features]
        The features with each object as the target, in object order.
    scores : StageTwoScores
        The stage-2 score band (summed log-likelihoods of runs of sections under each skill).
    method : Method or None
        The method (None when :func:`~lfd.segmentation.pipeline.segment_trajectory` was called
        directly).
    """

    trajectory: Trajectory
    features: Features
    object_features: list[Features]
    scores: StageTwoScores
    method: Any = None  # a Method (lfd.segmentation.method imports this module)


@dataclass
class Segmentation:
    """A demonstration cut into skills.

    Attributes
    ----------
    segments : list[Segment]
        In time order, covering the whole trajectory.
    warnings : list[str]
        Impossible transitions, relaxed constraints, data problems.
    method : str
        ``"greedy"``, ``"dp"``, ``"changepoint"``, ``"proximity"`` or ``"gripper"``.
    sections : list[int]
        Stage-1 section boundaries (sample indices ``[0, ..., n]``); empty for baselines.
    object_names : list[str]
        Names of the trajectory's objects.
    run : Run or None
        The run that made it (trajectory, features, scores, method); None for baselines and
        for results read back from JSON.
    """

    segments: list[Segment]
    warnings: list[str] = field(default_factory=list)
    method: str = "greedy"
    sections: list[int] = field(default_factory=list)
    object_names: list[str] = field(default_factory=list)
    run: Run | None = field(default=None, repr=False, compare=False)

    def __len__(self) -> int:
        return len(self.segments)

    @property
    def skill_sequence(self) -> list[str]:
        """Skill names in order."""
        return [s.skill for s in self.segments]

    def to_labels(self) -> list[SkillLabel]:
        """The segments as :class:`~lfd.demo.SkillLabel` objects."""
        return [s.to_label() for s in self.segments]

    def to_dict(self) -> dict[str, Any]:
        """The task program as a JSON-ready dict."""
        return {
            "format_version": RESULT_FORMAT_VERSION,
            "method": self.method,
            "objects": list(self.object_names),
            "segments": [s.to_dict() for s in self.segments],
            "warnings": list(self.warnings),
        }

    def to_json(self, **kwargs: Any) -> str:
        """The task program as JSON text (``kwargs`` go to :func:`json.dumps`)."""
        kwargs.setdefault("indent", 2)
        return json.dumps(self.to_dict(), **kwargs)

    @property
    def origin_ns(self) -> int:
        """The absolute time (ns) that ``start_s`` / ``end_s`` count from: the first sample."""
        first = self.segments[0]
        return first.start_ns - round(first.start_s * 1e9)

    def report(
        self,
        ground_truth: Sequence[SkillLabel] = (),
        *,
        recording: str | None = None,
        exclude: Sequence[tuple[int, int]] = (),
    ) -> dict[str, Any]:
        """The document of ``lfd segment --json``: the segments, the ground truth on the same
        clock, and the metrics against it (``{}`` without ground truth; non-finite -> ``None``),
        left out inside the ``exclude`` spans (``[start_ns, end_ns)``, e.g. where another hand
        handles the object: :func:`~lfd.segmentation.metrics.excluded_spans`; listed in
        ``excluded_s``).

        ``origin_ns`` is the absolute time ``start_s`` / ``end_s`` count from; ``lfd label``
        reads it back (:func:`lfd.io.labels.read_labels`).
        """
        t0 = self.segments[0].start_ns
        doc: dict[str, Any] = {
            "recording": recording,
            "method": self.method,
            "origin_ns": self.origin_ns,
            "segments": [s.to_dict() for s in self.segments],
            "warnings": list(self.warnings),
            "ground_truth": [
                {
                    "skill": lab.skill,
                    "start_s": (lab.start_ns - t0) * 1e-9,
                    "end_s": (lab.end_ns - t0) * 1e-9,
                    "object": lab.object,
                }
                for lab in ground_truth
            ],
            "metrics": {},
        }
        if self.run is not None and self.run.method is not None:
            doc["method_detail"] = self.run.method.describe()
        if exclude:
            doc["excluded_s"] = [[(a - t0) * 1e-9, (b - t0) * 1e-9] for a, b in exclude]
        if ground_truth:
            metrics = all_metrics(self.segments, ground_truth, exclude=exclude)
            doc["metrics"] = {k: _finite(v) for k, v in metrics.items()}
        return doc
