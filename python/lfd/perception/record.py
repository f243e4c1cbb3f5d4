"""``lfd record``: perceive RGB-D frames from a source and write a demonstration MCAP live.

Per frame, object poses come from the tags (:class:`~lfd.perception.markers.MarkerTracker`,
at frame rate); every ``1 / hand_rate_hz`` seconds the hand estimator gives the 21 keypoints with
a confidence and a visibility each: MediaPipe Hands on the colour image lifted with the depth
image, or placed from colour alone when the source has no depth (a webcam, a video file)
(:class:`~lfd.perception.hand.rgbd.MediaPipeEstimator`, for real cameras, every frame by
default) or the depth network (:class:`~lfd.perception.hand.infer.HandEstimator`, trained on the
simulator's hand, 5 Hz like the paper). A hand placed from colour alone is held until its
skeleton is measured (the first second of confident hands, ``MediaPipeEstimator.feed``) and
those samples are written then, in order, so that every hand has the same bones; a recording
stopped sooner writes what is held when it ends. Samples go to a
:class:`~lfd.io.McapRecorder` as they are produced, so an interrupted recording (Ctrl+C,
SIGTERM) is a complete, loadable file up to the last frame.

Frames: the world is the reference tag's (origin at its centre, z up), from the first frame it
is seen (or the camera pose of ``camera.json``). The hand topic (``/hand/<side>/keypoints``)
holds world-frame samples only: until the reference is seen, and for a whole recording in which
it is never seen, a hand found is written in the camera frame (OpenCV axes: x right, y down, z
forward, metres) to a topic of its own, ``/hand/<side>/keypoints_camera`` (and
``/hand/<side>/confidence_camera``), and the hand topic has the sample unobserved; the objects
are unobserved too (an object's pose needs the reference). The camera calibration
(``/camera/color/camera_info``, ``/tf``) is written when the reference is found, so a recording
without it has none. The metadata says whether depth was used (``depth``) and how the hand was
placed in metres (``hand_lifting``).

What is done beside the file (``lfd record --rerun``, ``--live-segment``) is an ``observer``
(a :class:`RecordObserver`, e.g. :class:`lfd.live.LiveObserver`): it sees every frame, object
pose and hand sample as it is written, and the skills it returns are written to
``/lfd/live/segments``. This stage imports neither the segmentation nor the viewer.
"""

from __future__ import annotations

import os
from collections import deque
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any, Protocol

import numpy as np

from ..demo import CameraInfo, SkillLabel
from ..errors import LfdError
from .camera_file import check_hand_rate
from .markers import MarkerConfig, MarkerTracker
from .sources import Frame, Source, check_frame, describe


@dataclass
class RecordStats:
    """What a recording run produced."""

    frames: int = 0
    object_poses: int = 0
    hand_estimates: int = 0
    hand_missing: int = 0
    interrupted: bool = False
    live_segments: int = 0
    hand_in_camera: int = 0
    """Hand samples written in the camera frame (``/hand/<side>/keypoints_camera``), before the
    reference tag was seen; the world topic has them unobserved (not counted in
    ``hand_estimates`` nor ``hand_missing``)."""
    sides: tuple[str, ...] = ("right",)
    """The hands recorded; the counts above are over all of them."""


def _boxes(tracker: MarkerTracker, poses: dict[str, tuple[np.ndarray, np.ndarray]]) -> list[Any]:
    from scipy.spatial.transform import Rotation

    sizes = {b.name: np.asarray(b.size) for b in tracker.config.boxes}
    return [(p, Rotation.from_quat(q).as_matrix(), sizes[n]) for n, (p, q) in poses.items()]


Poses = Mapping[str, tuple[np.ndarray, np.ndarray]]
"""Object poses of one frame: name -> (position (3,) m, quaternion (4,) x, y, z, w)."""

SettledSkill = tuple[SkillLabel, int, dict[str, str]]
"""A skill an observer settled: the label, the time it settled (the message's log time, ns) and
extra metadata; :func:`record` writes it to ``/lfd/live/segments``
(:meth:`lfd.io.McapRecorder.add_live_segment`)."""


class RecordObserver(Protocol):
    """What :func:`record` tells as it writes, in the order it writes it. Each method returns the
    skills settled by what it was told (written to ``/lfd/live/segments`` at once)."""

    def on_frame(self, t_ns: int, color: np.ndarray, poses: Poses) -> Iterable[SettledSkill]:
        """A camera frame and the object poses written for it (tags seen, or at the first
        frame the calibration's)."""
        ...

    def on_hand(
        self,
        t_ns: int,
        keypoints: np.ndarray | None,
        confidence: np.ndarray | None,
        keypoints_2d: np.ndarray | None,
        side: str | None = None,
    ) -> Iterable[SettledSkill]:
        """A hand sample: world keypoints (21, 3) m, confidence (21,) and, from a colour model,
        the 2-D keypoints (21, 2) px; ``keypoints`` None: no hand found (written unobserved,
        NaN with confidence 0). Of a two-hand recording every hand's, ``side`` naming it (of
        one hand, not given)."""
        ...

    def on_camera(self, camera: CameraInfo) -> Iterable[SettledSkill]:
        """The camera's calibration, once its pose in the world is known (written then)."""
        ...

    def finish(self, t_ns: int) -> Iterable[SettledSkill]:
        """The recording ends at ``t_ns`` (its last frame): what is still open settles."""
        ...


class RecordingFailed(LfdError):
    """A part of the recording (the source, the tag tracker, the hand model, the observer)
    failed: the ``frames`` recorded before it are closed, complete, in ``path`` (with none, no
    file is written). The failure itself is the ``__cause__``."""

    def __init__(self, message: str, *, part: str, frames: int, path: str) -> None:
        super().__init__(message)
        self.part, self.frames, self.path = part, frames, path


_END = object()
"""What ``next`` gives at the end of a source's frames."""

TAG_TRACKER = "the tag tracker"
HAND_MODEL = "the hand model"
OBSERVER = "the live segmentation or view"
WRITER = "lfd record"
"""The parts of a recording a failure is attributed to; the source is named by its own
``metadata["source"]`` (``camera:0``)."""


def record(
    source: Source,
    output: str | os.PathLike[str],
    *,
    hand_rate_hz: float | None = 5.0,
    estimator: Any = None,
    save_images: bool = False,
    max_frames: int | None = None,
    progress: Any = None,
    markers: dict[str, Any] | None = None,
    side: str = "right",
    observer: RecordObserver | None = None,
    sides: Sequence[str] | None = None,
) -> RecordStats:
    """Record ``source`` into ``output`` (MCAP). ``estimator`` is a ``MediaPipeEstimator``, a
    ``HandEstimator`` or None; ``side`` names the hand topics (``/hand/<side>/...``).

    Two hands: ``sides=("right", "left")`` records both, and ``estimator`` is then a mapping
    side -> one-hand estimator (:meth:`MediaPipeEstimator.for_side
    <lfd.perception.hand.rgbd.MediaPipeEstimator.for_side>`,
    :meth:`DepthHands.side <lfd.perception.hand.sides.DepthHands.side>`), or None. Each hand
    gets its own topics, sampled at the same times; the ``observer`` sees the first hand's
    samples (the right).

    ``hand_rate_hz`` None estimates the hand on every frame; else it is a rate in
    :data:`~lfd.perception.camera_file.HAND_RATE_RANGE_HZ`.

    ``observer`` (a :class:`RecordObserver`, e.g. :class:`lfd.live.LiveObserver`: Rerun, live
    segmentation) sees every frame, pose and hand sample as it is written; the skills it settles
    are written to ``/lfd/live/segments`` during the recording, the rest when it ends
    (``stats.live_segments`` counts them).

    ``markers`` are extra :class:`~lfd.perception.markers.MarkerConfig` fields, e.g.
    ``{"dictionary": "DICT_5X5_100", "reference_size": 0.15}``.

    ``progress(stats)`` is called after every frame. KeyboardInterrupt stops the recording
    cleanly (the file is closed, complete and renamed to ``output``); ``stats.interrupted``
    tells it happened. Nothing recorded is lost: when any part fails (the source or its depth
    reader, a malformed frame, the tag tracker, the hand model, the observer), whatever it
    raises, the frames recorded before it are closed, complete, in ``output`` and
    :class:`RecordingFailed` says which part failed, why and how many frames were kept. A
    failure before the first frame leaves no file.
    """
    from ..io import McapRecorder

    try:
        hands = _sides(side, sides)
        estimators = _per_side(estimator, hands)
        if hand_rate_hz is not None:
            check_hand_rate(hand_rate_hz)
        tracker, calib_poses = _tracker(source, markers)
        first = None if not estimators else estimators[hands[0]]
        meta = _metadata(source, first, hand_rate_hz, hands[0])
        objects = [(o["name"], o["tag_id"], np.asarray(o["size"], float)) for o in source.objects]
        two: dict[str, Any] = {"hands": hands} if len(hands) > 1 else {}  # one hand: as always
        if len(hands) > 1:
            meta["hands"] = list(hands)
        rec = McapRecorder(
            output, objects=objects, metadata=meta, color_format="png", side=hands[0], **two
        )
    except BaseException:
        _close(source)
        raise
    session = _Session(source, rec, tracker, estimators, observer, calib_poses, hands)
    session.period = 0 if hand_rate_hz is None else round(1e9 / hand_rate_hz)  # 0: every frame
    session.save_images = save_images
    try:
        session.run(max_frames, progress, os.fspath(output))
    finally:
        _close(source)
    return session.stats


def _sides(side: str, sides: Sequence[str] | None) -> tuple[str, ...]:
    """The hands to record, the right first."""
    from ..demo import HAND_SIDES, check_side

    given = (side,) if sides is None else tuple(sides)
    for s in given:
        check_side(s, "hand")
    if not given or len(set(given)) != len(given):
        raise LfdError(f"record one hand or two different ones, not {given}")
    return tuple(s for s in HAND_SIDES if s in given)


def _per_side(estimator: Any, hands: tuple[str, ...]) -> dict[str, Any]:
    """The one-hand estimator of each hand ({}: no hand estimated)."""
    if estimator is None:
        return {}
    if isinstance(estimator, Mapping):
        missing = [s for s in hands if s not in estimator]
        if missing:
            raise LfdError(f"no hand estimator for the {' and '.join(missing)} hand")
        return {s: estimator[s] for s in hands}
    if len(hands) > 1:
        raise LfdError("two hands need one estimator per hand (a mapping side -> estimator)")
    return {hands[0]: estimator}


def _tracker(
    source: Source, markers: dict[str, Any] | None
) -> tuple[MarkerTracker, dict[str, tuple[np.ndarray, np.ndarray]]]:
    """The tag tracker, and the object poses of the source's empty-workspace frame if any."""
    config = MarkerConfig.from_objects(source.objects, **(markers or {}))
    known = source.world_T_camera_if_known()
    tracker = MarkerTracker(config, source.camera.K, world_T_camera=known)
    calib = source.calibration_frame()
    if calib is None:
        return tracker, {}
    # the empty workspace: reference marker and the boxes' initial poses
    return tracker, dict(tracker.process(calib.color, calib.depth).poses)


def _metadata(
    source: Source, estimator: Any, hand_rate_hz: float | None, side: str
) -> dict[str, Any]:
    """The recording's metadata: the source's, the hand rate and model, whether depth is used."""
    meta = {
        **source.metadata,
        "hand_rate_hz": "every frame" if hand_rate_hz is None else hand_rate_hz,
        "perception": "lfd.perception",
        "depth": source.has_depth,
    }
    if estimator is None:
        return meta
    info = getattr(estimator, "info", {})
    meta["hand_model"] = str(info.get("model") or info.get("training", {}))
    meta["hand_side"] = side
    lifting = getattr(estimator, "lifting", None)
    if callable(lifting):
        meta["hand_lifting"] = lifting(source.has_depth)
    elif not source.has_depth:  # the depth network sees nothing without depth
        raise LfdError(
            f"{meta.get('source', 'the source')} has no depth: the depth network cannot "
            "place the hand; use the colour model (--hand-model mediapipe)"
        )
    return meta


def _close(source: Source) -> None:
    """Release the source; a failure to do so is a warning (the recording is already made)."""
    try:
        source.close()
    except Exception as err:
        import warnings

        from ..errors import LfdWarning

        name = source.metadata.get("source", "the source")
        warnings.warn(f"{name}: closing it failed: {describe(err)}", LfdWarning, stacklevel=3)


class _Session:
    """One recording being made: the file, the tag tracker, the hand model and the observer,
    frame by frame; :attr:`part` names the part running now (a failure's culprit)."""

    def __init__(
        self,
        source: Source,
        rec: Any,
        tracker: MarkerTracker,
        estimators: dict[str, Any],
        observer: RecordObserver | None,
        calib_poses: dict[str, tuple[np.ndarray, np.ndarray]],
        sides: tuple[str, ...] = ("right",),
    ) -> None:
        self.source, self.rec, self.tracker = source, rec, tracker
        self.estimators, self.observer, self.calib_poses = estimators, observer, calib_poses
        self.sides = sides
        self.name = str(source.metadata.get("source", "the source"))
        self.stats = RecordStats(sides=sides)
        self.part = self.name
        self.period = 0
        self.save_images = False
        self.next_hand: int | None = None
        self.camera_written = False
        self.last_poses: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        self.last_t: int | None = None
        self.every_frame = {s: getattr(e, "needs_colour", False) for s, e in estimators.items()}
        # per hand, the frames given to its estimator not answered yet: (time, hand due then,
        # world frame known then)
        self.fed: dict[str, deque[tuple[int, bool, bool]]] = {s: deque() for s in sides}

    def _call(self, part: str, fn: Any, *args: Any) -> Any:
        """``fn(*args)``, run as ``part`` (a failure in it is that part's)."""
        self.part = part
        result = fn(*args)
        self.part = WRITER
        return result

    # --- the loop --------------------------------------------------------------------------
    def run(self, max_frames: int | None, progress: Any, output: str) -> None:
        """Record every frame; close the file with what was recorded, whatever happens."""
        failure: tuple[str, BaseException] | None = None
        try:
            frames = iter(self._call(self.name, self.source.frames))
            while max_frames is None or self.stats.frames < max_frames:
                frame = self._call(self.name, self._next, frames)
                if frame is None:
                    break
                self.step(frame)
                if progress is not None:
                    progress(self.stats)
        except KeyboardInterrupt:
            self.stats.interrupted = True
        except BaseException as err:
            failure = (self.part, err)
        try:
            if failure is not None and self.stats.frames == 0:
                self.rec.discard()  # nothing recorded: no file under the requested name
            else:
                late = self._wind_up(None if failure is None else failure[0])
                failure = failure or late
        finally:
            self.rec.close()  # no-op after discard
        if failure is not None:
            part, cause = failure
            if not isinstance(cause, Exception):  # SystemExit, GeneratorExit: not a failure
                raise cause
            raise RecordingFailed(
                _failure(part, cause, self.stats.frames, output),
                part=part,
                frames=self.stats.frames,
                path=output,
            ) from cause

    def _next(self, frames: Any) -> Frame | None:
        """The source's next frame, checked (None: the source has ended)."""
        frame = next(frames, _END)
        return None if frame is _END else check_frame(frame, self.source.camera, self.name)

    def _wind_up(self, failed: str | None) -> tuple[str, BaseException] | None:
        """Write the hands the estimator still holds and the skills the observer still has open,
        unless that part is the one that failed; the first failure of these, if any."""
        if self.rec.closed:
            return None
        try:
            for side, estimator in self.estimators.items():
                fed = self.fed[side]
                if not fed or failed == HAND_MODEL or not hasattr(estimator, "drain"):
                    continue
                # frames the estimator still holds (the colour hand measuring its bones), oldest
                # first; Ctrl+C in the middle of a frame leaves that newest one on one side only
                held = self._call(HAND_MODEL, lambda e=estimator: list(e.drain()))
                for (t_ns, due_then, world_then), est in zip(fed, held, strict=False):
                    if due_then:
                        hand = self._call(HAND_MODEL, lambda e=est: _checked(_unpack(e)))
                        self.write_hand(t_ns, world_then, hand, side)
            if self.observer is not None and self.last_t is not None and failed != OBSERVER:
                self._observe(self.observer.finish, self.last_t)  # the skills still open
        except Exception as err:
            return self.part, err
        return None

    # --- one frame -------------------------------------------------------------------------
    def step(self, frame: Frame) -> None:
        """Perceive and write one frame: object poses, camera calibration, hand."""
        stats = self.stats
        seen = self._call(TAG_TRACKER, self.tracker.process, frame.color, frame.depth)
        poses = dict(seen.poses)
        for name, (p, q) in poses.items():
            self.rec.add_object_pose(name, frame.t_ns, p, q)
            stats.object_poses += 1
        if self.save_images:
            self.rec.add_color(frame.t_ns, frame.color)
            if frame.depth is not None:
                self.rec.add_depth(frame.t_ns, frame.depth)
        if stats.frames == 0:  # a box hidden in the first frame starts where calibration saw it
            for name, (p, q) in self.calib_poses.items():
                if name not in poses:
                    self.rec.add_object_pose(name, frame.t_ns, p, q)
                    stats.object_poses += 1
                    poses[name] = (p, q)
        self.last_poses.update(poses)  # boxes hidden by the hand are where they were last seen
        self.last_t = frame.t_ns
        if self.observer is not None:
            self._observe(self.observer.on_frame, frame.t_ns, frame.color, poses)
        if not self.camera_written and self.tracker.world_T_camera is not None:
            cam = self.source.camera
            info = CameraInfo(cam.width, cam.height, cam.K, self.tracker.world_T_camera)
            self.rec.add_camera_info(info, frame.t_ns)
            self.camera_written = True
            if self.observer is not None:
                self._observe(self.observer.on_camera, info)
        self._hand(frame)
        stats.frames += 1
        self.rec.flush_if_due()  # a follower (lfd segment --follow) sees each frame within ~1 s

    def _hand(self, frame: Frame) -> None:
        """The hand of this frame when one is due (or, from a colour tracker that follows the
        hand, of the frames it held until now)."""
        due = self.next_hand is None or frame.t_ns >= self.next_hand
        in_world = self.tracker.world_T_camera is not None  # else the hand is camera-frame
        if self.estimators:
            for side in self.sides:
                if not (due or self.every_frame[side]):
                    continue
                # a colour tracker sees every frame it is given: it follows the hand from the
                # previous one, so it is fed at the hand rate and its result kept when due
                fed = self.fed[side]
                fed.append((frame.t_ns, due, in_world))
                found = self._call(HAND_MODEL, self._estimate, side, frame)
                for (t_ns, due_then, world_then), hand in zip(
                    [fed.popleft() for _ in found], found, strict=True
                ):
                    if due_then:
                        self.write_hand(t_ns, world_then, hand, side)
        elif due:
            for side in self.sides:
                self.write_hand(frame.t_ns, in_world, None, side)
        if due:
            period = self.period
            self.next_hand = (
                frame.t_ns + period if self.next_hand is None else self.next_hand + period
            )
            self.next_hand = max(self.next_hand, frame.t_ns + period // 2)

    def _estimate(self, side: str, frame: Frame) -> list[_Found | None]:
        found = _estimate_hands(
            self.estimators[side],
            frame,
            self.source.camera.K,
            self.tracker.world_T_camera,
            _boxes(self.tracker, self.last_poses),
        )
        if len(found) > len(self.fed[side]):
            raise LfdError(
                f"it returned {len(found)} hands for the {len(self.fed[side])} frames it was given"
            )
        return [_checked(hand) for hand in found]

    def write_hand(
        self, t_ns: int, in_world: bool, found: _Found | None, side: str | None = None
    ) -> None:
        """One sample of the ``side`` hand (default: the first): in the world frame, in the
        camera frame (before the reference tag was seen: its own topic, the world topic marked
        unobserved), or none found. The observer sees every hand's (of two, naming its side)."""
        rec, stats = self.rec, self.stats
        side = self.sides[0] if side is None else side
        which: dict[str, Any] = {"side": side} if len(self.sides) > 1 else {}
        observer = self.observer
        told = (side,) if len(self.sides) > 1 else ()
        if found is not None and not in_world:  # its own topic: no frames mixed
            kp, confidence, visible, _ = found
            rec.add_hand(t_ns, kp, confidence, visible=visible, frame="camera", **which)
            stats.hand_in_camera += 1
        if found is None or not in_world:  # marked unobserved (NaN, confidence 0)
            rec.add_hand(t_ns, np.full((21, 3), np.nan), np.zeros(21), **which)
            stats.hand_missing += found is None
            if observer is not None:
                self._observe(observer.on_hand, t_ns, None, None, None, *told)
        else:
            kp, confidence, visible, kp_2d = found
            rec.add_hand(t_ns, kp, confidence, visible=visible, **which)
            stats.hand_estimates += 1
            if observer is not None:
                self._observe(observer.on_hand, t_ns, kp, confidence, kp_2d, *told)

    def _observe(self, method: Any, *args: Any) -> None:
        """Tell the observer; write the skills it settles to ``/lfd/live/segments``."""
        skills = self._call(OBSERVER, lambda: list(method(*args)))
        for label, settled_ns, extra in skills:
            if label.hand is None and len(self.sides) > 1:  # the observer follows the first hand
                label = replace(label, hand=self.sides[0])
            self.rec.add_live_segment(label, settled_ns, extra)
            self.stats.live_segments += 1


def _failure(part: str, err: BaseException, frames: int, output: str) -> str:
    """The one line of a failed recording."""
    if frames == 0:
        return f"{part} failed before the first frame: {describe(err)}; nothing was recorded"
    return (
        f"{part} failed after {frames} frames: {describe(err)}; kept the {frames} frames "
        f"recorded, complete, in {output}"
    )


SPREAD_SCALE_M = 0.005
"""A keypoint whose estimates over the point subsets spread by this much gets confidence 0.5."""


_Found = tuple[np.ndarray, np.ndarray, np.ndarray, "np.ndarray | None"]
"""World keypoints (21, 3), confidence (21,), visibility (21,) and, from a colour model, the
2-D keypoints (21, 2) of one frame."""


def _unpack(est: Any) -> _Found | None:
    """A colour estimator's :class:`~lfd.perception.hand.rgbd.HandEstimate` as a ``_Found``."""
    if est is None:
        return None
    kp_2d = None if est.hand is None else est.hand.keypoints_2d
    return est.keypoints, est.confidence, est.visible, kp_2d


def _checked(hand: _Found | None) -> _Found | None:
    """A hand model's answer for one frame as arrays of the right shapes, or an
    :class:`LfdError` saying what it returned."""
    if hand is None:
        return None
    kp, confidence, visible, kp_2d = (None if v is None else np.asarray(v) for v in hand)
    wanted = [(kp, (21, 3), "keypoints"), (confidence, (21,), "confidence")]
    wanted += [(visible, (21,), "visibility")]
    if kp_2d is not None:
        wanted.append((kp_2d, (21, 2), "2-D keypoints"))
    for value, shape, what in wanted:
        if value is None or value.shape != shape or value.dtype.kind not in "biuf":
            got = "None" if value is None else f"{value.dtype} {value.shape}"
            raise LfdError(f"it returned {what} of {got}, expected numbers of shape {shape}")
    assert kp is not None and confidence is not None and visible is not None
    return kp.astype(float), confidence.astype(float), visible.astype(bool), kp_2d


def _estimate_hands(
    estimator: Any,
    frame: Frame,
    K: np.ndarray,
    world_T_camera: np.ndarray | None,
    boxes: list[Any],
) -> list[_Found | None]:
    """The hands of the oldest frames given to ``estimator`` that are now known, in order
    (None: no hand in that frame): this frame's at once, but for a colour estimator that holds
    frames (``feed``; the colour hand measuring its bones, then all of them at once).

    A colour estimator (``feed`` or ``estimate_frame``) gets every frame, and its keypoints
    are in the camera frame while ``world_T_camera`` is None (the reference tag not seen yet);
    a depth estimator needs depth and the camera pose. The depth network's confidence is
    1 / (1 + spread / SPREAD_SCALE_M) over its point subsets; an estimator with only
    ``estimate`` gets confidence 1."""
    if hasattr(estimator, "feed"):
        found = estimator.feed(frame.color, frame.depth, K, world_T_camera, boxes)
        return [_unpack(est) for est in found]
    if hasattr(estimator, "estimate_frame"):
        return [
            _unpack(estimator.estimate_frame(frame.color, frame.depth, K, world_T_camera, boxes))
        ]
    if frame.depth is None or world_T_camera is None:
        return [None]
    args = (frame.depth, K, world_T_camera, boxes)
    if hasattr(estimator, "estimate_with_spread"):
        result = estimator.estimate_with_spread(*args)
        if result is None:
            return [None]
        kp, spread = result
        return [(kp, 1.0 / (1.0 + np.asarray(spread) / SPREAD_SCALE_M), np.ones(21, bool), None)]
    kp = estimator.estimate(*args)
    return [None if kp is None else (kp, np.ones(21), np.ones(21, bool), None)]


def _process(
    frame: Frame, tracker: MarkerTracker, rec: Any, stats: RecordStats, save_images: bool
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    seen = tracker.process(frame.color, frame.depth)
    for name, (p, q) in seen.poses.items():
        rec.add_object_pose(name, frame.t_ns, p, q)
        stats.object_poses += 1
    if save_images:
        rec.add_color(frame.t_ns, frame.color)
        if frame.depth is not None:
            rec.add_depth(frame.t_ns, frame.depth)
    return seen.poses
