"""Read an lfd MCAP recording into a :class:`~lfd.demo.Demonstration` (:func:`load`).

Damaged files are handled, never silently: a truncated or unfinished file keeps every complete
chunk and emits a :class:`~lfd.errors.RecoveredFileWarning`; out-of-order samples are sorted and
duplicate timestamps dropped with a :class:`~lfd.errors.TimestampWarning`; both are also
recorded in ``demo.metadata["load_report"]``. A file that is not MCAP, or lacks the hand
keypoints or every object pose, raises :class:`~lfd.errors.RecordingFormatError`.

A file with both hands (``/hand/right/...`` and ``/hand/left/...``) loads as a two-hand
demonstration (``demo.other_hand``, labels by ``hand``, handovers); a hand topic of an unknown
side, hands on two clocks and labels or handovers for a hand the file lacks are refused
(:mod:`lfd.io.hands`).
"""

from __future__ import annotations

import json
import math
import os
import re
import warnings
from collections.abc import Iterable, Iterator, Mapping, Sequence
from functools import partial
from typing import Any

import numpy as np

from ..demo import (
    CameraInfo,
    Demonstration,
    Handover,
    HandTrack,
    ImageStream,
    ObjectTrack,
    SkillLabel,
)
from ..errors import (
    LfdError,
    RecordingFormatError,
    RecoveredFileWarning,
    TimestampWarning,
    UsageError,
)
from ..inputs import is_ros_path, parse_json
from . import topics as T
from .camera_pose import CameraPoses, calibration_camera
from .hands import clock_problem, handovers_of_events, lanes_problem, spans_of
from .mcapfile import RawRecording, Records, read
from .sizes import resolve_sizes

__all__ = ["load"]


def _ns(stamp: Any) -> int:
    return int(stamp.seconds) * 1_000_000_000 + int(stamp.nanos)


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _tag_id(value: Any, where: str, *, text: bool = False) -> int:
    """A tag id from JSON (an integer) or, with ``text``, from channel metadata (the text of an
    integer: channel metadata values are strings)."""
    if text and isinstance(value, str) and re.fullmatch(r"-?[0-9]+", value.strip()):
        return int(value)
    if isinstance(value, int) and not isinstance(value, bool):
        return value
    raise RecordingFormatError(f"{where}: tag_id must be an integer, got {value!r}")


def _size(value: Any, where: str) -> list[float] | None:
    """An object size ``[x, y, z]`` (positive, finite, metres) or None if absent."""
    if value is None:
        return None
    if not (
        isinstance(value, list) and len(value) == 3 and all(_is_number(v) and v > 0 for v in value)
    ):
        raise RecordingFormatError(
            f"{where}: size must be [x, y, z], three positive lengths in metres, got {value!r}"
        )
    return [float(v) for v in value]


def _confidence(data: bytes, where: str) -> tuple[list[float], list[bool] | None]:
    """The 21 per-keypoint confidences and, if present, visibilities of one
    ``{"confidence": [...], "visible": [...]}`` JSON message."""
    try:
        record = json.loads(data)
        values = record["confidence"]
    except (ValueError, KeyError, TypeError, RecursionError) as err:
        raise RecordingFormatError(
            f'{where}: not a JSON object {{"confidence": [21 numbers]}} ({err!r})'
        ) from None
    if not (
        isinstance(values, list)
        and len(values) == 21
        and all(_is_number(v) and 0 <= v <= 1 for v in values)
    ):
        raise RecordingFormatError(
            f"{where}: confidence must be 21 numbers in [0, 1], got {str(values)[:80]}"
        )
    visible = record.get("visible")
    if visible is not None and not (
        isinstance(visible, list)
        and len(visible) == 21
        and all(isinstance(v, bool) for v in visible)
    ):
        raise RecordingFormatError(f"{where}: visible must be 21 booleans, got {str(visible)[:80]}")
    return [float(v) for v in values], visible


def order_times(times: np.ndarray) -> tuple[np.ndarray, int, int]:
    """Indices that sort ``times`` (stable) without duplicates, the first of equal times kept
    (how a recording's messages are read); counts of unsorted and dups."""
    unsorted = int(np.count_nonzero(np.diff(times) < 0)) if times.size > 1 else 0
    idx = np.argsort(times, kind="stable")
    keep = np.ones(idx.size, dtype=bool)
    keep[1:] = np.diff(times[idx]) != 0
    return idx[keep], unsorted, int(idx.size - np.count_nonzero(keep))


def label_of_event(m: Any, where: str = "") -> SkillLabel:
    """The skill label of one foxglove ``Event`` (metadata ``skill``, ``object``, ``hand``).

    Raises
    ------
    RecordingFormatError
        Its ``hand`` is not a side (``right``, ``left``).
    LfdError
        An unknown skill or a bad span."""
    meta = {kv.key: kv.value for kv in m.metadata}
    hand = meta.get("hand") or None
    if hand is not None and hand not in T.HAND_SIDES:
        raise RecordingFormatError(
            f"{where}label {meta.get('skill', '')!r} at {_ns(m.start_time)} ns is for the "
            f"{hand!r} hand; a hand is one of {', '.join(T.HAND_SIDES)}"
        )
    return SkillLabel(
        skill=meta.get("skill", ""),
        start_ns=_ns(m.start_time),
        end_ns=_ns(m.end_time),
        object=meta.get("object") or None,
        hand=hand,
    )


def labels_of_events(events: Iterable[Any], where: str = "") -> tuple[list[SkillLabel], list[str]]:
    """Skill labels of foxglove ``Event`` messages (:func:`label_of_event`), sorted by time, and
    what was skipped (an unknown skill, a bad span) and why. A label for a hand of an unknown
    side raises :class:`~lfd.errors.RecordingFormatError` (``where`` starts its message)."""
    labels, skipped = [], []
    for m in events:
        try:
            labels.append(label_of_event(m, where))
        except RecordingFormatError:
            raise
        except LfdError as err:
            meta = {kv.key: kv.value for kv in m.metadata}
            skipped.append(f"label {meta}: {err}")
    return sorted(labels, key=lambda lab: (lab.start_ns, lab.end_ns)), skipped


class _Loader:
    def __init__(self, raw: RawRecording) -> None:
        self.raw = raw
        self.unsorted: dict[str, int] = {}
        self.duplicates: dict[str, int] = {}
        self.skipped: list[str] = []

    def decode(self, topic: str, cls: Any) -> tuple[np.ndarray, list[Any]]:
        """Decode a topic's messages, sorted by log time, duplicates dropped."""
        t, each = self.each(topic, cls)
        return t, list(each)

    def each(self, topic: str, cls: Any) -> tuple[np.ndarray, Iterator[Any]]:
        """:meth:`decode` one message at a time (a long recording's messages are not all held
        decoded at once)."""
        items = self.raw.encoded(topic)
        times = np.array([t for t, _ in items], dtype=np.int64)
        idx = self._ordered(topic, times)

        def parse() -> Iterator[Any]:
            from google.protobuf.message import DecodeError

            for i in idx:
                msg = cls()
                try:
                    msg.ParseFromString(items[i][1])
                except DecodeError as err:
                    raise RecordingFormatError(
                        f"{self.raw.path}: cannot decode a {cls.DESCRIPTOR.full_name} on "
                        f"{topic} at {items[i][0]} ns: {err}"
                    ) from err
                yield msg

        return times[idx], parse()

    def _ordered(self, topic: str, times: np.ndarray) -> np.ndarray:
        """:func:`order_times` of a topic's messages, counted in the report."""
        idx, unsorted, dups = order_times(times)
        if unsorted:
            self.unsorted[topic] = unsorted
        if dups:
            self.duplicates[topic] = dups
        return idx

    def _order(self, topic: str, times: np.ndarray) -> np.ndarray | slice:
        """:meth:`_ordered`, or ``slice(None)`` when the messages are already in order (a view
        then, not a copy, of each decoded array)."""
        idx = self._ordered(topic, times)
        return slice(None) if topic not in self.unsorted and idx.size == times.size else idx

    def _bad(self, arrays: dict[str, Any]) -> None:
        if arrays.get("bad"):  # the engine's words, the file's path first
            raise RecordingFormatError(arrays["bad"])

    def hand(self, side: str) -> HandTrack:
        topic = T.hand_topic(side)
        decoded = self.raw.tracks.get(topic)
        if decoded is None:
            return self._hand_of_messages(side)
        self._bad(decoded)
        idx = self._order(topic, decoded["t_ns"])
        t = decoded["t_ns"][idx]
        kp = decoded["keypoints"][idx]
        # (as np.isfinite(kp).all(axis=2), without numpy's slow reduction over 3 items)
        finite = np.isfinite(kp[:, :, 0]) & np.isfinite(kp[:, :, 1]) & np.isfinite(kp[:, :, 2])
        conf = finite.astype(np.float64)
        vis = np.zeros_like(finite)
        has_vis = np.zeros(len(t), dtype=bool)
        given = self.raw.tracks.get(T.confidence_topic(side))
        if given is not None:
            self._bad(given)
            # the first message of a hand frame counts; messages at no hand frame are ignored
            tc = given["t_ns"]
            _, first = np.unique(tc, return_index=True)
            at = np.searchsorted(t, tc[first])
            hit = at < len(t)
            hit[hit] = t[at[hit]] == tc[first][hit]
            rows, src = at[hit], first[hit]
            conf[rows] = given["confidence"][src]
            seen = given["has_visible"][src]
            vis[rows[seen]] = given["visible"][src[seen]]
            has_vis[rows[seen]] = True
        # files written before "visible" existed: observed with confidence > 0
        vis[~has_vis] = finite[~has_vis] & (conf[~has_vis] > 0)
        return HandTrack(t_ns=t, keypoints=kp, confidence=conf, side=side, visible=vis)

    def _hand_of_messages(self, side: str) -> HandTrack:
        """:meth:`hand` from encoded messages (:func:`lfd.io.mcapfile.scan`)."""
        from foxglove_schemas_protobuf.PosesInFrame_pb2 import PosesInFrame

        t, msgs = self.each(T.hand_topic(side), PosesInFrame)
        kp = np.full((len(t), 21, 3), np.nan)
        bad: str | None = None  # reported once every message decoded, as before streaming
        for i, m in enumerate(msgs):
            if len(m.poses) != 21:
                bad = bad or (
                    f"{self.raw.path}: hand message at {t[i]} ns has {len(m.poses)} poses, not 21"
                )
                continue
            kp[i] = [(p.position.x, p.position.y, p.position.z) for p in m.poses]
        if bad is not None:
            raise RecordingFormatError(bad)
        finite = np.isfinite(kp).all(axis=2)
        conf = finite.astype(np.float64)
        vis = np.zeros_like(finite)
        has_vis = np.zeros(len(t), dtype=bool)
        row = {int(ti): i for i, ti in enumerate(t)}
        done: set[int] = set()
        topic = T.confidence_topic(side)
        for tc, data in self.raw.encoded(topic):
            given, seen = _confidence(data, f"{self.raw.path}: {topic} at {tc} ns")
            at = row.get(tc)
            if at is None or tc in done:  # the first message of a hand frame counts
                continue
            done.add(tc)
            conf[at] = np.array(given, dtype=np.float64)
            if seen is not None:
                vis[at] = np.array(seen, dtype=bool)
                has_vis[at] = True
        # files written before "visible" existed: observed with confidence > 0
        vis[~has_vis] = finite[~has_vis] & (conf[~has_vis] > 0)
        return HandTrack(t_ns=t, keypoints=kp, confidence=conf, side=side, visible=vis)

    def object(self, name: str, tag_id: int, size: Any) -> ObjectTrack:
        topic = T.object_topic(name)
        decoded = self.raw.tracks.get(topic)
        if decoded is not None:
            self._bad(decoded)
            idx = self._order(topic, decoded["t_ns"])
            t = decoded["t_ns"][idx]
            pos = decoded["position"][idx]
            quat = decoded["quaternion"][idx]
        else:
            from foxglove_schemas_protobuf.PoseInFrame_pb2 import PoseInFrame

            t, msgs = self.each(topic, PoseInFrame)
            pos = np.empty((len(t), 3))
            quat = np.empty((len(t), 4))
            for i, m in enumerate(msgs):
                p, q = m.pose.position, m.pose.orientation
                pos[i] = (p.x, p.y, p.z)
                quat[i] = (q.x, q.y, q.z, q.w)
        return ObjectTrack(
            name=name,
            tag_id=tag_id,
            size=size,
            t_ns=t,
            position=pos,
            quaternion=quat,
            visible=np.ones(len(t), dtype=bool),
        )

    def labels(self, topic: str = T.GROUND_TRUTH_TOPIC) -> list[SkillLabel]:
        if not self.raw.encoded(topic):
            return []
        from foxglove_schemas_protobuf.Event_pb2 import Event

        labels, skipped = labels_of_events(self._lanes(topic, Event), f"{self.raw.path}: {topic}: ")
        self.skipped += skipped
        return labels

    def _lanes(self, topic: str, cls: Any) -> list[Any]:
        """:meth:`decode` of a label topic, where two hands' labels may share a log time (both
        lanes start together): a duplicate is a repeated time in one lane (``hand``)."""
        t, msgs = self.decode_all(topic, cls)
        lanes = [next((kv.value for kv in m.metadata if kv.key == "hand"), "") for m in msgs]
        order = np.argsort(t, kind="stable")
        seen: set[tuple[int, str]] = set()
        keep = []
        for i in order.tolist():
            key = (int(t[i]), lanes[i])
            if key not in seen:
                seen.add(key)
                keep.append(i)
        unsorted = int(np.count_nonzero(np.diff(t) < 0)) if t.size > 1 else 0
        if unsorted:
            self.unsorted[topic] = unsorted
        if len(keep) < len(msgs):
            self.duplicates[topic] = len(msgs) - len(keep)
        return [msgs[i] for i in keep]

    def decode_all(self, topic: str, cls: Any) -> tuple[np.ndarray, list[Any]]:
        """A topic's messages decoded in file order (none dropped, nothing counted)."""
        from google.protobuf.message import DecodeError

        items = self.raw.encoded(topic)
        msgs = []
        for t, data in items:
            msg = cls()
            try:
                msg.ParseFromString(data)
            except DecodeError as err:
                raise RecordingFormatError(
                    f"{self.raw.path}: cannot decode a {cls.DESCRIPTOR.full_name} on "
                    f"{topic} at {t} ns: {err}"
                ) from err
            msgs.append(msg)
        return np.array([t for t, _ in items], dtype=np.int64), msgs

    def handovers(self) -> list[Handover]:
        if not self.raw.encoded(T.HANDOVERS_TOPIC):
            return []
        from foxglove_schemas_protobuf.Event_pb2 import Event

        _, msgs = self.decode(T.HANDOVERS_TOPIC, Event)
        return handovers_of_events(msgs, self.raw.path)

    def camera(self) -> CameraInfo | None:
        rec = self.raw.json_metadata(T.CALIBRATION_METADATA, "camera")
        if isinstance(rec, dict):
            try:
                return calibration_camera(rec)
            except RecordingFormatError as err:
                self.skipped.append(f"calibration metadata: {err}")
        if not self.raw.encoded(T.CAMERA_INFO_TOPIC):
            return None
        from foxglove_schemas_protobuf.CameraCalibration_pb2 import CameraCalibration
        from foxglove_schemas_protobuf.FrameTransforms_pb2 import FrameTransforms

        t_info, infos = self.decode(T.CAMERA_INFO_TOPIC, CameraCalibration)
        t_tf, tfs = self.decode(T.TF_TOPIC, FrameTransforms)
        try:
            poses = CameraPoses(infos[-1])
        except RecordingFormatError as err:  # the recording loads without its camera
            self.skipped.append(f"{T.CAMERA_INFO_TOPIC} at {t_info[-1]} ns: {err}")
            return None
        for t, msg in zip(t_tf, tfs, strict=True):
            try:
                poses.add(msg)
            except RecordingFormatError as err:  # the last good pose stays
                self.skipped.append(f"{T.TF_TOPIC} at {t} ns: {err}")
        return poses.camera

    def images(self, topic: str) -> ImageStream | None:
        """The frames of ``topic`` (raw, else its ``/compressed`` variant), decoded when first
        used (:attr:`lfd.demo.ImageStream.frames`)."""
        compressed = T.compressed_topic(topic)
        if self.raw.encoded(topic):
            kind = "raw"
        elif self.raw.encoded(compressed):
            topic, kind = compressed, "compressed"
        else:
            return None
        items = self.raw.encoded(topic)
        times = np.array([t for t, _ in items], dtype=np.int64)
        idx = self._ordered(topic, times)
        payloads = [items[i] for i in idx]
        return ImageStream(
            t_ns=times[idx], frames=partial(_decode_images, self.raw.path, topic, kind, payloads)
        )


def _decode_images(
    path: str, topic: str, kind: str, payloads: list[tuple[int, bytes]]
) -> np.ndarray:
    """The frames of encoded RawImage or CompressedImage messages, stacked."""
    from foxglove_schemas_protobuf.CompressedImage_pb2 import CompressedImage
    from foxglove_schemas_protobuf.RawImage_pb2 import RawImage
    from google.protobuf.message import DecodeError

    from .images import decode_compressed, decode_raw

    cls: Any = RawImage if kind == "raw" else CompressedImage
    frames = []
    for t, data in payloads:
        msg = cls()
        try:
            msg.ParseFromString(data)
            if kind == "raw":
                frames.append(decode_raw(msg))
            else:
                frames.append(decode_compressed(msg.data, msg.format))
        except (DecodeError, ValueError) as err:
            raise RecordingFormatError(f"{path}: {topic} at {t} ns: {err}") from err
    shapes = {f.shape for f in frames}
    if len(shapes) > 1:
        raise RecordingFormatError(f"{path}: {topic} mixes image sizes {shapes}")
    return np.stack(frames)


def objects_of(raw: Records) -> list[tuple[str, int, Any]]:
    """``(name, tag_id, size)`` of every object: from the ``demo`` metadata record, else from
    the pose channel's metadata. Values of the wrong type raise RecordingFormatError."""
    where = f"{raw.path}: metadata {T.DEMO_METADATA}/objects"
    declared = raw.json_metadata(T.DEMO_METADATA, "objects", default=[])
    if not isinstance(declared, list):
        raise RecordingFormatError(f"{where} must be a JSON list, got {declared!r}"[:200])
    specs: dict[str, tuple[str, int, Any]] = {}
    for i, obj in enumerate(declared):
        if not (isinstance(obj, dict) and isinstance(obj.get("name"), str) and obj["name"]):
            raise RecordingFormatError(
                f"{where}[{i}] must be an object with a non-empty string 'name', got {obj!r}"[:200]
            )
        at = f"{where}[{i}] ({obj['name']!r})"
        specs[obj["name"]] = (
            obj["name"],
            _tag_id(obj.get("tag_id", -1), at),
            _size(obj.get("size"), at),
        )
    for topic, ch in raw.channels.items():
        name = T.object_name_from_topic(topic)
        if name is not None and name not in specs:
            at = f"{raw.path}: channel {topic} metadata"
            size = None
            if "size" in ch.metadata:
                size = parse_json(
                    ch.metadata["size"],
                    f"{at}: size is not JSON [x, y, z] in metres: {ch.metadata['size'][:80]!r}",
                    RecordingFormatError,
                )
            tag_id = _tag_id(ch.metadata.get("tag_id", "-1"), at, text=True)
            specs[name] = (name, tag_id, _size(size, at))
    return list(specs.values())


def load(
    path: str | os.PathLike[str],
    *,
    images: bool = True,
    object_sizes: Mapping[str, Sequence[float]] | None = None,
    mapping: Any = None,
) -> Demonstration:
    """Read a recording: an lfd MCAP file, or a ROS bag with a topic ``mapping``.

    Parameters
    ----------
    path : str or os.PathLike
        An MCAP file written by :class:`lfd.io.McapRecorder` (or any file with the same topics),
        or a ROS bag: a ROS 1 ``.bag``, a ROS 2 bag directory (``metadata.yaml``) or its
        ``.db3``, or an ``.mcap`` whose channels are ROS 2 (``cdr``) messages.
    images : bool
        Decode the colour and depth images (set False to load only the tracks, faster).
    object_sizes : mapping of name -> (x, y, z), optional
        Object sizes in metres; they win over the sidecar ``REC.sizes.toml`` and the file's
        own sizes. An object no source sizes gets a 5 cm cube and a
        :class:`~lfd.errors.DefaultSizeWarning` (:mod:`lfd.io.sizes`).
    mapping : lfd.io.ros.RosMapping or path, optional
        How a ROS bag's topics map to the hand and the objects (TOML, docs/ros.md); needed
        for a ROS bag, refused for an lfd recording.

    Returns
    -------
    Demonstration
        One hand, or two when the file holds both (``demo.hand`` the right, ``other_hand`` the
        left; each label's ``hand`` set; ``handovers``). With ``metadata["load_report"]``: ``complete``, ``messages``, ``unsorted`` and
        ``duplicates`` (per topic), ``recovered`` (the warning text, or None), ``damage`` (the
        damaged chunks stepped over and the messages lost, one line, or None: every other
        chunk is read).

    Raises
    ------
    RecordingFormatError
        Not an MCAP file, empty, or missing the hand keypoints / every object pose; a hand topic
        of an unknown side, two hands not on one clock, a label or handover for a hand the file
        lacks (:mod:`lfd.io.hands`).
    UsageError
        A ROS bag without ``mapping``, a ``mapping`` for an lfd recording, or an object size
        for an object the recording does not have.
    """
    if is_ros_path(path):
        return _load_ros(path, None, object_sizes, mapping)
    raw = read(path, images=images, topics=_load_topics(images))
    if is_ros_recording(raw):  # its topics are the mapping's: read them all
        return _load_ros(path, read(path, images=images), object_sizes, mapping)
    if mapping is not None:
        raise UsageError(
            f"{raw.path} is an lfd recording, not a ROS bag: drop the topic mapping (--map)"
        )
    return demonstration_of(raw, images=images, object_sizes=object_sizes, stacklevel=3)


def _load_topics(images: bool) -> list[str]:
    """The topics whose encoded messages :func:`demonstration_of` reads (the hand and object
    tracks come decoded; ``/tf`` is only needed without calibration metadata, and is then
    read on demand, :meth:`RawRecording.encoded`)."""
    topics = [T.GROUND_TRUTH_TOPIC, T.LIVE_SEGMENTS_TOPIC, T.HANDOVERS_TOPIC, T.CAMERA_INFO_TOPIC]
    if images:
        for topic in (T.COLOR_TOPIC, T.DEPTH_TOPIC):
            topics += [topic, T.compressed_topic(topic)]
    return topics


def check_hand_topics(raw: Records) -> None:
    """Raise :class:`~lfd.errors.RecordingFormatError` if the recording has a
    ``/hand/<side>/...`` topic of an unknown side (``/hand/middle/keypoints``). A ROS
    recording's topics are its own (its mapping names the hands): not checked."""
    if is_ros_recording(raw):
        return
    unknown = T.unknown_hand_topics(raw.channels)
    if unknown:
        raise RecordingFormatError(
            f"{raw.path}: hand topic {unknown[0]} names an unknown side "
            f"{T.hand_topic_side(unknown[0])!r}; a hand is /hand/right/... or /hand/left/..."
        )


def hand_sides(raw: Records, complete: bool = True, error: str | None = None) -> tuple[str, ...]:
    """The sides of the hands a recording holds, right first: one or two.

    Raises
    ------
    RecordingFormatError
        It has a hand topic of an unknown side, no hand keypoints or no object pose
        (``error``: the damage, if not ``complete``), or two hands not on one clock (the
        clock rule, :func:`lfd.io.hands.clock_problem`, on the channels' first and last
        times).
    """
    check_hand_topics(raw)
    sides = present_sides(raw)
    obj_topics = _object_topics(raw)
    missing = []
    if not sides:
        missing.append("hand keypoints (/hand/right/keypoints or /hand/left/keypoints)")
    if not obj_topics:
        missing.append("at least one object pose (/objects/<name>/pose)")
    if missing:
        raise RecordingFormatError(
            f"{raw.path} is not a usable lfd recording: missing {' and '.join(missing)}; "
            f"it has {raw.describe_topics()}" + ("" if complete else f" (file damaged: {error})")
        )
    check_hand_clock(raw)
    return tuple(sides)


def present_sides(raw: Records) -> list[str]:
    """The sides of the hand keypoint channels with messages, right first."""
    sides = [s for s in T.HAND_SIDES if raw.channels.get(T.hand_topic(s), None)]
    return [s for s in sides if raw.channels[T.hand_topic(s)].count > 0]


def _object_topics(raw: Records) -> list[str]:
    return [t for t, c in raw.channels.items() if T.object_name_from_topic(t) and c.count > 0]


def check_hand_clock(raw: Records) -> None:
    """Raise :class:`~lfd.errors.RecordingFormatError` if the recording's two hands break the
    clock rule (:func:`lfd.io.hands.clock_problem`) on their channels' first and last times
    (a ROS recording's hands are its mapping's: checked when it is loaded)."""
    if is_ros_recording(raw):
        return
    hands = {s: _channel_span(raw, [T.hand_topic(s)]) for s in present_sides(raw)}
    objects = _object_topics(raw)
    problem = clock_problem(
        {s: span for s, span in hands.items() if span is not None},
        _channel_span(raw, objects) if objects else None,
    )
    if problem is not None:
        raise RecordingFormatError(f"{raw.path}: {problem}")


def _channel_span(raw: Records, topics: Sequence[str]) -> tuple[int, int] | None:
    """The first and last log time of the channels ``topics`` (None: not known)."""
    firsts = [raw.channels[t].first_ns for t in topics]
    lasts = [raw.channels[t].last_ns for t in topics]
    known_firsts = [v for v in firsts if v is not None]
    known_lasts = [v for v in lasts if v is not None]
    if len(known_firsts) < len(firsts) or len(known_lasts) < len(lasts):
        return None
    return min(known_firsts), max(known_lasts)


def hand_side(raw: Records, complete: bool = True, error: str | None = None) -> str:
    """The side of the only hand of a recording, or the right hand of two
    (:func:`hand_sides`)."""
    return hand_sides(raw, complete, error)[0]


def demonstration_of(
    raw: RawRecording,
    *,
    images: bool = True,
    object_sizes: Mapping[str, Sequence[float]] | None = None,
    stacklevel: int = 2,
) -> Demonstration:
    """The :class:`Demonstration` of an lfd recording read by :func:`lfd.io.mcapfile.read`
    (decoded tracks) or :func:`lfd.io.mcapfile.scan` (encoded messages): the same arrays from
    either (:func:`load`'s rules; its warnings at ``stacklevel``)."""
    report: dict[str, Any] = {"complete": raw.complete, "messages": raw.message_count}
    report["recovered"] = None
    if not raw.complete:
        msg = (
            f"{raw.path} is truncated or was not closed ({raw.error}); recovered "
            f"{raw.message_count} messages covering {raw.span_s:.2f} s from its complete chunks "
            f"(file size {raw.file_size} bytes); anything after the last complete chunk is lost"
        )
        report["recovered"] = msg
        warnings.warn(msg, RecoveredFileWarning, stacklevel=stacklevel)
    damage = raw.damage_text()
    report["damage"] = damage
    if damage is not None:
        msg = (
            f"{raw.path} is damaged: {damage}; every other chunk was read "
            f"({raw.message_count} messages covering {raw.span_s:.2f} s)"
        )
        report["recovered"] = msg if report["recovered"] is None else report["recovered"]
        warnings.warn(msg, RecoveredFileWarning, stacklevel=stacklevel)
    sides = hand_sides(raw, raw.complete and damage is None, raw.error or damage)
    loader = _Loader(raw)
    hands = [loader.hand(side) for side in sides]
    objects = {}
    specs = objects_of(raw)
    sizes = resolve_sizes(raw.path, {name: size for name, _, size in specs}, object_sizes)
    for name, tag_id, _ in specs:
        objects[name] = loader.object(name, tag_id, sizes[name])
    labels = loader.labels()
    live = loader.labels(T.LIVE_SEGMENTS_TOPIC)
    handovers = loader.handovers()
    for what, lane in (("label", labels), ("live segment", live)):
        problem = lanes_problem(sides, lane, handovers if what == "label" else (), what)
        if problem is not None:
            raise RecordingFormatError(f"{raw.path}: {problem}")
    camera = loader.camera()
    color = loader.images(T.COLOR_TOPIC) if images else None
    depth = loader.images(T.DEPTH_TOPIC) if images else None
    metadata = raw.json_metadata(T.DEMO_METADATA, "metadata", default={})
    if not isinstance(metadata, dict):
        metadata = {"metadata": metadata}
    report.update(unsorted=loader.unsorted, duplicates=loader.duplicates, skipped=loader.skipped)
    if loader.unsorted or loader.duplicates:
        warnings.warn(
            f"{raw.path}: sorted out-of-order samples {loader.unsorted or {}} and dropped "
            f"duplicate timestamps {loader.duplicates or {}} (per topic)",
            TimestampWarning,
            stacklevel=stacklevel,
        )
    if loader.skipped:
        warnings.warn(
            f"{raw.path}: skipped {loader.skipped}", RecoveredFileWarning, stacklevel=stacklevel
        )
    metadata["load_report"] = report
    demo = Demonstration(
        hand=hands[0],
        other_hand=hands[1] if len(hands) > 1 else None,
        handovers=handovers,
        objects=objects,
        labels=labels,
        live_segments=live,
        camera=camera,
        color=color,
        depth=depth,
        metadata=metadata,
    )
    problem = clock_problem(*spans_of(demo))  # the samples read (the channels' agreed)
    if problem is not None:
        raise RecordingFormatError(f"{raw.path}: {problem}")
    return demo


def is_ros_recording(raw: Records) -> bool:
    """Whether an MCAP file holds ROS messages (a channel with message encoding ``cdr``, ROS 2,
    or ``ros1``)."""
    return any(c.encoding in ("cdr", "ros1") for c in raw.channels.values())


def _load_ros(
    path: str | os.PathLike[str],
    raw: RawRecording | None,
    object_sizes: Mapping[str, Sequence[float]] | None,
    mapping: Any,
) -> Demonstration:
    from .ros import load_ros  # rosbags is an optional extra: imported on use

    if mapping is None:
        raise UsageError(
            f"{os.fspath(path)} is a ROS bag: give a topic mapping with --map MAP.toml "
            "(lfd.load(..., mapping=...); see docs/ros.md)"
        )
    if raw is not None and not raw.complete:
        warnings.warn(
            f"{raw.path} is truncated or was not closed ({raw.error}); recovered "
            f"{raw.message_count} messages covering {raw.span_s:.2f} s from its complete chunks",
            RecoveredFileWarning,
            stacklevel=3,
        )
    return load_ros(path, mapping, object_sizes=object_sizes, raw=raw)
