"""Live segmentation: raw recording messages in, settled skills out, by the batch pipeline.

:class:`LiveSegmentation` is what ``lfd record --live-segment`` and ``lfd segment --follow``
run, and what ``benches/segment_live.py`` measures. Hand keypoint frames and object poses go in
as they arrive, in any interleaving; they are kept as the recording will hold them. Every
``every_s`` seconds of recording the batch segmentation (:func:`lfd.segment`, with the same
:class:`~lfd.segmentation.method.Method`: the same preprocessing, features, stage 1, search,
grammar and contact rules) runs on the recording so far. A skill settles, and is never revised
afterwards, once it ends ``lag_s`` before the newest hand frame and has come out the same
(skill, object, end within ``tolerance_s``) in every run for ``stable_s``, and the run of the
recording so far as batch preprocesses it (an unseen object rests where it was last seen unless
the camera saw that place empty) has it too: a hidden tag leaves what it could change undecided.
A Move settles once the skill after it is known. When the recording ends the batch segmentation
of the whole recording gives the skills still open, so the live result is the batch one wherever
the settled skills were right (docs/live.md). A recording longer than ``window_s`` is segmented
from its last settled skill that may begin a demonstration (Move, Pick up, Push, Locate).
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from ..demo import CameraInfo, Demonstration, HandTrack, ObjectTrack, SkillLabel
from ..errors import InvalidParameterError, LfdError
from ..io.reader import order_times
from ..skills import allowed, grammar
from .live_rules import Candidate, Settling
from .method import Method
from .result import Segment, Segmentation
from .templates import TemplateChoice, Templates

DEFAULT_EVERY_S = 0.2
"""Recording seconds between two runs of the batch segmentation (every frame of a 5 Hz hand)."""
DEFAULT_LAG_S = 0.25
"""A skill settles no sooner than this long after its end (the newest hand frame's time)..."""
DEFAULT_STABLE_S = 0.25
"""...and once it has come out the same in every run for this long (three runs in a row)."""
DEFAULT_TOLERANCE_S = 0.2
"""Two runs give "the same" skill when its end moved by at most this much."""
DEFAULT_MIN_CONFIDENCE = 0.5
"""A skill the grammar chose against a rival that explains its samples better (confidence below
this) is a guess about what comes next..."""
DEFAULT_UNCERTAIN_S = 3.0
"""...so it settles only once it has come out the same for this long."""
MAX_WAIT_S = 1e6  # the longest any of the times below may be (s): longer overflows as ns
DEFAULT_MAX_WAIT_S = 0.0
"""A skill settles once every object the hand reached has been seen after its end, or has been
out of sight this long (0: no such wait; the check run holds what a hidden tag could change)."""
DEFAULT_REAPPEAR_S = 0.5
"""An object seen again after it was out of sight for longer than this counts as seen from its
reappearance only once it has been seen again for this long (the first poses after a long gap
do not tell yet where batch will interpolate it)."""
DEFAULT_REACH_M = 0.15
"""An object the TCP came this close to (m) may have been moved while hidden."""
DEFAULT_WINDOW_S = 60.0
"""Beyond this much recording, a run starts at the last settled skill's start."""


@dataclass(frozen=True)
class HandMessage:
    """A hand keypoint frame: (21, 3) metres (NaN = unobserved), confidence (21,) in [0, 1]
    (default: 1 where observed), visible (21,) (default: observed with confidence > 0), and the
    hand's side (None: the only hand; :class:`~lfd.segmentation.live_hands.LiveHands` keeps a
    lane per side)."""

    t_ns: int
    keypoints: np.ndarray
    confidence: np.ndarray | None = None
    visible: np.ndarray | None = None
    side: str | None = None


@dataclass(frozen=True)
class ObjectMessage:
    """An object pose: centre (3,) metres, quaternion (4,) xyzw."""

    t_ns: int
    name: str
    position: np.ndarray
    quaternion: np.ndarray


@dataclass(frozen=True)
class Span:
    """A skill span on the recording's clock (what the live views draw)."""

    skill: str
    start_ns: int
    end_ns: int
    object: str | None = None


@dataclass(frozen=True)
class FeatureRow:
    """One sample's Table I feature row, as the segmentation computed it."""

    t_ns: int
    values: np.ndarray
    thresholds: np.ndarray
    target: int


@dataclass
class LiveUpdate:
    """What one message produced."""

    segments: list[Segment] = field(default_factory=list)
    """Newly settled segments, in time order (never revised)."""
    rows: list[FeatureRow] = field(default_factory=list)
    """Feature rows of the samples the newly settled segments cover (for live views)."""
    sections: list[int] = field(default_factory=list)
    """Stage-1 section starts (ns) inside the newly settled segments."""
    provisional: Span | None = None
    """The skill the newest run ends with, from its start to the newest message."""


def demo_messages(demo: Demonstration) -> Iterator[HandMessage | ObjectMessage]:
    """A demonstration's hand frames (each with its side) and object poses as messages in
    timestamp order (ties: the hands first, the right one first, then the objects in
    ``demo.objects`` order)."""
    hands = list(demo.hands.values())
    keys: list[tuple[int, int, int]] = []
    for h, hand in enumerate(hands):
        keys += [(int(t), h, i) for i, t in enumerate(hand.t_ns)]
    names = list(demo.objects)
    for j, name in enumerate(names):
        keys += [(int(t), len(hands) + j, i) for i, t in enumerate(demo.objects[name].t_ns)]
    keys.sort()
    for t, src, i in keys:
        if src < len(hands):
            hand = hands[src]
            yield HandMessage(
                t, hand.keypoints[i], hand.confidence[i], hand.visible[i], side=hand.side
            )
        else:
            name = names[src - len(hands)]
            ob = demo.objects[name]
            yield ObjectMessage(t, name, ob.position[i], ob.quaternion[i])


class _Tracks:
    """The messages so far, kept as :func:`lfd.load` reads them back from the recording: in
    time order, the first of equal timestamps."""

    def __init__(self, objects: Sequence[tuple[str, int, np.ndarray]], side: str) -> None:
        self.objects = list(objects)
        self.side = side
        self.hand: list[tuple[int, np.ndarray, np.ndarray, np.ndarray]] = []
        self.poses: dict[str, list[tuple[int, np.ndarray, np.ndarray]]] = {
            name: [] for name, _, _ in objects
        }

    def add(self, msg: HandMessage | ObjectMessage) -> None:
        if isinstance(msg, HandMessage):
            if msg.side is not None and msg.side != self.side:
                raise InvalidParameterError(
                    f"a {msg.side}-hand frame for the live segmentation of the {self.side} hand "
                    "(two hands: lfd.segmentation.live_hands.LiveHands)"
                )
            kp = _shaped(msg.keypoints, (21, 3), "hand keypoints")
            finite = np.asarray(np.isfinite(kp).all(axis=1))
            conf = _shaped(
                finite.astype(np.float64) if msg.confidence is None else msg.confidence,
                (21,),
                "hand confidence",
            )
            vis = np.asarray(
                finite & (conf > 0) if msg.visible is None else msg.visible, dtype=bool
            ).reshape(21)
            self.hand.append((int(msg.t_ns), kp, conf, vis))
        elif msg.name in self.poses:
            p = _shaped(msg.position, (3,), f"{msg.name} position")
            q = _shaped(msg.quaternion, (4,), f"{msg.name} quaternion")
            self.poses[msg.name].append((int(msg.t_ns), p, q))

    def ready(self) -> bool:
        return bool(self.hand) and all(self.poses.values())

    def demonstration(
        self, start_ns: int | None, metadata: dict[str, Any], camera: CameraInfo | None = None
    ) -> Demonstration:
        """The recording so far (from ``start_ns``, when given) as a demonstration."""
        lo = -(2**63) if start_ns is None else start_ns
        if start_ns is not None:  # from the hand frame the window's first skill starts at
            lo = max([h[0] for h in self.hand if h[0] <= lo], default=lo)
        t, keep = _ordered([h[0] for h in self.hand], lo)
        hand = HandTrack(
            t_ns=t,
            keypoints=np.array([self.hand[i][1] for i in keep]).reshape(-1, 21, 3),
            confidence=np.array([self.hand[i][2] for i in keep]).reshape(-1, 21),
            side=self.side,
            visible=np.array([self.hand[i][3] for i in keep], dtype=bool).reshape(-1, 21),
        )
        objects = {}
        for name, tag_id, size in self.objects:
            poses = self.poses[name]
            to, ko = _ordered([p[0] for p in poses], lo, held=start_ns is not None)
            objects[name] = ObjectTrack(
                name=name,
                tag_id=tag_id,
                size=size,
                t_ns=to,
                position=np.array([poses[i][1] for i in ko]).reshape(-1, 3),
                quaternion=np.array([poses[i][2] for i in ko]).reshape(-1, 4),
                visible=np.ones(len(to), dtype=bool),
            )
        return Demonstration(hand=hand, objects=objects, metadata=dict(metadata), camera=camera)


def _shaped(value: Any, shape: tuple[int, ...], what: str) -> np.ndarray:
    """``value`` as a float array of ``shape``, or one clear error."""
    try:
        out = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise InvalidParameterError(f"{what} must be numbers, got {value!r:.60}") from None
    if out.size != int(np.prod(shape)):
        raise InvalidParameterError(f"{what} must have shape {shape}, got {out.shape}")
    return out.reshape(shape)


def _ordered(times: list[int], lo: int, held: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Times from ``lo`` on as :func:`lfd.load` reads them (sorted, the first of equal ones),
    and their indices; ``held``: with the last one before ``lo``, at ``lo`` (an object's pose
    where a run's window starts: a skill that may start a demonstration begins there, nothing
    is carried, and an object hidden from before it is still where it was last seen)."""
    t = np.asarray(times, dtype=np.int64)
    idx, _, _ = order_times(t)
    early = idx[t[idx] < lo]
    idx = idx[t[idx] >= lo]
    out = t[idx]
    if held and early.size and (not idx.size or out[0] > lo):
        idx = np.concatenate([early[-1:], idx])
        out = np.concatenate([np.asarray([lo], dtype=np.int64), out])
    return out, idx


class LiveSegmentation:
    """Segment a demonstration from its raw messages while it is recorded.

    Parameters
    ----------
    object_names, object_sizes :
        The objects and their box sizes (k, 3), metres.
    templates : Templates or {"default", "paper"}, optional
        As :func:`lfd.segment` (or give ``method``).
    method : Method or str, optional
        The segmentation method (default: :meth:`Method.default`).
    side : {"right", "left"}
        The demonstrating hand.
    params : SegmentParams, optional
        Overrides the method's parameters.
    tag_ids : sequence of int, optional
        The objects' tag ids (as the recording declares them).
    metadata : dict, optional
        The recording's metadata (what :func:`lfd.load` would give the demonstration).
    every_s, lag_s, stable_s, tolerance_s, window_s, min_confidence, uncertain_s, max_wait_s,
    reappear_s, reach_m : float
        How often the segmentation runs and when a skill settles (the module constants,
        docs/live.md).
    followers : int
        Segments that must follow one in a run before it settles (a Move: one more).
    """

    def __init__(
        self,
        object_names: Sequence[str],
        object_sizes: npt.ArrayLike,
        templates: Templates | TemplateChoice | None = None,
        *,
        method: Method | str | None = None,
        side: str = "right",
        params: Any = None,
        tag_ids: Sequence[int] | None = None,
        metadata: dict[str, Any] | None = None,
        camera: CameraInfo | None = None,
        every_s: float = DEFAULT_EVERY_S,
        lag_s: float = DEFAULT_LAG_S,
        stable_s: float = DEFAULT_STABLE_S,
        tolerance_s: float = DEFAULT_TOLERANCE_S,
        window_s: float = DEFAULT_WINDOW_S,
        min_confidence: float = DEFAULT_MIN_CONFIDENCE,
        uncertain_s: float = DEFAULT_UNCERTAIN_S,
        followers: int = 1,
        max_wait_s: float = DEFAULT_MAX_WAIT_S,
        reappear_s: float = DEFAULT_REAPPEAR_S,
        reach_m: float = DEFAULT_REACH_M,
    ) -> None:
        from . import resolve_method

        for name, value in (
            ("every_s", every_s),
            ("lag_s", lag_s),
            ("stable_s", stable_s),
            ("tolerance_s", tolerance_s),
            ("window_s", window_s),
            ("uncertain_s", uncertain_s),
            ("max_wait_s", max_wait_s),
            ("reappear_s", reappear_s),
        ):
            if not (0 <= value <= MAX_WAIT_S) or (name == "every_s" and value <= 0):
                low = "> 0" if name == "every_s" else ">= 0"
                raise InvalidParameterError(f"{name} must be {low} and <= 1e6 s, got {value}")
        self.method = resolve_method(templates, method).with_options(params=params)
        names = list(object_names)
        sizes = np.asarray(object_sizes, dtype=np.float64).reshape(len(names), 3)
        ids = list(tag_ids) if tag_ids is not None else list(range(len(names)))
        self._tracks = _Tracks(list(zip(names, ids, sizes, strict=True)), side)
        self.metadata = dict(metadata or {})
        self.camera = camera  # its pose tells where a hidden object's place was seen empty
        self.every_ns = round(every_s * 1e9)
        self.lag_ns = round(lag_s * 1e9)
        self.stable_ns = round(stable_s * 1e9)
        self.tolerance_ns = round(tolerance_s * 1e9)
        self.window_ns = round(window_s * 1e9)
        self.min_confidence = float(min_confidence)
        self.uncertain_ns = round(uncertain_s * 1e9)
        if int(followers) < 1:
            raise InvalidParameterError(f"followers must be at least 1, got {followers}")
        self.followers = int(followers)
        self.max_wait_ns = round(max_wait_s * 1e9)
        self.reappear_ns = round(reappear_s * 1e9)
        self.reach_m = float(reach_m)
        self.settled_ns: list[int] = []
        """Message time at which each emitted segment settled (same order as the segments)."""
        self._emitted: list[Segment] = []
        self._candidates: list[Candidate] = []
        self._now: int | None = None
        self._newest_hand: int | None = None
        self._next_run: int | None = None
        self._last: Segmentation | None = None
        self._final: Segmentation | None = None
        self._warnings: list[str] = []
        self._origin_ns: int | None = None
        self._start_skills = frozenset(grammar()["start"])
        self._finished = False

    @classmethod
    def for_demonstration(
        cls,
        demo: Demonstration,
        templates: Templates | TemplateChoice | None = None,
        **options: Any,
    ) -> LiveSegmentation:
        """For the objects, sizes, tag ids, hand side and metadata of a recording."""
        names, sizes, recorded = recording_arguments(demo)
        return cls(names, sizes, templates, side=demo.hand.side, **recorded, **options)

    def set_camera(self, camera: CameraInfo | None) -> None:
        """The camera's pose, once known (:attr:`camera`)."""
        self.camera = camera

    @property
    def object_names(self) -> list[str]:
        return [o[0] for o in self._tracks.objects]

    @property
    def warnings(self) -> list[str]:
        """The warnings of the newest run (the final one once the recording ended)."""
        run = self._final or self._last
        return list(run.warnings) if run is not None else list(self._warnings)

    # --- messages in ------------------------------------------------------------------------
    def push(self, message: HandMessage | ObjectMessage) -> LiveUpdate:
        """One hand frame or object pose, as it arrives."""
        self.take(message)
        if not self._tracks.ready() or self._newest_hand is None:
            return LiveUpdate()
        if not self.due(self._newest_hand):
            return LiveUpdate(provisional=self.provisional_span())
        return self._step()

    def take(self, message: HandMessage | ObjectMessage) -> None:
        """Keep a message (no run): what :meth:`push` and a lane of
        :class:`~lfd.segmentation.live_hands.LiveHands` do with each."""
        if self._finished:
            raise InvalidParameterError("the live segmentation has finished; start a new one")
        t = int(message.t_ns)
        self._now = t if self._now is None else max(self._now, t)
        self._tracks.add(message)
        if isinstance(message, HandMessage):
            self._newest_hand = t if self._newest_hand is None else max(self._newest_hand, t)

    def due(self, newest_hand_ns: int) -> bool:
        """Whether a run is due at the newest hand frame ``newest_hand_ns`` (every
        ``every_s``; the first run one period after the recording is ready)."""
        if self._next_run is None:
            self._next_run = newest_hand_ns + self.every_ns
            return False
        if newest_hand_ns < self._next_run:
            return False
        self._next_run = newest_hand_ns + self.every_ns
        return True

    @property
    def ready(self) -> bool:
        """Whether the hand and every object have been seen (the runs start then: an object
        not seen yet leaves every skill undecided)."""
        return self._tracks.ready()

    @property
    def seen_hand(self) -> bool:
        """Whether a frame of the hand has come (at the end the batch segmentation runs then,
        as batch ignores an object never seen)."""
        return bool(self._tracks.hand)

    def push_hand(
        self,
        t_ns: int,
        keypoints: npt.ArrayLike,
        confidence: npt.ArrayLike | None = None,
        *,
        side: str | None = None,
    ) -> LiveUpdate:
        """A hand keypoint frame (21, 3), metres, with per-keypoint confidence (of the
        ``side`` hand: this segmenter's, or None)."""
        conf = None if confidence is None else np.asarray(confidence)
        return self.push(HandMessage(int(t_ns), np.asarray(keypoints), conf, side=side))

    def push_object(
        self, name: str, t_ns: int, position: npt.ArrayLike, quaternion: npt.ArrayLike
    ) -> LiveUpdate:
        """An object pose (centre, metres; quaternion xyzw)."""
        return self.push(
            ObjectMessage(int(t_ns), name, np.asarray(position), np.asarray(quaternion))
        )

    def push_recorded(self, kind: str, t_ns: int, value: Any) -> LiveUpdate:
        """A decoded message of a recording as :func:`lfd.io.follow` yields it (``kind``
        ``hand``: keypoints (21, 3); ``confidence``: ``(confidence, visible)`` of the hand frame
        just before it; ``object``: an object pose; any other kind is ignored)."""
        if kind == "hand":
            return self.push_hand(t_ns, value)
        if kind == "confidence":
            self._confidence(int(t_ns), value)
            return LiveUpdate()
        if kind == "object":
            return self.push_object(value.name, t_ns, value.position, value.quaternion)
        return LiveUpdate()

    def _confidence(self, t_ns: int, value: Any) -> None:
        """Set the confidence (and visibility) of the newest hand frame at ``t_ns`` (the first
        message per frame counts, as :func:`lfd.load` reads it)."""
        hand = self._tracks.hand
        for i in range(len(hand) - 1, max(len(hand) - 4, -1), -1):
            t, kp, _, _ = hand[i]
            if t == t_ns:
                conf = np.asarray(value[0], dtype=np.float64).reshape(21)
                seen = value[1] if len(value) > 1 else None
                finite = np.isfinite(kp).all(axis=1)
                vis = finite & (conf > 0) if seen is None else np.asarray(seen, dtype=bool)
                hand[i] = (t, kp, conf, vis.reshape(21))
                return

    # --- runs and settling ------------------------------------------------------------------
    def _run(self, *, complete: bool = False) -> Segmentation | None:
        """The batch segmentation of the recording so far (on a window once it is long);
        ``complete`` once the recording has ended."""
        from . import segment

        demo = self.recording_so_far(self.window_start())
        try:
            return segment(demo, method=self.method, complete=complete)
        except LfdError as err:
            self._warnings = [str(err)]
            return None

    def _run_at_rest(self) -> Segmentation | None:
        """The recording so far preprocessed as batch does it (a hidden object rests unless the
        camera saw its place empty), segmented as a recording still being made. The open run
        (:meth:`_run`) has an object hidden since the hand reached it follow the hand."""
        from . import segment
        from .pipeline import as_trajectory

        demo = self.recording_so_far(self.window_start())
        try:
            traj = as_trajectory(demo, self.method.preprocessing)
            return segment(traj, method=self.method, complete=False)
        except LfdError as err:
            self._warnings = [str(err)]
            return None

    def window_start(self) -> int | None:
        """Where a run starts (None: at the recording's start): once the recording is longer
        than ``window_s``, at the last settled skill a demonstration may start with (the
        grammar's start)."""
        if self._emitted and self._newest_hand is not None:
            first = int(self._emitted[0].start_ns)
            if self._newest_hand - first > self.window_ns:
                begins = [s for s in self._emitted if s.skill in self._start_skills]
                return int(begins[-1].start_ns) if begins else None
        return None

    def recording_so_far(self, start_ns: int | None = None) -> Demonstration:
        """The messages so far (from ``start_ns``) as a one-hand demonstration."""
        return self._tracks.demonstration(start_ns, self.metadata, self.camera)

    def _aligned(self, run: Segmentation) -> list[Segment]:
        """The run's segments after the settled ones: after the run's counterpart of the last
        settled segment (the same skill, ending within ``tolerance_s`` of it), else those
        ending after the settled end, less one of the same skill that straddles it (the settled
        skill, whose end the run moved). The grammar lets no skill follow itself, and a Move's
        object is named from where it ends, so the skill alone identifies the counterpart."""
        if not self._emitted:
            return list(run.segments)
        last = self._emitted[-1]
        front = int(last.end_ns)
        same = [
            (abs(int(s.end_ns) - front), i)
            for i, s in enumerate(run.segments)
            if s.skill == last.skill and abs(int(s.end_ns) - front) <= self.tolerance_ns
        ]
        if same:
            return list(run.segments[min(same)[1] + 1 :])
        rest = [s for s in run.segments if int(s.end_ns) > front]
        if rest and int(rest[0].start_ns) < front and rest[0].skill == last.skill:
            rest = rest[1:]
        if rest and not allowed(last.skill, rest[0].skill):
            # the settled skill ends later than the run's, past a short Move: keep the Move
            k = next(i for i, s in enumerate(run.segments) if s is rest[0])
            if k > 0 and run.segments[k - 1].skill == "move" and allowed(last.skill, "move"):
                rest.insert(0, run.segments[k - 1])
        return rest

    def _step(self) -> LiveUpdate:
        run = self._run()
        if run is None:
            return LiveUpdate()
        return self.settle(run, ended=functools.cache(self._run_at_rest))

    def failed(self, message: str) -> None:
        """A run of the recording so far failed (its one line becomes the warnings)."""
        self._warnings = [message]

    def settle(
        self,
        run: Segmentation,
        shared: Callable[[Segment], bool] | None = None,
        ended: Callable[[], Segmentation | None] | None = None,
    ) -> LiveUpdate:
        """Settle what ``run`` (the segmentation of the recording so far: :meth:`_run`, or this
        hand's lane of both hands') has kept the same long enough; a segment ``shared`` says
        depends on the other hand (its object in the other hand's skill then) waits as an
        uncertain one. ``ended`` gives the batch segmentation of the recording so far as if it
        ended now (``complete``; called only when a segment is otherwise ready): a segment
        settles only if that run has it too (:meth:`_agrees`)."""
        self._last = run
        rest = self._aligned(run)
        now = int(self._now or 0)
        cands: list[Candidate] = []
        for i, seg in enumerate(rest):
            since = now
            # a run's last segment ends where the recording so far ends: its end counts from
            # the first run in which another segment followed it
            if i < len(self._candidates) - 1:
                old = self._candidates[i].segment
                if (old.skill, old.object) == (seg.skill, seg.object) and abs(
                    int(old.end_ns) - int(seg.end_ns)
                ) <= self.tolerance_ns:
                    since = self._candidates[i].since_ns
            cands.append(Candidate(seg, since))
        newest = int(self._newest_hand or now)
        limit = min(newest - self.lag_ns, self._seen_until())

        rules = Settling(run, cands, self._emitted, self._tracks.poses, now, limit, shared, self)
        settled: list[Segment] = []
        # the last segment of a run is open: it settles only when the recording ends
        while len(cands) > self.followers and rules.ready(cands[0]) and rules.next_known(0):
            # a Move: and the skill after it, if that one ended in the run
            step = 2 if cands[0].segment.skill == "move" and len(cands) > 1 + self.followers else 1
            if ended is not None and not self._agrees([c.segment for c in cands[:step]], ended()):
                break
            settled.append(self._joined(cands.pop(0).segment, _dt(run)))
            self._emitted.append(settled[-1])
            self.settled_ns.append(now)
        self._candidates = cands
        return self._update(run, settled)

    def _agrees(self, segs: list[Segment], ended: Segmentation | None) -> bool:
        """Whether the check run (``ended``, :meth:`_run_at_rest`) has ``segs`` next after the
        settled segments: the same skills and objects, each ending within ``tolerance_s``. It
        differs from the open run only in what is not known yet (whether a hidden object moved);
        where they disagree on a segment, the evidence is not in."""
        if ended is None:
            return False
        rest = self._aligned(ended)
        return len(rest) >= len(segs) and all(
            (a.skill, a.object) == (b.skill, b.object)
            and abs(int(a.end_ns) - int(b.end_ns)) <= self.tolerance_ns
            for a, b in zip(rest, segs, strict=False)
        )

    def _seen_until(self) -> int:
        """The time up to which every object the hand may have moved unseen has been seen: an
        object out of sight since the hand came within ``reach_m`` of it (from 0.5 s before it
        was last seen), for at most ``max_wait_s``; an object seen again less than
        ``reappear_s`` ago after a gap longer than that, up to where the gap began."""
        newest = int(self._newest_hand or self._now or 0)
        run = self._last.run if self._last is not None else None
        until = newest
        for poses in self._tracks.poses.values():
            if not poses:
                continue
            t_last, p_last, _ = poses[-1]
            i = len(poses) - 1 if self.reappear_ns > 0 else 0
            while i > 0 and poses[i][0] > newest - self.reappear_ns:
                if poses[i][0] - poses[i - 1][0] > self.reappear_ns:
                    until = min(until, int(poses[i - 1][0]))
                i -= 1
            if newest - t_last > self.max_wait_ns or t_last >= newest:
                continue
            if run is not None:
                t = np.asarray(run.trajectory.t_ns, dtype=np.int64)
                near = (t >= t_last - 500_000_000) & np.isfinite(run.trajectory.tcp).all(axis=1)
                d = np.linalg.norm(run.trajectory.tcp[near] - p_last, axis=1)
                if not (d <= self.reach_m).any():
                    continue  # hidden where the hand never came: it rests
            until = min(until, t_last)
        return until

    def _joined(self, seg: Segment, dt: float) -> Segment:
        """``seg`` starting where the last settled segment ends (runs move boundaries a little),
        its sample indices and seconds on the whole recording's clock (a run on a window counts
        from the window's start)."""
        if self._origin_ns is None:
            self._origin_ns = int(seg.start_ns)
        start_ns = int(self._emitted[-1].end_ns) if self._emitted else int(seg.start_ns)
        o = self._origin_ns

        def index(t: int) -> int:
            return round((t - o) * 1e-9 / dt) if dt > 0 else 0

        start, end = index(start_ns), max(index(int(seg.end_ns)), index(start_ns) + 1)
        end_ns = int(seg.end_ns)
        if end_ns <= start_ns:  # a short Move the settled skill overlapped: one sample long
            end_ns = start_ns + max(round(dt * 1e9), 1)
        return dataclasses.replace(
            seg,
            start=start,
            end=end,
            start_s=(start_ns - o) * 1e-9,
            end_s=(end_ns - o) * 1e-9,
            start_ns=start_ns,
            end_ns=end_ns,
        )

    def _update(self, run: Segmentation, settled: list[Segment]) -> LiveUpdate:
        out = LiveUpdate(segments=settled, provisional=self.provisional_span())
        if not settled or run.run is None:
            return out
        feats = run.run.features
        t = np.asarray(feats.t_ns, dtype=np.int64)
        lo, hi = int(settled[0].start_ns), int(settled[-1].end_ns)
        sel = np.flatnonzero((t >= lo) & (t < hi))
        out.rows = [
            FeatureRow(int(t[i]), feats.values[i], feats.thresholds[i], int(feats.target[i]))
            for i in sel
        ]
        bounds = [int(t[min(b, len(t) - 1)]) for b in run.sections[:-1]]
        out.sections = [b for b in bounds if lo <= b < hi]
        return out

    def finish(self) -> LiveUpdate:
        """End of the recording: the batch segmentation of the whole recording gives every
        skill still open (after the settled ones)."""
        if self._finished:
            return LiveUpdate()
        self._finished = True
        if not self.seen_hand:
            return LiveUpdate()
        run = self._run(complete=True)
        if run is None:
            return LiveUpdate()
        return self.settle_final(run)

    def settle_final(self, run: Segmentation) -> LiveUpdate:
        """The recording has ended: ``run`` (the batch segmentation of all of it) gives every
        skill still open."""
        self._finished = True
        self._final = run
        rest = self._aligned(run)
        dt = _dt(run)
        tail = []
        for seg in rest:
            tail.append(self._joined(seg, dt))
            self._emitted.append(tail[-1])
        self.settled_ns += [int(self._now or 0)] * len(tail)
        self._candidates = []
        out = self._update(run, tail)
        out.provisional = None
        return out

    @property
    def settled_until(self) -> int | None:
        """The end (ns) of the last settled skill (None: none yet)."""
        return int(self._emitted[-1].end_ns) if self._emitted else None

    def provisional_span(self) -> Span | None:
        """The skill the newest run ends with, from its start to the newest message."""
        if self._finished or not self._candidates or self._now is None:
            return None
        seg = self._candidates[-1].segment
        return Span(seg.skill, int(seg.start_ns), max(int(seg.start_ns), self._now), seg.object)

    def result(self) -> Segmentation:
        """Everything emitted so far, as a :class:`Segmentation` (with the newest run's)."""
        run = self._final or self._last
        return Segmentation(
            segments=list(self._emitted),
            warnings=self.warnings,
            method=self.method.search,
            sections=list(run.sections) if run is not None else [],
            object_names=self.object_names,
            run=run.run if run is not None else None,
        )


def _dt(run: Segmentation) -> float:
    return float(run.run.trajectory.dt) if run.run is not None else 0.0


def recording_arguments(
    demo: Demonstration,
) -> tuple[list[str], list[np.ndarray], dict[str, Any]]:
    """What a live segmenter takes of a recording: its objects' names and sizes, and as keyword
    arguments their tag ids and the metadata (without the load report)."""
    objects = list(demo.objects.values())
    return (
        [o.name for o in objects],
        [o.size for o in objects],
        {
            "tag_ids": [o.tag_id for o in objects],
            "metadata": {k: v for k, v in demo.metadata.items() if k != "load_report"},
            "camera": demo.camera,
        },
    )


def label_of(seg: Segment, hand: str | None = None) -> SkillLabel:
    """A settled segment as a skill label (for ``/lfd/live/segments``), in the lane of
    ``hand`` (None: the only hand)."""
    return SkillLabel(seg.skill, int(seg.start_ns), int(seg.end_ns), seg.object, hand=hand)


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
