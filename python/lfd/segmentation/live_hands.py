"""Live segmentation of both hands: a lane per hand, the runs over both hands together.

:class:`LiveHands` is :class:`~lfd.segmentation.live.LiveSegmentation` for a recording of one
or two hands (``lfd record --live-segment``, ``lfd segment --follow`` of a two-hand recording).
Each hand keeps its lane: its frames (a :class:`~lfd.segmentation.live.HandMessage` names its
``side``), its settled skills, its provisional one; the object poses go to every lane. Every
``every_s`` of recording :func:`lfd.segment_hands` runs on the recording so far, both hands
together, and each lane settles its skills from its own lane of the run by the one-hand rules
(:meth:`LiveSegmentation.settle`). A handover of the run settles once the giver's lane has
settled up to its end and the taker's up to its start. When the recording ends, the batch
segmentation of the whole recording (``lfd.segment_hands``) gives what is still open, so at the
end live equals batch wherever the settled skills were right, as for one hand (docs/live.md).
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from ..demo import HAND_SIDES, CameraInfo, Demonstration, Handover, SkillLabel, check_side
from ..errors import InvalidParameterError, LfdError
from .live import (
    DEFAULT_EVERY_S,
    DEFAULT_TOLERANCE_S,
    HandMessage,
    LiveSegmentation,
    LiveUpdate,
    ObjectMessage,
    Span,
    demo_messages,
    label_of,
    recording_arguments,
)
from .method import Method
from .result import Segment, Segmentation
from .templates import TemplateChoice, Templates

if TYPE_CHECKING:
    from .hands import HandsSegmentation


@dataclass
class HandsUpdate:
    """What one message produced, per hand."""

    lanes: dict[str, LiveUpdate] = field(default_factory=dict)
    """Each hand's update (its newly settled segments, feature rows, provisional span)."""
    handovers: list[Handover] = field(default_factory=list)
    """Newly settled handovers (never revised)."""

    @property
    def labels(self) -> list[SkillLabel]:
        """The newly settled segments of every lane as labels naming their hand, in time
        order (what ``/lfd/live/segments`` gets)."""
        out = [label_of(s, side) for side, up in self.lanes.items() for s in up.segments]
        return sorted(out, key=lambda lab: (lab.start_ns, lab.hand or ""))


class LiveHands:
    """Segment one or two hands from their raw messages while they are recorded.

    Parameters
    ----------
    object_names, object_sizes, templates, method, params, tag_ids, metadata :
        As :class:`~lfd.segmentation.live.LiveSegmentation`.
    sides : sequence of {"right", "left"}
        The hands recorded (a lane each), the right first.
    options :
        The settling settings of :class:`~lfd.segmentation.live.LiveSegmentation`
        (``every_s``, ``lag_s``, ...), the same for every lane.
    """

    def __init__(
        self,
        object_names: Sequence[str],
        object_sizes: npt.ArrayLike,
        templates: Templates | TemplateChoice | None = None,
        *,
        method: Method | str | None = None,
        sides: Sequence[str] = HAND_SIDES,
        params: Any = None,
        tag_ids: Sequence[int] | None = None,
        metadata: dict[str, Any] | None = None,
        **options: Any,
    ) -> None:
        from . import resolve_method

        for side in sides:
            check_side(side, "live segmentation")
        if not sides or len(set(sides)) != len(sides):
            raise InvalidParameterError(f"live segmentation: one or two sides, got {sides!r}")
        self.method = resolve_method(templates, method).with_options(params=params)
        self.lanes = {
            side: LiveSegmentation(
                object_names,
                object_sizes,
                method=self.method,
                side=side,
                tag_ids=tag_ids,
                metadata=metadata,
                **options,
            )
            for side in sorted(sides, key=HAND_SIDES.index)
        }
        every_s = options.get("every_s", DEFAULT_EVERY_S)
        self.every_ns = round(every_s * 1e9)
        self.tolerance_ns = round(options.get("tolerance_s", DEFAULT_TOLERANCE_S) * 1e9)
        self._newest_hand: int | None = None
        self._next_run: int | None = None
        self._handovers: list[Handover] = []
        self._last: HandsSegmentation | None = None
        self._final: HandsSegmentation | None = None
        self._warnings: list[str] = []
        self._finished = False

    @classmethod
    def for_demonstration(
        cls,
        demo: Demonstration,
        templates: Templates | TemplateChoice | None = None,
        **options: Any,
    ) -> LiveHands:
        """For the objects, sizes, tag ids, hands and metadata of a recording."""
        names, sizes, recorded = recording_arguments(demo)
        return cls(names, sizes, templates, sides=demo.sides, **recorded, **options)

    def set_camera(self, camera: CameraInfo | None) -> None:
        """The camera's pose, once known (every lane's check runs use it)."""
        for lane in self.lanes.values():
            lane.set_camera(camera)

    @property
    def sides(self) -> tuple[str, ...]:
        return tuple(self.lanes)

    @property
    def object_names(self) -> list[str]:
        return next(iter(self.lanes.values())).object_names

    @property
    def warnings(self) -> list[str]:
        """The warnings of the newest run (the final one once the recording ended)."""
        run = self._final or self._last
        if run is None:
            return list(self._warnings)
        return [*run.warnings] + [
            f"{side}: {w}" if len(self.lanes) > 1 else w
            for side, seg in run.lanes.items()
            for w in seg.warnings
        ]

    # --- messages in ------------------------------------------------------------------------
    def push(self, message: HandMessage | ObjectMessage) -> HandsUpdate:
        """One hand frame (of the hand its ``side`` names) or object pose, as it arrives."""
        if self._finished:
            raise InvalidParameterError("the live segmentation has finished; start a new one")
        if isinstance(message, HandMessage):
            self._lane(message.side).take(message)
            t = int(message.t_ns)
            self._newest_hand = t if self._newest_hand is None else max(self._newest_hand, t)
        else:
            for lane in self.lanes.values():
                lane.take(message)
        if not self.ready or self._newest_hand is None:
            return HandsUpdate()
        if self._next_run is None:
            self._next_run = self._newest_hand + self.every_ns
            return HandsUpdate()
        if self._newest_hand < self._next_run:
            return self._provisional()
        self._next_run = self._newest_hand + self.every_ns
        return self._step()

    def push_hand(
        self,
        t_ns: int,
        keypoints: npt.ArrayLike,
        confidence: npt.ArrayLike | None = None,
        *,
        side: str | None = None,
    ) -> HandsUpdate:
        """A hand keypoint frame (21, 3), metres, of the ``side`` hand."""
        conf = None if confidence is None else np.asarray(confidence)
        return self.push(HandMessage(int(t_ns), np.asarray(keypoints), conf, side=side))

    def push_object(
        self, name: str, t_ns: int, position: npt.ArrayLike, quaternion: npt.ArrayLike
    ) -> HandsUpdate:
        """An object pose (centre, metres; quaternion xyzw)."""
        return self.push(
            ObjectMessage(int(t_ns), name, np.asarray(position), np.asarray(quaternion))
        )

    def push_recorded(
        self, kind: str, t_ns: int, value: Any, *, side: str | None = None
    ) -> HandsUpdate:
        """A decoded message of a recording as :func:`lfd.io.follow` yields it (see
        :meth:`LiveSegmentation.push_recorded`), a hand's with its ``side``."""
        if kind == "hand":
            return self.push_hand(t_ns, value, side=side)
        if kind == "confidence":
            self._lane(side).push_recorded(kind, t_ns, value)
            return HandsUpdate()
        if kind == "object":
            return self.push_object(value.name, t_ns, value.position, value.quaternion)
        return HandsUpdate()

    def _lane(self, side: str | None) -> LiveSegmentation:
        if side is None:
            if len(self.lanes) > 1:
                raise InvalidParameterError(
                    f"a hand frame names no side, and the {' and '.join(self.lanes)} hands "
                    "are segmented"
                )
            return next(iter(self.lanes.values()))
        lane = self.lanes.get(side)
        if lane is None:
            raise InvalidParameterError(
                f"a {side}-hand frame, and only the {' and '.join(self.lanes)} hand is segmented"
            )
        return lane

    @property
    def ready(self) -> bool:
        """Whether every hand and every object have been seen."""
        return all(lane.ready for lane in self.lanes.values())

    # --- runs and settling ------------------------------------------------------------------
    def _run(self, sides: Sequence[str], *, complete: bool = False) -> HandsSegmentation | None:
        """:func:`lfd.segment_hands` of the recording so far (of the ``sides`` hands), from
        the earliest window start of the lanes."""
        from . import segment_hands

        starts = [self.lanes[side].window_start() for side in sides]
        start = None if any(s is None for s in starts) else min(s for s in starts if s is not None)
        parts = [self.lanes[side].recording_so_far(start) for side in sides]
        first = parts[0]
        other = parts[1].hand if len(parts) > 1 else None
        try:
            demo = Demonstration(
                hand=first.hand, objects=first.objects, metadata=first.metadata, other_hand=other
            )
            return segment_hands(demo, method=self.method, complete=complete)
        except LfdError as err:
            self._warnings = [str(err)]
            for side in sides:
                self.lanes[side].failed(str(err))
            return None

    def _step(self) -> HandsUpdate:
        run = self._run(self.sides)
        if run is None:
            return HandsUpdate()
        self._last = run
        # the run of the recording so far as if it ended now, made once a lane needs it
        ended = functools.cache(lambda: self._run(self.sides, complete=True))
        lanes = {
            side: lane.settle(run.lanes[side], _shared(run, side), _lane_of(ended, side))
            for side, lane in self.lanes.items()
        }
        return HandsUpdate(lanes, self._settled_handovers(run.handovers, final=False))

    def _provisional(self) -> HandsUpdate:
        return HandsUpdate(
            {
                side: LiveUpdate(provisional=lane.provisional_span())
                for side, lane in self.lanes.items()
            }
        )

    def _settled_handovers(self, found: Iterable[Handover], *, final: bool) -> list[Handover]:
        """The handovers of a run not settled before that settle now: once the giver's lane
        has settled up to the handover's end and the taker's up to its start (at the end of
        the recording, every one)."""
        new = []
        for h in found:
            if any(self._same(h, old) for old in self._handovers):
                continue
            giver, taker = self.lanes.get(h.giver), self.lanes.get(h.taker)
            if giver is None or taker is None:
                continue
            g, t = giver.settled_until, taker.settled_until
            tol = self.tolerance_ns
            if final or (
                g is not None and t is not None and g >= h.end_ns - tol and t >= h.start_ns - tol
            ):
                new.append(h)
        self._handovers += new
        return new

    def _same(self, a: Handover, b: Handover) -> bool:
        return (a.giver, a.taker, a.object) == (b.giver, b.taker, b.object) and abs(
            a.end_ns - b.end_ns
        ) <= self.tolerance_ns

    def finish(self) -> HandsUpdate:
        """End of the recording: :func:`lfd.segment_hands` of the whole recording gives every
        skill and handover still open. A hand never seen gets no lane in that run."""
        if self._finished:
            return HandsUpdate()
        self._finished = True
        seen = [side for side, lane in self.lanes.items() if lane.seen_hand]
        lanes = {side: lane.finish() for side, lane in self.lanes.items() if side not in seen}
        if not seen:
            return HandsUpdate(lanes)
        run = self._run(seen, complete=True)
        if run is None:
            return HandsUpdate(lanes)
        self._final = run
        for side in seen:
            lanes[side] = self.lanes[side].settle_final(run.lanes[side])
        return HandsUpdate(lanes, self._settled_handovers(run.handovers, final=True))

    def provisional_spans(self) -> dict[str, Span]:
        """Each hand's open skill (see :meth:`LiveSegmentation.provisional_span`)."""
        spans = {side: lane.provisional_span() for side, lane in self.lanes.items()}
        return {side: span for side, span in spans.items() if span is not None}

    @property
    def settled_ns(self) -> dict[str, list[int]]:
        """Per hand, the message time at which each emitted segment settled."""
        return {side: list(lane.settled_ns) for side, lane in self.lanes.items()}

    def result(self) -> HandsSegmentation:
        """Everything emitted so far: a lane per hand and the settled handovers."""
        from .hands import HandsSegmentation

        run = self._final or self._last
        return HandsSegmentation(
            lanes={side: lane.result() for side, lane in self.lanes.items()},
            handovers=sorted(self._handovers, key=lambda h: h.start_ns),
            warnings=list(run.warnings) if run is not None else list(self._warnings),
            method=self.method,
        )


def _lane_of(
    ended: Callable[[], HandsSegmentation | None], side: str
) -> Callable[[], Segmentation | None]:
    """The ``side`` hand's lane of the run ``ended`` gives (None: that run failed)."""

    def lane() -> Segmentation | None:
        run = ended()
        return None if run is None else run.lanes.get(side)

    return lane


def _shared(run: HandsSegmentation, side: str) -> Callable[[Segment], bool]:
    """Whether a segment of the ``side`` hand's lane of ``run`` is on an object the other
    hand handles meanwhile (a step of the other lane on it, not a Move, overlapping it): a
    handover, a two-handed carry, what one hand holds for the other. Such a skill depends on
    what the other hand does next, so it settles as an uncertain one (``uncertain_s``)."""
    others = [
        (int(s.start_ns), int(s.end_ns), s.object)
        for other, seg in run.lanes.items()
        if other != side
        for s in seg.segments
        if s.skill != "move" and s.object is not None
    ]

    def shared(seg: Segment) -> bool:
        a, b = int(seg.start_ns), int(seg.end_ns)
        return seg.object is not None and any(
            o == seg.object and s < b and a < e for s, e, o in others
        )

    return shared


def segment_hands_live(
    demo: Demonstration,
    templates: Templates | TemplateChoice | None = None,
    *,
    messages: Iterable[HandMessage | ObjectMessage] | None = None,
    **options: Any,
) -> tuple[HandsSegmentation, dict[str, np.ndarray]]:
    """Replay a recording's messages (both hands') in time order through :class:`LiveHands`;
    returns the final segmentation and, per hand and segment, the time (ns) it settled at."""
    live = LiveHands.for_demonstration(demo, templates, **options)
    for msg in messages if messages is not None else demo_messages(demo):
        live.push(msg)
    live.finish()
    settled = {side: np.asarray(t, dtype=np.int64) for side, t in live.settled_ns.items()}
    return live.result(), settled
