"""Segment one recording file: the task :mod:`lfd.batch` runs for ``lfd segment A B ... | DIR``.

A task takes a path and plain options (picklable, so it runs in a worker process or on a Ray
node; a :class:`~lfd.segmentation.method.Method` pickles as its portable text) and gives plain
data back: the ``lfd segment --json`` document of the recording.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .method import Method

if TYPE_CHECKING:
    from ..demo import Demonstration, SkillLabel
    from ..trajectory import Trajectory
    from .hands import HandsSegmentation
    from .result import Segmentation


def segment_file(
    path: str | Path,
    *,
    method: Method | None = None,
    load_options: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """Load ``path``, segment it and return the ``lfd segment --json`` document
    (:meth:`~lfd.segmentation.Segmentation.report` with its ground truth).

    ``method``: the method (``None``: the default one; a worker gets it pickled,
    :meth:`Method.portable`); ``load_options``:
    keyword arguments of :func:`lfd.load` (``object_sizes``, a ROS ``mapping``).
    """
    from ..io import load

    demo = load(path, images=False, **(load_options or {}))
    if len(demo.sides) > 1:
        return segment_hands_recording(demo, method, recording=str(path))[1]
    _, doc = segment_recording(demo, method, recording=str(path))
    return doc


def segment_hands_recording(
    demo: Demonstration,
    method: Method | None = None,
    *,
    recording: str | None = None,
) -> tuple[HandsSegmentation, dict[str, Any]]:
    """Segment a loaded two-hand recording as ``lfd segment`` does (:func:`lfd.segment_hands`;
    a hand that reaches no object is not refused: one hand may only watch): the result and its ``--json`` document (:meth:`HandsSegmentation.report`: each hand's
    lane scored against its labels over the whole recording, the handovers against the
    recording's)."""
    from . import segment_hands

    result = segment_hands(demo, method=method or Method.default())
    return result, result.report(demo.labels, demo.handovers, recording=recording)


def segment_recording(
    demo: Demonstration,
    method: Method | None = None,
    *,
    recording: str | None = None,
) -> tuple[Segmentation, dict[str, Any]]:
    """Segment a loaded recording as ``lfd segment`` does: refused when the hand reaches no
    object (:func:`lfd.io.checks.check_hand_reaches`, ``DemonstrationError``), scored against
    its ground truth outside the spans its metadata gives to another hand
    (:func:`~lfd.segmentation.metrics.excluded_spans`), with one warning in the document when
    no object moves but the skills found move one. Returns the segmentation (with its run) and
    the ``--json`` document. (:func:`prepare_recording`, then :meth:`Prepared.segment`.)"""
    return prepare_recording(demo, method).segment(recording=recording)


@dataclass(frozen=True)
class Prepared:
    """A recording made ready for :func:`segment_recording`: its trajectory, preprocessed with
    the method's preprocessing, and what the report reads of the demonstration (the labels, the
    spans left out of the scores, how far each object travels). It holds no sample of the
    demonstration, so a caller that drops the demonstration after :func:`prepare_recording`
    segments a long recording with about half the memory."""

    method: Method
    trajectory: Trajectory
    labels: list[SkillLabel]
    exclude: list[tuple[int, int]]
    travel: dict[str, float]

    def segment(self, *, recording: str | None = None) -> tuple[Segmentation, dict[str, Any]]:
        """The segmentation and the ``--json`` document (see :func:`segment_recording`)."""
        from ..io.checks import unmoved_objects_message
        from . import segment

        result = segment(self.trajectory, method=self.method)
        doc = result.report(self.labels, recording=recording, exclude=self.exclude)
        unmoved = unmoved_objects_message(self.travel, result.skill_sequence)
        if unmoved is not None:
            doc["warnings"].append(unmoved)
        return result, doc


def prepare_recording(demo: Demonstration, method: Method | None = None) -> Prepared:
    """Check and preprocess a loaded recording for :func:`segment_recording`
    (``DemonstrationError`` when the hand reaches no object)."""
    from ..io.checks import check_hand_reaches, object_travel
    from .metrics import excluded_spans
    from .pipeline import as_trajectory

    check_hand_reaches(demo)
    m = method or Method.default()
    return Prepared(
        method=m,
        trajectory=as_trajectory(demo, m.preprocessing),
        labels=list(demo.labels),
        exclude=excluded_spans(demo.metadata, demo.start_ns) if demo.labels else [],
        travel=object_travel(demo),
    )
