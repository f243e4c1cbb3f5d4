"""A ROS bag read into a :class:`~lfd.demo.Demonstration` through its topic mapping
(:func:`load_ros`), and what a bag holds (:func:`bag_summary`, ``lfd info``)."""

from __future__ import annotations

import os
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ...demo import Demonstration, HandTrack, ObjectTrack
from ...errors import LfdWarning, RecordingFormatError, UsageError
from ..hands import clock_problem, spans_of
from ..mcapfile import RawRecording
from ..sizes import resolve_sizes
from .bag import _Bag, _norm
from .mapping import (
    HAND_TYPES,
    N_KEYPOINTS,
    OBJECT_TYPES,
    POSE_ARRAY,
    TF_MESSAGE,
    UNITS,
    HandSource,
    ObjectSource,
    RosMapping,
    _frame,
    _mapping,
)
from .tf import _check_transform, _matrix, _stamp, _TfTree


def _sorted_unique(t: np.ndarray) -> np.ndarray:
    idx = np.argsort(t, kind="stable")
    keep = np.ones(idx.size, dtype=bool)
    keep[1:] = np.diff(t[idx]) != 0
    return idx[keep]


def _pose_xyzq(pose: Any, scale: float) -> tuple[np.ndarray, np.ndarray]:
    p, q = pose.position, pose.orientation
    return np.array([p.x, p.y, p.z]) * scale, np.array([q.x, q.y, q.z, q.w])


def _hand_points(msg: Any, msgtype: str, need: int, scale: float) -> tuple[Any, np.ndarray] | None:
    """(header, points (k, 3) in the header's frame) of a hand message, None if it lacks the
    keypoints (a MarkerArray deleting markers, a PoseArray with too few poses)."""
    if msgtype == POSE_ARRAY:
        if len(msg.poses) < need:
            return None
        pts = np.array([[p.position.x, p.position.y, p.position.z] for p in msg.poses])
        return msg.header, pts * scale
    markers = [m for m in msg.markers if m.action == 0]  # ADD
    for m in markers:  # one marker holding every keypoint (POINTS, SPHERE_LIST, ...)
        if len(m.points) >= need:
            pts = np.array([[p.x, p.y, p.z] for p in m.points]) * scale
            pos, quat = _pose_xyzq(m.pose, scale)
            mat = _matrix(pos, quat)
            return m.header, pts @ mat[:3, :3].T + mat[:3, 3]
    if len(markers) >= need:  # one marker per keypoint, in id order
        markers.sort(key=lambda m: m.id)
        pts = np.array([_pose_xyzq(m.pose, scale)[0] for m in markers])
        return markers[0].header, pts
    return None


def load_ros(
    path: str | os.PathLike[str],
    mapping: RosMapping | str | os.PathLike[str] | Mapping[str, Any],
    *,
    object_sizes: Mapping[str, Sequence[float]] | None = None,
    raw: RawRecording | None = None,
) -> Demonstration:
    """Read a ROS bag into a :class:`~lfd.demo.Demonstration` through a topic mapping.

    Parameters
    ----------
    path : str or os.PathLike
        A ROS 1 ``.bag``, a ROS 2 bag directory (or its ``.db3``), or a ROS 2 ``.mcap`` file.
    mapping : RosMapping, path of a TOML mapping file, or the mapping as a dict
        Which topics or tf frames are the hand and the objects (docs/ros.md).
    object_sizes : mapping of name -> (x, y, z), optional
        Sizes that win over the mapping's (see :mod:`lfd.io.sizes`).
    raw : RawRecording, optional
        The scanned ``.mcap`` file (:func:`lfd.io.scan`), when the caller has it.

    Raises
    ------
    UsageError
        The mapping names topics or tf frames the bag does not have (the message lists those
        it has), or a topic of a message type lfd cannot read (the message names the supported
        ones).
    RecordingFormatError
        The bag cannot be read, or holds no hand or object samples.
    """
    m = _mapping(mapping)
    p = os.fspath(path)
    bag = _Bag(p, raw)
    try:
        return _read(bag, m, object_sizes)
    finally:
        bag.close()


def _check_topics(bag: _Bag, m: RosMapping) -> None:
    where = m.source or "the topic mapping"
    wanted: list[tuple[str, str]] = []
    wanted += [(h.topic, _hand_name(m, h)) for h in m.hands if h.topic]
    wanted += [(o.topic, f"object {o.name}") for o in m.objects if o.topic]
    missing = [f"{t} ({what})" for t, what in wanted if t not in bag.topics]
    needs_tf = any(h.frames for h in m.hands) or any(o.frame for o in m.objects)
    if needs_tf and not any(t in bag.topics for t in m.tf_topics):
        missing.append(f"{' or '.join(m.tf_topics)} (tf, for the mapped frames)")
    if missing:
        raise UsageError(
            f"{where} names topics {bag.path} does not have: {', '.join(missing)}; "
            f"the bag has: {bag.describe()}"
        )
    for topic, _ in [*wanted, *((t, "tf") for t in m.tf_topics if t in bag.topics)]:
        info = bag.topics[topic]
        if info.others:
            raise RecordingFormatError(
                f"{bag.path}: topic {topic} carries {1 + len(info.others)} message types "
                f"({', '.join((info.msgtype, *info.others))}); lfd reads one type per topic"
            )
    for h in m.hands:
        if h.topic and _norm(bag.topics[h.topic].msgtype) not in HAND_TYPES:
            raise UsageError(
                f"{where}: {_hand_name(m, h)} topic {h.topic} has message type "
                f"{bag.topics[h.topic].msgtype}, which lfd cannot read as hand keypoints; "
                f"supported: {', '.join(HAND_TYPES)} (or tf frames: hand.frames)"
            )
    for o in m.objects:
        if o.topic:
            got = _norm(bag.topics[o.topic].msgtype)
            if got not in OBJECT_TYPES:
                raise UsageError(
                    f"{where}: object {o.name} topic {o.topic} has message type "
                    f"{bag.topics[o.topic].msgtype}, which lfd cannot read as an object pose; "
                    f"supported: {', '.join(OBJECT_TYPES)} (or a tf frame: frame)"
                )
    for t in m.tf_topics:
        if t in bag.topics and _norm(bag.topics[t].msgtype) != TF_MESSAGE:
            raise UsageError(
                f"{where}: tf topic {t} has message type {bag.topics[t].msgtype}; "
                f"supported: {TF_MESSAGE}"
            )


def _hand_name(m: RosMapping, h: HandSource) -> str:
    """``hand`` (one hand), or ``right hand`` / ``left hand`` (two)."""
    return "hand" if m.other_hand is None else f"{h.side} hand"


@dataclass
class _Messages:
    """The mapped messages of a bag: every tf transform, the hand's ``(stamp, frame_id,
    keypoints)`` and each object's ``(stamp, frame_id, position, quaternion)``, in the bag's
    order; ``skipped``: hand messages without the keypoints."""

    tf: _TfTree = field(default_factory=_TfTree)
    hands: dict[str, list[tuple[int, str, np.ndarray]]] = field(default_factory=dict)
    objects: dict[str, list[tuple[int, str, np.ndarray, np.ndarray]]] = field(default_factory=dict)
    skipped: dict[str, int] = field(default_factory=dict)


def _read(
    bag: _Bag, m: RosMapping, object_sizes: Mapping[str, Sequence[float]] | None
) -> Demonstration:
    _check_topics(bag, m)
    where = m.source or "the topic mapping"
    tf_topics = [t for t in m.tf_topics if t in bag.topics]
    got = _messages(bag, m, tf_topics)
    for h in m.hands:
        if got.skipped.get(h.side):
            warnings.warn(
                f"{bag.path}: skipped {got.skipped[h.side]} message(s) on {h.topic} without "
                f"{max(h.order) + 1} keypoints",
                LfdWarning,
                stacklevel=3,
            )
    tf = got.tf
    frames = [f for h in m.hands for f in h.frames]
    for f in [*frames, *(o.frame for o in m.objects if o.frame)]:
        if f not in tf.parent:
            raise UsageError(
                f"{where} names tf frame {f!r}, which no transform in {', '.join(tf_topics)} "
                f"has as its child; tf frames in {bag.path}: {', '.join(tf.frames) or 'none'}"
            )
    hands = []
    for h in m.hands:
        t, kp = _hand_keypoints(bag, m, h, got, where)
        finite = np.isfinite(kp).all(axis=2)
        hands.append(
            HandTrack(t_ns=t, keypoints=kp, confidence=finite.astype(np.float64), side=h.side)
        )
    objects = _object_tracks(bag, m, got, hands[0].t_ns, where, object_sizes)
    metadata: dict[str, Any] = {
        "source": "ros",
        "ros": {"bag": bag.path, "format": bag.kind, "mapping": m.to_dict()},
        "load_report": {"complete": True, "messages": sum(v.count for v in bag.topics.values())},
    }
    demo = Demonstration(
        hand=hands[0],
        other_hand=hands[1] if len(hands) > 1 else None,
        objects=objects,
        metadata=metadata,
    )
    problem = clock_problem(*spans_of(demo))
    if problem is not None:
        raise RecordingFormatError(f"{bag.path}: {problem}")
    return demo


def _messages(bag: _Bag, m: RosMapping, tf_topics: list[str]) -> _Messages:
    """The bag's messages on the mapped topics, decoded (hand messages without the keypoints
    their order needs are counted as skipped)."""
    scale = UNITS[m.units]
    out = _Messages()
    by_topic: dict[str, list[ObjectSource]] = {}
    for o in m.objects:
        if o.topic:
            by_topic.setdefault(o.topic, []).append(o)
    hand_of = {h.topic: h for h in m.hands if h.topic}
    topics = list(dict.fromkeys([*tf_topics, *hand_of, *by_topic]))
    for topic, log_ns, msg in bag.messages(topics):
        if topic in tf_topics:
            static = topic in m.static_tf_topics
            for tr in msg.transforms:
                x = tr.transform
                p = np.array([x.translation.x, x.translation.y, x.translation.z]) * scale
                q = np.array([x.rotation.x, x.rotation.y, x.rotation.z, x.rotation.w])
                _check_transform(p, q, f"{bag.path}: {topic} at {log_ns} ns", tr.child_frame_id)
                out.tf.add(
                    tr.header.frame_id,
                    tr.child_frame_id,
                    _stamp(tr.header, log_ns, m.time),
                    p,
                    q,
                    static,
                )
        h = hand_of.get(topic)
        if h is not None:
            need = max(h.order) + 1
            got = _hand_points(msg, _norm(bag.topics[topic].msgtype), need, scale)
            if got is None:
                out.skipped[h.side] = out.skipped.get(h.side, 0) + 1
            else:
                header, pts = got
                out.hands.setdefault(h.side, []).append(
                    (
                        _stamp(header, log_ns, m.time),
                        _frame(header.frame_id),
                        pts[list(h.order)],
                    )
                )
        for o in by_topic.get(topic, []):
            pos, quat = _pose_xyzq(msg.pose, scale)
            out.objects.setdefault(o.name, []).append(
                (_stamp(msg.header, log_ns, m.time), _frame(msg.header.frame_id), pos, quat)
            )
    return out


def _in_ref(
    tf: _TfTree, ref: str, frame_ids: list[str], times: np.ndarray, mats: np.ndarray, where: str
) -> np.ndarray:
    """``mats`` (n, 4, 4) given in ``frame_ids`` -> in the reference frame ``ref``."""
    out = mats.copy()
    for f in set(frame_ids):
        if f in ("", ref):
            continue
        sel = np.array([fi == f for fi in frame_ids])
        out[sel] = tf.ref_T(ref, f, times[sel], where) @ mats[sel]
    return out


def _hand_keypoints(
    bag: _Bag, m: RosMapping, h: HandSource, got: _Messages, where: str
) -> tuple[np.ndarray, np.ndarray]:
    """The hand ``h``'s sample times and keypoints ``(n, 21, 3)`` in the reference frame, from
    its topic or its tf frames."""
    tf, ref = got.tf, m.reference_frame
    if h.topic:
        hand_raw = got.hands.get(h.side, [])
        t = np.array([h[0] for h in hand_raw], dtype=np.int64)
        idx = _sorted_unique(t)
        t = t[idx]
        kp = np.array([hand_raw[i][2] for i in idx]).reshape(len(idx), N_KEYPOINTS, 3)
        frames = [hand_raw[i][1] for i in idx]
        for f in set(frames):
            if f in ("", ref):
                continue
            sel = np.array([fi == f for fi in frames])
            T = tf.ref_T(ref, f, t[sel], where)
            kp[sel] = np.einsum("nij,nkj->nki", T[:, :3, :3], kp[sel]) + T[:, None, :3, 3]
    else:
        t = tf.times(h.frames[0])
        kp = np.empty((len(t), N_KEYPOINTS, 3))
        for i, k in enumerate(h.order):
            kp[:, i] = tf.ref_T(ref, h.frames[k], t, where)[:, :3, 3]
    if len(t) == 0:
        raise RecordingFormatError(
            f"{bag.path}: no {_hand_name(m, h)} keypoints on "
            f"{h.topic or 'the tf frames ' + ', '.join(h.frames[:2]) + ', ...'}"
        )
    return t, kp


def _object_tracks(
    bag: _Bag,
    m: RosMapping,
    got: _Messages,
    t: np.ndarray,
    where: str,
    object_sizes: Mapping[str, Sequence[float]] | None,
) -> dict[str, ObjectTrack]:
    """Every mapped object's track in the reference frame, from its topic or its tf frame (a
    static frame at the hand's times ``t``)."""
    tf, ref = got.tf, m.reference_frame
    declared = {o.name: o.size for o in m.objects}
    sizes = resolve_sizes(bag.path, declared, object_sizes)
    objects: dict[str, ObjectTrack] = {}
    for o in m.objects:
        if o.topic:
            items = got.objects.get(o.name, [])
            ot = np.array([s[0] for s in items], dtype=np.int64)
            idx = _sorted_unique(ot)
            ot = ot[idx]
            mats = np.array([_matrix(items[i][2], items[i][3]) for i in idx]).reshape(-1, 4, 4)
            mats = _in_ref(tf, ref, [items[i][1] for i in idx], ot, mats, where)
        else:
            assert o.frame is not None
            ot = t.copy() if o.frame in tf.static else tf.times(o.frame)
            mats = tf.ref_T(ref, o.frame, ot, where)
        from scipy.spatial.transform import Rotation

        pos = mats[:, :3, 3]
        quat = Rotation.from_matrix(mats[:, :3, :3]).as_quat() if len(ot) else np.empty((0, 4))
        if len(ot) == 0:
            raise RecordingFormatError(
                f"{bag.path}: object {o.name} has no pose on {o.topic or 'tf frame ' + str(o.frame)}"
            )
        objects[o.name] = ObjectTrack(
            name=o.name,
            tag_id=o.tag_id,
            size=np.array(sizes[o.name]),
            t_ns=ot,
            position=pos,
            quaternion=quat,
            visible=np.isfinite(pos).all(axis=1),
        )
    return objects


def bag_summary(path: str | os.PathLike[str]) -> dict[str, Any]:
    """What a ROS bag holds, in the shape of :func:`lfd.io.summarise`'s file part: every topic
    with its message type, count, rate and time span (the messages are read, not decoded)."""
    p = os.fspath(path)
    bag = _Bag(p, None)
    try:
        stats: dict[str, list[int]] = {}
        for conn, t, _ in bag.raw_messages():
            s = stats.setdefault(conn.topic, [0, int(t), int(t)])
            s[0] += 1
            s[1], s[2] = min(s[1], int(t)), max(s[2], int(t))
        t0 = min((s[1] for s in stats.values()), default=0)
        t1 = max((s[2] for s in stats.values()), default=0)
        size = (
            os.path.getsize(p)
            if os.path.isfile(p)
            else sum(f.stat().st_size for f in os.scandir(p) if f.is_file())
        )
        channels = []
        for topic, info in sorted(bag.topics.items()):
            count, first, last = stats.get(topic, [0, 0, 0])
            span = (last - first) * 1e-9
            channels.append(
                {
                    "topic": topic,
                    "schema": info.msgtype,
                    "count": count,
                    "rate_hz": round((count - 1) / span, 3) if span > 0 else 0.0,
                    "first_s": (first - t0) * 1e-9 if count else None,
                    "last_s": (last - t0) * 1e-9 if count else None,
                }
            )
        return {
            "path": p,
            "file_size": size,
            "library": bag.kind,
            "complete": True,
            "damage": None,
            "messages": sum(c["count"] for c in channels),
            "duration_s": (t1 - t0) * 1e-9,
            "start_ns": t0,
            "channels": channels,
            "metadata_records": {},
        }
    finally:
        bag.close()
