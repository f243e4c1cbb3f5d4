"""Live segmentation: raw recording messages in, settled skills out.

:class:`LiveSegmentation` chains the causal preprocessing and features
(:class:`~lfd.preprocessing.online.OnlinePreprocessor`,
:class:`~lfd.preprocessing.online.OnlineFeatures`, docs/live.md) and the online segmenter
(:class:`~lfd.segmentation.online.OnlineSegmenter`). It is what ``lfd record --live-segment``
and ``lfd segment --follow`` run, and what ``benches/segment_live.py`` measures: hand keypoint
frames and object poses go in as they arrive, in any interleaving; skill segments come out
once they settle, with their object, score and confidence, and never change afterwards.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from ..demo import Demonstration, SkillLabel
from ..preprocessing.online import (
    FeatureSample,
    HandMessage,
    ObjectMessage,
    OnlineFeatures,
    OnlinePreprocessor,
    demo_messages,
)
from .online import (
    DEFAULT_BEAM,
    DEFAULT_LAG_S,
    DEFAULT_STABLE_S,
    OnlineSegmenter,
    Provisional,
)
from .pipeline import SegmentParams
from .result import Segment, Segmentation
from .templates import TemplateChoice, Templates, resolve_templates

PREPROCESSOR_OPTIONS = ("max_wait_s", "smoother", "lookahead_s", "window_s")
"""Options of :meth:`LiveSegmentation.for_demonstration` that go to its
:class:`~lfd.preprocessing.online.OnlinePreprocessor`."""


@dataclass(frozen=True)
class Span:
    """A skill span on the recording's clock (what the live views draw)."""

    skill: str
    start_ns: int
    end_ns: int
    object: str | None = None


@dataclass
class LiveUpdate:
    """What one message produced."""

    segments: list[Segment] = field(default_factory=list)
    """Newly settled segments, in time order (never revised)."""
    rows: list[FeatureSample] = field(default_factory=list)
    """Feature rows determined by the message (for live views)."""
    provisional: Provisional | None = None
    """The skill the best current hypothesis ends with."""
    sections: list[int] = field(default_factory=list)
    """Stage-1 section boundaries found (ns on the recording's clock, moved back by the
    filters' delay like the segments)."""


class LiveSegmentation:
    """Segment a demonstration from its raw messages while it is recorded.

    Parameters
    ----------
    object_names, object_sizes :
        The objects and their box sizes (k, 3), metres.
    templates : Templates or {"default", "paper"}, optional
        As :func:`lfd.segment`; their preprocessing options are used (causally).
    side : {"right", "left"}
        The demonstrating hand.
    hand_rate_hz : float, optional
        The hand-pose estimator's frame rate (for the ``auto`` filter cut-off).
    params : SegmentParams, optional
        As offline.
    lag_s, beam, stable_s :
        Settling of the online segmenter (see :class:`~lfd.segmentation.online.OnlineSegmenter`).
    preprocessor : OnlinePreprocessor, optional
        A causal preprocessor made by the caller; it replaces the one built from
        ``object_names``, ``object_sizes``, ``side``, ``hand_rate_hz``, ``max_wait_s`` and the
        templates' options.
    max_wait_s : float, optional
        Longest wait for a silent stream (see
        :class:`~lfd.preprocessing.online.OnlinePreprocessor`).
    """

    def __init__(
        self,
        object_names: Sequence[str],
        object_sizes: npt.ArrayLike,
        templates: Templates | TemplateChoice | None = None,
        *,
        side: str = "right",
        hand_rate_hz: float | None = None,
        params: SegmentParams | None = None,
        lag_s: float = DEFAULT_LAG_S,
        beam: float = DEFAULT_BEAM,
        stable_s: float | None = DEFAULT_STABLE_S,
        max_wait_s: float | None = None,
        preprocessor: OnlinePreprocessor | None = None,
    ) -> None:
        self.templates = resolve_templates(templates)
        self.pre = preprocessor or OnlinePreprocessor(
            object_names,
            object_sizes,
            side=side,
            hand_rate_hz=hand_rate_hz,
            max_wait_s=max_wait_s,
            **(self.templates.preprocessing or {}),
        )
        self.features = OnlineFeatures(
            self.pre.object_names, self.pre.object_sizes, self.pre.rate_hz
        )
        self.segmenter = OnlineSegmenter(
            self.templates,
            self.pre.object_names,
            1.0 / self.pre.rate_hz,
            params=params,
            lag_s=lag_s,
            beam=beam,
            stable_s=stable_s,
        )
        self.settled_ns: list[int] = []
        """Message time at which each emitted segment settled (same order as the segments)."""
        self.lag_samples = self.pre.shift_samples
        """The causal filters' delay, in samples: emitted segments are moved back by it, so
        their boundaries are where the skills happened rather than where the filtered signals
        showed them."""
        self._emitted: list[Segment] = []
        self._n_bounds = 0
        self._now: int | None = None
        self._first: int | None = None
        self._pending: HandMessage | None = None
        self._started = False

    @classmethod
    def for_demonstration(
        cls,
        demo: Demonstration,
        templates: Templates | TemplateChoice | None = None,
        **options: Any,
    ) -> LiveSegmentation:
        """For the objects, sizes, hand side and hand rate of a recording
        (:meth:`OnlinePreprocessor.for_demonstration`)."""
        resolved = resolve_templates(templates)
        causal = {k: options.pop(k) for k in PREPROCESSOR_OPTIONS if k in options}
        pre = OnlinePreprocessor.for_demonstration(
            demo, **{"max_wait_s": None, **causal}, **(resolved.preprocessing or {})
        )
        return cls(pre.object_names, pre.object_sizes, resolved, preprocessor=pre, **options)

    @property
    def object_names(self) -> list[str]:
        return self.pre.object_names

    @property
    def warnings(self) -> list[str]:
        """Dropped or repaired input, from every stage, in order of the stages."""
        return list(self.pre.warnings) + list(self.segmenter.warnings)

    def push(self, message: HandMessage | ObjectMessage) -> LiveUpdate:
        """One hand frame or object pose, as it arrives."""
        self._now = max(self._now or message.t_ns, message.t_ns)
        rows: list[FeatureSample] = []
        for s in self.pre.push(message):
            rows += self.features.push(s)
        return self._feed(rows)

    def push_hand(
        self, t_ns: int, keypoints: npt.ArrayLike, confidence: npt.ArrayLike | None = None
    ) -> LiveUpdate:
        """A hand keypoint frame (21, 3), metres, with per-keypoint confidence."""
        kp = np.asarray(keypoints, dtype=np.float64).reshape(21, 3)
        conf = None if confidence is None else np.asarray(confidence, dtype=np.float64)
        return self.push(HandMessage(int(t_ns), kp, conf))

    def push_object(
        self, name: str, t_ns: int, position: npt.ArrayLike, quaternion: npt.ArrayLike
    ) -> LiveUpdate:
        """An object pose (centre, metres; quaternion xyzw)."""
        return self.push(
            ObjectMessage(
                int(t_ns),
                name,
                np.asarray(position, dtype=np.float64).reshape(3),
                np.asarray(quaternion, dtype=np.float64).reshape(4),
            )
        )

    def push_recorded(self, kind: str, t_ns: int, value: Any) -> LiveUpdate:
        """A decoded message of a recording as :func:`lfd.io.follow` yields it (``kind``
        ``hand``: keypoints (21, 3); ``confidence``: ``(confidence, visible)``; ``object``: an
        object pose; any other kind is ignored). A hand frame is held until its confidence
        (written right after it, same time) or any later message arrives."""
        out = LiveUpdate()
        if kind == "confidence" and self._pending is not None and self._pending.t_ns == t_ns:
            conf = np.asarray(value[0], dtype=np.float64)
            held, self._pending = self._pending, None
            return self.push(HandMessage(held.t_ns, held.keypoints, conf))
        if kind in ("hand", "object") and self._pending is not None:
            held, self._pending = self._pending, None
            out = self.push(held)
        if kind == "hand":
            kp = np.asarray(value, dtype=np.float64).reshape(21, 3)
            self._pending = HandMessage(int(t_ns), kp, None)
        elif kind == "object":
            more = self.push_object(value.name, t_ns, value.position, value.quaternion)
            out.segments += more.segments
            out.rows += more.rows
            out.sections += more.sections
            out.provisional = more.provisional
        return out

    def _feed(self, rows: list[FeatureSample]) -> LiveUpdate:
        out = LiveUpdate(rows=rows, provisional=self.segmenter.provisional)
        for r in rows:
            # rows before the hand and every object were seen once are NaN: nothing to segment
            if not self._started and not (
                np.isfinite(r.values).all() and np.isfinite(r.object_values).all()
            ):
                continue
            self._started = True
            if self._first is None:
                self._first = r.t_ns
            s = r.sample
            up = self.segmenter.push(
                r.t_ns,
                r.values,
                r.thresholds,
                r.object_values,
                r.object_thresholds,
                s.tcp,
                r.object_position,
                rotation=s.rotation,
                object_quaternion=s.object_quaternion,
            )
            out.segments += [self._back(s) for s in up.segments]
            out.provisional = up.provisional
        self.settled_ns += [self._now or 0] * len(out.segments)
        self._emitted += out.segments
        out.sections = self._new_sections()
        return out

    def _ns(self, index: int) -> int:
        """The recording time of sample ``index`` of the online trajectory."""
        return (self._first or 0) + round(index * (1.0 / self.pre.rate_hz) * 1e9)

    def _new_sections(self) -> list[int]:
        if self._first is None:
            return []
        new = self.segmenter.boundaries(self._n_bounds)
        self._n_bounds += len(new)
        return [self._ns(max(b - self.lag_samples, 0)) for b in new]

    def _back(self, seg: Segment, *, last: bool = False) -> Segment:
        """``seg`` moved back by the filters' delay (the recording's last segment keeps its
        end; the first sample stays the first)."""
        k = self.lag_samples
        if k == 0 or self._first is None:
            return seg
        start = max(seg.start - k, 0)
        end = seg.end if last else max(seg.end - k, start + 1)
        dt = 1.0 / self.pre.rate_hz
        return dataclasses.replace(
            seg,
            start=start,
            end=end,
            start_s=start * dt,
            end_s=end * dt,
            start_ns=self._ns(start),
            end_ns=seg.end_ns if last else self._ns(end),
        )

    def finish(self) -> LiveUpdate:
        """End of the recording: the samples still buffered, and every remaining segment."""
        first = LiveUpdate()
        if self._pending is not None:
            held, self._pending = self._pending, None
            first = self.push(held)
        rows: list[FeatureSample] = []
        for s in self.pre.flush():
            rows += self.features.push(s)
        rows += self.features.flush()
        out = self._feed(rows)
        if self._started:
            n = self.segmenter.n_samples
            last = [self._back(s, last=s.end >= n) for s in self.segmenter.finish()]
            out.segments += last
            self.settled_ns += [self._now or 0] * len(last)
            self._emitted += last
            out.sections += self._new_sections()
        out.provisional = None
        out.segments[:0] = first.segments
        out.rows[:0] = first.rows
        out.sections[:0] = first.sections
        return out

    def provisional_span(self) -> Span | None:
        """The provisional skill from its start to the newest sample (None before any)."""
        p = self.segmenter.provisional
        if p is None or self._first is None:
            return None
        start = self._ns(max(p.start - self.lag_samples, 0))
        return Span(p.skill, start, max(start, self._now or start))

    def result(self) -> Segmentation:
        """Everything emitted so far, as a :class:`Segmentation`."""
        result = self.segmenter.result()
        return dataclasses.replace(
            result, segments=list(self._emitted), warnings=[*self.pre.warnings, *result.warnings]
        )


def label_of(seg: Segment) -> SkillLabel:
    """A settled segment as a skill label (for ``/lfd/live/segments``)."""
    return SkillLabel(seg.skill, int(seg.start_ns), int(seg.end_ns), seg.object)


def segment_live(
    demo: Demonstration,
    templates: Templates | TemplateChoice | None = None,
    *,
    messages: Iterable[HandMessage | ObjectMessage] | None = None,
    **options: Any,
) -> tuple[Segmentation, np.ndarray]:
    """Replay a recording's messages in time order through :class:`LiveSegmentation`; returns
    the final segmentation and, per segment, the message time (ns) it settled at."""
    live = LiveSegmentation.for_demonstration(demo, templates, **options)
    for msg in messages if messages is not None else demo_messages(demo):
        live.push(msg)
    live.finish()
    return live.result(), np.asarray(live.settled_ns, dtype=np.int64)
