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
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from ..demo import CameraInfo, SkillLabel
from ..errors import LfdError
from .markers import MarkerConfig, MarkerTracker
from .sources import Frame, Source


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
    ) -> Iterable[SettledSkill]:
        """A hand sample: world keypoints (21, 3) m, confidence (21,) and, from a colour model,
        the 2-D keypoints (21, 2) px; ``keypoints`` None: no hand found (written unobserved,
        NaN with confidence 0)."""
        ...

    def finish(self, t_ns: int) -> Iterable[SettledSkill]:
        """The recording ends at ``t_ns`` (its last frame): what is still open settles."""
        ...


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
) -> RecordStats:
    """Record ``source`` into ``output`` (MCAP). ``estimator`` is a ``MediaPipeEstimator``, a
    ``HandEstimator`` or None; ``side`` names the hand topics (``/hand/<side>/...``).

    ``hand_rate_hz`` None estimates the hand on every frame.

    ``observer`` (a :class:`RecordObserver`, e.g. :class:`lfd.live.LiveObserver`: Rerun, live
    segmentation) sees every frame, pose and hand sample as it is written; the skills it settles
    are written to ``/lfd/live/segments`` during the recording, the rest when it ends
    (``stats.live_segments`` counts them).

    ``markers`` are extra :class:`~lfd.perception.markers.MarkerConfig` fields, e.g.
    ``{"dictionary": "DICT_5X5_100", "reference_size": 0.15}``.

    ``progress(stats)`` is called after every frame. KeyboardInterrupt stops the recording
    cleanly (the file is closed, complete and renamed to ``output``); ``stats.interrupted``
    tells it happened. When the source fails after some frames (an :class:`LfdError`, e.g. a
    camera unplugged), the recording so far is closed, complete, under ``output`` and the error
    says so; any other exception, or one before the first frame, removes the unfinished file.
    """
    from ..io import McapRecorder

    if hand_rate_hz is not None and not hand_rate_hz > 0:
        raise LfdError(f"hand rate must be positive, got {hand_rate_hz}")
    config = MarkerConfig.from_objects(source.objects, **(markers or {}))
    known = source.world_T_camera_if_known()
    tracker = MarkerTracker(config, source.camera.K, world_T_camera=known)
    calib = source.calibration_frame()
    calib_poses: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    if calib is not None:  # the empty workspace: reference marker and the boxes' initial poses
        calib_poses = dict(tracker.process(calib.color, calib.depth).poses)
    meta = {
        **source.metadata,
        "hand_rate_hz": "every frame" if hand_rate_hz is None else hand_rate_hz,
        "perception": "lfd.perception",
        "depth": source.has_depth,
    }
    if estimator is not None:
        info = getattr(estimator, "info", {})
        meta["hand_model"] = str(info.get("model") or info.get("training", {}))
        meta["hand_side"] = side
        lifting = getattr(estimator, "lifting", None)
        if callable(lifting):
            meta["hand_lifting"] = lifting(source.has_depth)
        elif not source.has_depth:  # the depth network sees nothing without depth
            source.close()
            raise LfdError(
                f"{meta.get('source', 'the source')} has no depth: the depth network cannot "
                "place the hand; use the colour model (--hand-model mediapipe)"
            )
    objects = [(o["name"], o["tag_id"], np.asarray(o["size"], float)) for o in source.objects]
    stats = RecordStats()
    period = 0 if hand_rate_hz is None else round(1e9 / hand_rate_hz)  # 0: every frame
    next_hand: int | None = None
    camera_written = False
    last_poses: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    rec = McapRecorder(output, objects=objects, metadata=meta, color_format="png", side=side)

    def settled(skills: Iterable[SettledSkill]) -> None:
        for label, settled_ns, extra in skills:
            rec.add_live_segment(label, settled_ns, extra)
            stats.live_segments += 1

    def write_hand(t_ns: int, in_world: bool, found: _Found | None) -> None:
        if found is not None and not in_world:  # its own topic: no frames mixed
            kp, confidence, visible, _ = found
            rec.add_hand(t_ns, kp, confidence, visible=visible, frame="camera")
            stats.hand_in_camera += 1
        if found is None or not in_world:  # marked unobserved (NaN, confidence 0)
            rec.add_hand(t_ns, np.full((21, 3), np.nan), np.zeros(21))
            stats.hand_missing += found is None
            if observer is not None:
                settled(observer.on_hand(t_ns, None, None, None))
        else:
            kp, confidence, visible, kp_2d = found
            rec.add_hand(t_ns, kp, confidence, visible=visible)
            stats.hand_estimates += 1
            if observer is not None:
                settled(observer.on_hand(t_ns, kp, confidence, kp_2d))

    last_t: int | None = None
    tracks_every_frame = getattr(estimator, "needs_colour", False)
    fed: deque[tuple[int, bool, bool]] = deque()  # frames given to the estimator, not answered
    try:
        for frame in source.frames():
            poses = _process(frame, tracker, rec, stats, save_images)
            if stats.frames == 0:  # a box hidden in the first frame starts where calibration saw it
                for name, (p, q) in calib_poses.items():
                    if name not in poses:
                        rec.add_object_pose(name, frame.t_ns, p, q)
                        stats.object_poses += 1
                        poses[name] = (p, q)
            last_poses.update(poses)  # boxes hidden by the hand are where they were last seen
            last_t = frame.t_ns
            if observer is not None:
                settled(observer.on_frame(frame.t_ns, frame.color, poses))
            if not camera_written and tracker.world_T_camera is not None:
                cam = source.camera
                rec.add_camera_info(
                    CameraInfo(cam.width, cam.height, cam.K, tracker.world_T_camera), frame.t_ns
                )
                camera_written = True
            due = next_hand is None or frame.t_ns >= next_hand
            in_world = tracker.world_T_camera is not None  # else the hand is camera-frame
            if estimator is not None and (due or tracks_every_frame):
                # a colour tracker sees every frame it is given: it follows the hand from the
                # previous one, so it is fed at the hand rate and its result kept when due
                fed.append((frame.t_ns, due, in_world))
                found = _estimate_hands(
                    estimator,
                    frame,
                    source.camera.K,
                    tracker.world_T_camera,
                    _boxes(tracker, last_poses),
                )
                for (t_ns, due_then, world_then), hand in zip(
                    [fed.popleft() for _ in found], found, strict=True
                ):
                    if due_then:
                        write_hand(t_ns, world_then, hand)
            elif due:
                write_hand(frame.t_ns, in_world, None)
            if due:
                next_hand = frame.t_ns + period if next_hand is None else next_hand + period
                next_hand = max(next_hand, frame.t_ns + period // 2)
            stats.frames += 1
            rec.flush_if_due()  # a follower (lfd segment --follow) sees each frame within ~1 s
            if progress is not None:
                progress(stats)
            if max_frames is not None and stats.frames >= max_frames:
                break
    except KeyboardInterrupt:
        stats.interrupted = True
    except LfdError as err:
        if stats.frames == 0:
            rec.discard()  # nothing recorded: no file under the requested name
            raise
        # a source that fails mid-demonstration (camera unplugged, unreadable frame) must not
        # lose what was recorded: the file is closed, complete, under the requested name
        raise type(err)(
            f"{err}; the {stats.frames} frames recorded before it are kept, complete, in {output}"
        ) from err
    except BaseException:
        rec.discard()  # a failure of lfd itself leaves no file under the requested name
        raise
    finally:
        try:
            if fed and not rec.closed and hasattr(estimator, "drain"):
                # frames the estimator still holds (the colour hand measuring its bones), oldest
                # first; Ctrl+C in the middle of a frame leaves that newest one on one side only
                for (t_ns, due_then, world_then), est in zip(fed, estimator.drain(), strict=False):
                    if due_then:
                        write_hand(t_ns, world_then, _unpack(est))
            if observer is not None and last_t is not None and not rec.closed:
                settled(observer.finish(last_t))  # the skills still open when it ends
        finally:
            rec.close()  # no-op after discard
        source.close()
    return stats


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
