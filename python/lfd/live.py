"""What ``lfd record`` does beside the file: segment live and show it in Rerun.

:class:`LiveObserver` is the :class:`~lfd.perception.record.RecordObserver` that ``lfd record
--live-segment`` and ``--rerun*`` pass to :func:`lfd.perception.record.record`: every object pose
and hand sample written also goes to a :class:`~lfd.segmentation.live.LiveSegmentation` and to a
:class:`~lfd.viz.live.LiveTimeline`; each skill the segmenter settles is returned to be written
to ``/lfd/live/segments`` at once (and is drawn). Of two hands the segmenter is a
:class:`~lfd.segmentation.live_hands.LiveHands`, each hand sample names its side, and each
skill settled names its hand. It sits above the stages it composes
(perception, segmentation, viz; ARCHITECTURE.md, "Layers"), which do not know each other.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from .demo import HAND_BONES, CameraInfo, SkillLabel

if TYPE_CHECKING:
    from .segmentation.live import LiveSegmentation, LiveUpdate
    from .segmentation.live_hands import HandsUpdate, LiveHands

__all__ = ["LiveObserver"]


class LiveObserver:
    """Live segmentation and the live Rerun view of a recording being made.

    Parameters
    ----------
    segmenter : LiveSegmentation or LiveHands, optional
        Fed every object pose and hand sample (``--live-segment``); of two hands, a
        ``LiveHands``.
    timeline : lfd.viz.live.LiveTimeline, optional
        Shows the frames, poses, hand and the segmenter's features, sections and skills.
    """

    def __init__(
        self, segmenter: LiveSegmentation | LiveHands | None = None, timeline: Any = None
    ) -> None:
        self.segmenter, self.timeline = segmenter, timeline

    @classmethod
    def open(
        cls,
        objects: Iterable[tuple[str, int, Any]],
        *,
        segmenter: LiveSegmentation | LiveHands | None = None,
        view: bool = False,
        sides: tuple[str, ...] | None = None,
    ) -> LiveObserver:
        """An observer for a recording of ``objects`` ``(name, tag_id, size)``; ``view``: a
        :class:`~lfd.viz.live.LiveTimeline` on the current Rerun recording (open one first,
        e.g. :func:`lfd.viz.open_session`) of the hands ``sides`` (default: the
        segmenter's, else one)."""
        timeline = None
        if view:
            from .viz.live import LiveTimeline

            if sides is None:
                sides = tuple(getattr(segmenter, "sides", ()))
            timeline = LiveTimeline(
                objects=objects,
                object_names=None if segmenter is None else segmenter.object_names,
                sides=sides,
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

    def on_camera(self, camera: CameraInfo) -> list[tuple[SkillLabel, int, dict[str, str]]]:
        """The camera's calibration, once its pose in the world is known: the segmenter's
        check runs use it (:attr:`lfd.segmentation.live.LiveSegmentation.camera`)."""
        if self.segmenter is not None:
            self.segmenter.set_camera(camera)
        return []

    def on_hand(
        self,
        t_ns: int,
        keypoints: np.ndarray | None,
        confidence: np.ndarray | None,
        keypoints_2d: np.ndarray | None,
        side: str | None = None,
    ) -> list[tuple[SkillLabel, int, dict[str, str]]]:
        """A hand sample (of the ``side`` hand; None: the only one)."""
        settled = []
        if self.segmenter is not None:
            conf: np.ndarray | None = confidence
            keypoints_in = keypoints
            if keypoints_in is None:  # no hand found: an unobserved frame
                keypoints_in, conf = np.full((21, 3), np.nan), np.zeros(21)
            update = self.segmenter.push_hand(t_ns, keypoints_in, conf, side=side)
            settled = self._emit(update, t_ns)
        if self.timeline is not None and keypoints is not None:
            self.timeline.log_hand(t_ns, keypoints, side=side)
            if keypoints_2d is not None:
                self.timeline.log_hand_2d(t_ns, [keypoints_2d[[a, b]] for a, b in HAND_BONES])
        return settled

    def finish(self, t_ns: int) -> list[tuple[SkillLabel, int, dict[str, str]]]:
        if self.segmenter is None:
            return []
        return self._emit(self.segmenter.finish(), t_ns)

    def _emit(
        self, update: LiveUpdate | HandsUpdate, t_ns: int
    ) -> list[tuple[SkillLabel, int, dict[str, str]]]:
        """The skills ``update`` settled (each naming its hand, of two), logged at ``t_ns`` (or
        their end, if later); the update drawn."""
        from .segmentation.live import label_of

        assert self.segmenter is not None
        lanes = getattr(update, "lanes", None)
        if lanes is None:
            segments = [(None, s) for s in update.segments]  # type: ignore[union-attr]
        else:
            two = len(lanes) > 1
            segments = [(side if two else None, s) for side, u in lanes.items() for s in u.segments]
        settled = [
            (
                label_of(s, side),
                max(int(t_ns), int(s.end_ns)),
                {"score": f"{s.score:.6g}", "confidence": f"{s.confidence:.6g}"},
            )
            for side, s in sorted(segments, key=lambda x: int(x[1].start_ns))
        ]
        if self.timeline is not None:
            spans = getattr(self.segmenter, "provisional_spans", None)
            provisional = spans() if spans is not None else self.segmenter.provisional_span()  # type: ignore[union-attr]
            self.timeline.log_update(update, provisional)
        return settled
