"""What ``lfd record`` does beside the file: segment live and show it in Rerun.

:class:`LiveObserver` is the :class:`~lfd.perception.record.RecordObserver` that ``lfd record
--live-segment`` and ``--rerun*`` pass to :func:`lfd.perception.record.record`: every object pose
and hand sample written also goes to a :class:`~lfd.segmentation.live.LiveSegmentation` and to a
:class:`~lfd.viz.live.LiveTimeline`; each skill the segmenter settles is returned to be written
to ``/lfd/live/segments`` at once (and is drawn). It sits above the stages it composes
(perception, segmentation, viz; ARCHITECTURE.md, "Layers"), which do not know each other.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from .demo import HAND_BONES, SkillLabel

if TYPE_CHECKING:
    from .segmentation.live import LiveSegmentation, LiveUpdate

__all__ = ["LiveObserver"]


class LiveObserver:
    """Live segmentation and the live Rerun view of a recording being made.

    Parameters
    ----------
    segmenter : LiveSegmentation, optional
        Fed every object pose and hand sample (``--live-segment``).
    timeline : lfd.viz.live.LiveTimeline, optional
        Shows the frames, poses, hand and the segmenter's features, sections and skills.
    """

    def __init__(self, segmenter: LiveSegmentation | None = None, timeline: Any = None) -> None:
        self.segmenter, self.timeline = segmenter, timeline

    @classmethod
    def open(
        cls,
        objects: Iterable[tuple[str, int, Any]],
        *,
        segmenter: LiveSegmentation | None = None,
        view: bool = False,
    ) -> LiveObserver:
        """An observer for a recording of ``objects`` ``(name, tag_id, size)``; ``view``: a
        :class:`~lfd.viz.live.LiveTimeline` on the current Rerun recording (open one first,
        e.g. :func:`lfd.viz.open_session`)."""
        timeline = None
        if view:
            from .viz.live import LiveTimeline

            timeline = LiveTimeline(
                objects=objects,
                object_names=None if segmenter is None else segmenter.object_names,
            )
        return cls(segmenter, timeline)

    def on_frame(
        self, t_ns: int, color: np.ndarray, poses: Mapping[str, tuple[np.ndarray, np.ndarray]]
    ) -> list[tuple[SkillLabel, int, dict[str, str]]]:
        settled = []
        if self.segmenter is not None:
            for name, (p, q) in poses.items():
                settled += self._emit(self.segmenter.push_object(name, t_ns, p, q), t_ns)
        if self.timeline is not None:
            self.timeline.log_camera(t_ns, color)
            for name, (p, q) in poses.items():
                self.timeline.log_object(name, t_ns, p, q)
        return settled

    def on_hand(
        self,
        t_ns: int,
        keypoints: np.ndarray | None,
        confidence: np.ndarray | None,
        keypoints_2d: np.ndarray | None,
    ) -> list[tuple[SkillLabel, int, dict[str, str]]]:
        settled = []
        if self.segmenter is not None:
            if keypoints is None:  # no hand found: an unobserved frame
                update = self.segmenter.push_hand(t_ns, np.full((21, 3), np.nan), np.zeros(21))
            else:
                update = self.segmenter.push_hand(t_ns, keypoints, confidence)
            settled = self._emit(update, t_ns)
        if self.timeline is not None and keypoints is not None:
            self.timeline.log_hand(t_ns, keypoints)
            if keypoints_2d is not None:
                self.timeline.log_hand_2d(t_ns, [keypoints_2d[[a, b]] for a, b in HAND_BONES])
        return settled

    def finish(self, t_ns: int) -> list[tuple[SkillLabel, int, dict[str, str]]]:
        if self.segmenter is None:
            return []
        return self._emit(self.segmenter.finish(), t_ns)

    def _emit(self, update: LiveUpdate, t_ns: int) -> list[tuple[SkillLabel, int, dict[str, str]]]:
        """The skills ``update`` settled, logged at ``t_ns`` (or their end, if later); the update
        drawn."""
        from .segmentation.live import label_of

        assert self.segmenter is not None
        settled = [
            (
                label_of(s),
                max(int(t_ns), int(s.end_ns)),
                {"score": f"{s.score:.6g}", "confidence": f"{s.confidence:.6g}"},
            )
            for s in update.segments
        ]
        if self.timeline is not None:
            self.timeline.log_update(update, self.segmenter.provisional_span())
        return settled
