"""ROS 1 and ROS 2 bags as demonstrations, through ``rosbags`` (pure Python, no ROS install).

A bag holds its hand keypoints and object poses on topics of its own; a small TOML file, the
topic mapping (:func:`read_mapping`, schema in docs/ros.md), says which:

- the hand: a ``geometry_msgs/PoseArray`` or ``visualization_msgs/MarkerArray`` topic with the
  21 keypoints (MediaPipe order, or ``order``), or 21 tf child frames;
- each object: a ``geometry_msgs/PoseStamped`` topic or a tf child frame, with its size;
- the reference frame every pose is expressed in (tf chains from ``/tf`` and ``/tf_static``
  composed at each sample's time), and the units (``m`` or ``mm``).

:func:`load_ros` reads a ROS 1 ``.bag``, a ROS 2 bag directory (``metadata.yaml`` with sqlite3
or mcap storage, or its ``.db3``), or a lone ROS 2 ``.mcap`` file; :func:`lfd.load` calls it for
such paths. ``rosbags`` is imported only here, inside the functions (the ``ros`` extra).
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..demo import Demonstration, HandTrack, ObjectTrack
from ..errors import LfdError, LfdWarning, RecordingFormatError, UsageError
from .mcapfile import RawRecording
from .sizes import check_size, resolve_sizes

__all__ = [
    "HAND_TYPES",
    "OBJECT_TYPES",
    "HandSource",
    "ObjectSource",
    "RosMapping",
    "load_ros",
    "read_mapping",
]

POSE_ARRAY = "geometry_msgs/PoseArray"
MARKER_ARRAY = "visualization_msgs/MarkerArray"
POSE_STAMPED = "geometry_msgs/PoseStamped"
TF_MESSAGE = "tf2_msgs/TFMessage"
HAND_TYPES = (POSE_ARRAY, MARKER_ARRAY)
"""Message types a hand topic may have (or the hand is 21 tf frames: ``hand.frames``)."""
OBJECT_TYPES = (POSE_STAMPED,)
"""Message types an object topic may have (or the object is a tf frame: ``frame``)."""

UNITS = {"m": 1.0, "mm": 1e-3}
N_KEYPOINTS = 21
_MISSING = "pip install 'lfd[ros]'"


def _rosbags() -> Any:
    """The ``rosbags`` package, or a one-line :class:`LfdError` saying how to install it."""
    try:
        import rosbags.highlevel
        import rosbags.typesys
    except ImportError as err:
        raise LfdError(f"reading ROS bags needs the rosbags package: {_MISSING}") from err
    return rosbags


# --- the mapping ----------------------------------------------------------------------------
@dataclass(frozen=True)
class HandSource:
    """Where the hand keypoints are: a topic (PoseArray / MarkerArray) or 21 tf frames.

    ``order[i]`` is the index, in each message (or in ``frames``), of MediaPipe keypoint ``i``.
    """

    topic: str | None = None
    frames: tuple[str, ...] = ()
    order: tuple[int, ...] = tuple(range(N_KEYPOINTS))
    side: str = "right"


@dataclass(frozen=True)
class ObjectSource:
    """Where one object's pose is: a PoseStamped topic or a tf child frame; its size, tag."""

    name: str
    topic: str | None = None
    frame: str | None = None
    size: tuple[float, float, float] | None = None
    tag_id: int = -1


@dataclass(frozen=True)
class RosMapping:
    """A bag's topic mapping (see docs/ros.md); read one with :func:`read_mapping`."""

    hand: HandSource
    objects: tuple[ObjectSource, ...]
    reference_frame: str = "world"
    units: str = "m"
    time: str = "header"
    tf_topics: tuple[str, ...] = ("/tf", "/tf_static")
    static_tf_topics: tuple[str, ...] = ("/tf_static",)
    source: str = field(default="", compare=False)

    def to_dict(self) -> dict[str, Any]:
        """The mapping as plain data (kept in the demonstration's metadata)."""
        hand: dict[str, Any] = {"side": self.hand.side, "order": list(self.hand.order)}
        if self.hand.topic:
            hand["topic"] = self.hand.topic
        if self.hand.frames:
            hand["frames"] = list(self.hand.frames)
        objects = {}
        for o in self.objects:
            d: dict[str, Any] = {"tag_id": o.tag_id}
            if o.topic:
                d["topic"] = o.topic
            if o.frame:
                d["frame"] = o.frame
            if o.size:
                d["size"] = list(o.size)
            objects[o.name] = d
        return {
            "reference_frame": self.reference_frame,
            "units": self.units,
            "time": self.time,
            "tf_topics": list(self.tf_topics),
            "static_tf_topics": list(self.static_tf_topics),
            "hand": hand,
            "objects": objects,
        }


_TOP_KEYS = ("reference_frame", "units", "time", "tf_topics", "static_tf_topics", "hand", "objects")
_HAND_KEYS = ("topic", "frames", "order", "side")
_OBJECT_KEYS = ("topic", "frame", "size", "tag_id")


def _frame(name: str) -> str:
    """A tf frame id without the leading ``/`` ROS 1 allowed."""
    return name.lstrip("/")


def _keys(table: Mapping[str, Any], known: Sequence[str], where: str) -> None:
    for key in table:
        if key not in known:
            raise UsageError(f"{where}: unknown key {key!r}; known keys: {', '.join(known)}")


def _string(value: Any, where: str) -> str:
    if not isinstance(value, str) or not value:
        raise UsageError(f"{where} must be a non-empty string, got {value!r}")
    return value


def _strings(value: Any, where: str) -> tuple[str, ...]:
    if not isinstance(value, list) or not all(isinstance(v, str) and v for v in value):
        raise UsageError(f"{where} must be a list of non-empty strings, got {value!r}"[:200])
    return tuple(value)


def _parse_mapping(doc: Mapping[str, Any], where: str) -> RosMapping:
    _keys(doc, _TOP_KEYS, where)
    hand_doc = doc.get("hand")
    if not isinstance(hand_doc, dict):
        raise UsageError(f"{where}: missing the [hand] table (hand.topic or hand.frames)")
    _keys(hand_doc, _HAND_KEYS, f"{where}: [hand]")
    topic = hand_doc.get("topic")
    frames = hand_doc.get("frames")
    if (topic is None) == (frames is None):
        raise UsageError(f"{where}: [hand] needs exactly one of hand.topic and hand.frames")
    if topic is not None:
        topic = _string(topic, f"{where}: hand.topic")
    frame_names: tuple[str, ...] = ()
    if frames is not None:
        frame_names = tuple(_frame(f) for f in _strings(frames, f"{where}: hand.frames"))
        if len(frame_names) != N_KEYPOINTS:
            raise UsageError(
                f"{where}: hand.frames must name the {N_KEYPOINTS} keypoint frames, "
                f"got {len(frame_names)}"
            )
    order_doc = hand_doc.get("order", "mediapipe")
    if order_doc == "mediapipe":
        order = tuple(range(N_KEYPOINTS))
    elif (
        isinstance(order_doc, list)
        and len(order_doc) == N_KEYPOINTS
        and all(isinstance(i, int) and not isinstance(i, bool) and i >= 0 for i in order_doc)
        and len(set(order_doc)) == N_KEYPOINTS
    ):
        order = tuple(order_doc)
    else:
        raise UsageError(
            f'{where}: hand.order must be "mediapipe" or {N_KEYPOINTS} distinct indices '
            f"(the message index of each MediaPipe keypoint), got {order_doc!r}"[:240]
        )
    if frame_names and max(order) >= N_KEYPOINTS:
        raise UsageError(f"{where}: hand.order indexes hand.frames, so must be below 21")
    side = hand_doc.get("side", "right")
    if side not in ("right", "left"):
        raise UsageError(f'{where}: hand.side must be "right" or "left", got {side!r}')
    hand = HandSource(topic=topic, frames=frame_names, order=order, side=side)

    objects_doc = doc.get("objects")
    if not isinstance(objects_doc, dict) or not objects_doc:
        raise UsageError(
            f"{where}: missing the objects: one [objects.NAME] table per object "
            "(with topic or frame)"
        )
    objects = []
    for name, o in objects_doc.items():
        at = f"{where}: objects.{name}"
        if not isinstance(o, dict):
            raise UsageError(f"{at} must be a table (topic or frame, size, tag_id)")
        _keys(o, _OBJECT_KEYS, f"{where}: [objects.{name}]")
        if ("topic" in o) == ("frame" in o):
            raise UsageError(f"{at} needs exactly one of topic and frame")
        otopic = _string(o["topic"], f"{at}.topic") if "topic" in o else None
        oframe = _frame(_string(o["frame"], f"{at}.frame")) if "frame" in o else None
        size = check_size(o["size"], f"{at}.size") if "size" in o else None
        tag = o.get("tag_id", -1)
        if not isinstance(tag, int) or isinstance(tag, bool):
            raise UsageError(f"{at}.tag_id must be an integer, got {tag!r}")
        objects.append(ObjectSource(name, otopic, oframe, size, tag))

    ref = _frame(_string(doc.get("reference_frame", "world"), f"{where}: reference_frame"))
    units = doc.get("units", "m")
    if units not in UNITS:
        raise UsageError(f'{where}: units must be "m" or "mm", got {units!r}')
    time = doc.get("time", "header")
    if time not in ("header", "receive"):
        raise UsageError(f'{where}: time must be "header" or "receive", got {time!r}')
    tf_topics = _strings(doc.get("tf_topics", ["/tf", "/tf_static"]), f"{where}: tf_topics")
    static = _strings(doc.get("static_tf_topics", ["/tf_static"]), f"{where}: static_tf_topics")
    return RosMapping(
        hand=hand,
        objects=tuple(objects),
        reference_frame=ref,
        units=units,
        time=time,
        tf_topics=tf_topics,
        static_tf_topics=static,
        source=where,
    )


def read_mapping(path: str | os.PathLike[str]) -> RosMapping:
    """Read a topic mapping file (TOML; schema in docs/ros.md).

    Raises
    ------
    UsageError
        The file is missing, not TOML, or a key is unknown, missing or of the wrong type (the
        message names the key).
    """
    from ..inputs import parse_toml, read_text

    p = os.fspath(path)
    if os.path.isdir(p):
        raise UsageError(f"--map {p} is a directory; give a topic mapping file")
    try:
        text = read_text(
            p, "--map", not_text="is not a valid TOML topic mapping (binary, not UTF-8 text)"
        )
    except FileNotFoundError:
        raise UsageError(f"--map {p} does not exist; give a topic mapping file") from None
    except OSError as err:
        raise UsageError(f"--map {p}: {err.strerror or err}") from None
    return _parse_mapping(parse_toml(text, f"{p}: not a valid TOML topic mapping"), p)


def _mapping(mapping: RosMapping | str | os.PathLike[str] | Mapping[str, Any]) -> RosMapping:
    if isinstance(mapping, RosMapping):
        return mapping
    if isinstance(mapping, Mapping):
        return _parse_mapping(mapping, "topic mapping")
    return read_mapping(mapping)


# --- reading a bag ----------------------------------------------------------------------------
def _norm(msgtype: str) -> str:
    """``tf2_msgs/msg/TFMessage`` (ROS 2) and ``tf2_msgs/TFMessage`` (ROS 1) alike."""
    return msgtype.replace("/msg/", "/")


@dataclass
class _Topic:
    msgtype: str
    count: int
    others: tuple[str, ...] = ()
    """Other message types on the same topic (a bag may have several connections to one
    topic); a topic lfd reads must have one type."""


class _Bag:
    """The topics of a bag and its messages, decoded: ``(topic, log time ns, message)``."""

    def __init__(self, path: str, raw: RawRecording | None) -> None:
        self.path = path
        self.raw = raw
        self.reader: Any = None
        self.topics: dict[str, _Topic] = {}
        rosbags = _rosbags()
        if raw is not None:
            ros1 = any(c.encoding == "ros1" for c in raw.channels.values())
            self.kind = "ROS 1 MCAP file" if ros1 else "ROS 2 MCAP file"
            for topic, ch in raw.channels.items():
                self.topics[topic] = _Topic(ch.schema, ch.count)
            return
        from rosbags.typesys import Stores, get_typestore

        from ..inputs import check_input_file

        check_input_file(path, "ROS bag", RecordingFormatError, directory=True)
        if os.path.isdir(path):  # a ROS 2 bag: its metadata and storage files
            for name in os.listdir(path):
                check_input_file(
                    os.path.join(path, name), "ROS bag file", RecordingFormatError, directory=True
                )
        target = path
        if path.endswith(".db3"):
            target = os.path.dirname(os.path.abspath(path))
        ros1 = path.endswith(".bag")
        self.kind = "ROS 1 bag" if ros1 else "ROS 2 bag"
        store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
        from pathlib import Path

        try:
            self.reader = rosbags.highlevel.AnyReader([Path(target)], default_typestore=store)
            self.reader.open()
        except FileNotFoundError as err:
            raise RecordingFormatError(f"{path}: not a readable ROS bag: {err}") from None
        except Exception as err:  # rosbags' reader errors: a damaged or foreign file
            raise self.damaged(err, "not a readable") from None
        for c in self.reader.connections:
            t = self.topics.get(c.topic)
            if t is None:
                self.topics[c.topic] = _Topic(c.msgtype, c.msgcount)
                continue
            t.count += c.msgcount
            if c.msgtype != t.msgtype and c.msgtype not in t.others:
                t.others += (c.msgtype,)

    def damaged(self, err: BaseException, what: str = "damaged") -> RecordingFormatError:
        """The error for a failure of rosbags' reader (its own errors, or a struct, zlib, bz2,
        lz4 or sqlite3 error from deep inside it): the file is damaged or foreign."""
        detail = " ".join(str(err).split())[:200]
        return RecordingFormatError(
            f"{self.path}: {what} {self.kind}: {type(err).__name__}: {detail}"
        )

    def raw_messages(self, connections: Any = None) -> Iterator[tuple[Any, int, bytes]]:
        """``(connection, time ns, data)`` of the bag's messages, in time order; a record that
        cannot be read raises :class:`RecordingFormatError` (rosbags reads lazily: the
        damage in the middle of a bag shows only here)."""
        it = iter(self.reader.messages(connections=connections or self.reader.connections))
        while True:
            try:
                item = next(it)
            except StopIteration:
                return
            except Exception as err:  # rosbags' reader errors, as at open
                raise self.damaged(err) from None
            yield item

    def close(self) -> None:
        if self.reader is not None:
            self.reader.close()
            self.reader = None

    def describe(self) -> str:
        return (
            ", ".join(f"{t} ({v.msgtype}, {v.count} msgs)" for t, v in sorted(self.topics.items()))
            or "no topics"
        )

    def messages(self, topics: Sequence[str]) -> Iterator[tuple[str, int, Any]]:
        wanted = set(topics)
        if self.raw is not None:
            store = _mcap_typestore(self.raw)
            for topic in topics:
                msgtype = self.topics[topic].msgtype
                ros1 = self.raw.channels[topic].encoding == "ros1"
                decode = store.deserialize_ros1 if ros1 else store.deserialize_cdr
                for t, data in self.raw.messages.get(topic, []):
                    try:
                        msg = decode(data, _full(msgtype))
                    except Exception as err:
                        raise RecordingFormatError(
                            f"{self.path}: cannot decode a {msgtype} on {topic} at {t} ns: {err}"
                        ) from None
                    yield topic, t, msg
            return
        conns = [c for c in self.reader.connections if c.topic in wanted]
        for conn, t, data in self.raw_messages(conns):
            try:
                msg = self.reader.deserialize(data, conn.msgtype)
            except Exception as err:
                raise RecordingFormatError(
                    f"{self.path}: cannot decode a {conn.msgtype} on {conn.topic} at {t} ns: {err}"
                ) from None
            yield conn.topic, int(t), msg


def _full(msgtype: str) -> str:
    """``pkg/Type`` (ROS 1 names) -> ``pkg/msg/Type``, the names of rosbags' typestores."""
    parts = msgtype.split("/")
    return f"{parts[0]}/msg/{parts[1]}" if len(parts) == 2 else msgtype


def _mcap_typestore(raw: RawRecording) -> Any:
    """A typestore with the message definitions an MCAP file embeds (``ros2msg``,
    ``ros2idl`` or ``ros1msg`` schemas, so messages of any distribution decode), on top of ROS 2
    Humble's (ROS 1 Noetic's for ROS 1 messages) for a file without them."""
    from rosbags.typesys import Stores, get_types_from_idl, get_types_from_msg, get_typestore

    ros1 = any(ch.encoding == "ros1" for ch in raw.channels.values())
    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    types: dict[str, Any] = {}
    for ch in raw.channels.values():
        if not ch.schema_data or ch.encoding not in ("cdr", "ros1"):
            continue
        try:
            text = ch.schema_data.decode("utf-8")
            if ch.schema_encoding in ("ros2msg", "ros1msg"):
                types.update(get_types_from_msg(text, _full(ch.schema)))
            elif ch.schema_encoding == "ros2idl":
                types.update(get_types_from_idl(text))
        except Exception:  # a definition rosbags cannot parse: Humble's (if it has the type)
            continue
    if types:
        fresh = get_typestore(Stores.EMPTY)
        fresh.register({**store.fielddefs, **types})
        return fresh
    return store


def _stamp(header: Any, log_ns: int, time: str) -> int:
    if time == "receive":
        return log_ns
    s = header.stamp
    ns = int(s.sec) * 1_000_000_000 + int(s.nanosec)
    return ns if ns > 0 else log_ns


def _matrix(p: Any, q: Any) -> np.ndarray:
    """A 4x4 transform of a translation and an (x, y, z, w) quaternion."""
    from scipy.spatial.transform import Rotation

    m = np.eye(4)
    qa = np.asarray(q, dtype=np.float64)
    if np.all(np.isfinite(qa)) and np.linalg.norm(qa) > 0:
        m[:3, :3] = Rotation.from_quat(qa).as_matrix()
    m[:3, 3] = p
    return m


def _check_transform(p: np.ndarray, q: np.ndarray, where: str, child: str) -> None:
    """Refuse a tf transform that is no rigid motion: a quaternion that is zero (no rotation
    at all, not the identity: that is 0, 0, 0, 1), NaN or infinite, or such a translation."""
    if not (np.all(np.isfinite(q)) and np.linalg.norm(q) > 1e-9):
        raise RecordingFormatError(
            f"{where}: the transform to frame {child!r} has rotation quaternion "
            f"{', '.join(f'{v:g}' for v in q)} (x, y, z, w), which is not a rotation"
        )
    if not np.all(np.isfinite(p)):
        raise RecordingFormatError(
            f"{where}: the transform to frame {child!r} has translation "
            f"{', '.join(f'{v:g}' for v in p)}, which is not finite"
        )


class _TfTree:
    """Every transform of the tf topics; ``ref_T(frame, times)`` composes a chain at times."""

    def __init__(self) -> None:
        self.parent: dict[str, str] = {}
        self.samples: dict[str, list[tuple[int, np.ndarray, np.ndarray]]] = {}
        self.static: set[str] = set()

    def add(self, parent: str, child: str, t: int, p: np.ndarray, q: np.ndarray, static: bool):  # type: ignore[no-untyped-def]
        parent, child = _frame(parent), _frame(child)
        self.parent[child] = parent
        self.samples.setdefault(child, []).append((t, p, q))
        if static:
            self.static.add(child)

    @property
    def frames(self) -> list[str]:
        return sorted(set(self.parent) | set(self.parent.values()))

    def times(self, child: str) -> np.ndarray:
        """Distinct sample times of the edge into ``child``, sorted."""
        return np.unique(np.array([s[0] for s in self.samples.get(child, [])], dtype=np.int64))

    def _edge(self, child: str, times: np.ndarray) -> np.ndarray:
        """parent_T_child at ``times``, shape (n, 4, 4): interpolated (translation linear,
        rotation slerp), held constant before the first and after the last sample."""
        from scipy.spatial.transform import Rotation, Slerp

        items = sorted(self.samples[child], key=lambda s: s[0])
        t = np.array([s[0] for s in items], dtype=np.int64)
        _, first = np.unique(t, return_index=True)
        t = t[first]
        p = np.array([items[i][1] for i in first], dtype=np.float64)
        q = np.array([items[i][2] for i in first], dtype=np.float64)
        out = np.tile(np.eye(4), (len(times), 1, 1))
        if child in self.static or len(t) == 1:
            out[:] = _matrix(p[-1], q[-1])
            return out
        x = (times - t[0]) * 1e-9
        xs = (t - t[0]) * 1e-9
        for k in range(3):
            out[:, k, 3] = np.interp(x, xs, p[:, k])
        rot = Slerp(xs, Rotation.from_quat(q))(np.clip(x, xs[0], xs[-1]))
        out[:, :3, :3] = rot.as_matrix()
        return out

    def _chain(self, frame: str) -> list[str]:
        chain = [frame]
        while chain[-1] in self.parent and len(chain) <= len(self.parent):
            chain.append(self.parent[chain[-1]])
        return chain

    def _root_T(self, chain: list[str], upto: str, times: np.ndarray) -> np.ndarray:
        """upto_T_chain[0] at ``times`` (``upto`` is in ``chain``)."""
        out = np.tile(np.eye(4), (len(times), 1, 1))
        for child in chain[: chain.index(upto)]:
            out = self._edge(child, times) @ out
        return out

    def ref_T(self, ref: str, frame: str, times: np.ndarray, where: str) -> np.ndarray:
        """ref_T_frame at ``times``, shape (n, 4, 4)."""
        if frame == ref:
            return np.tile(np.eye(4), (len(times), 1, 1))
        a, b = self._chain(frame), self._chain(ref)
        common = next((f for f in a if f in b), None)
        if common is None:
            raise UsageError(
                f"{where}: no tf path from frame {frame!r} to the reference frame {ref!r}; "
                f"tf frames in the bag: {', '.join(self.frames) or 'none'}"
            )
        anc_T_frame = self._root_T(a, common, times)
        anc_T_ref = self._root_T(b, common, times)
        return np.linalg.inv(anc_T_ref) @ anc_T_frame


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
    if m.hand.topic:
        wanted.append((m.hand.topic, "hand"))
    wanted += [(o.topic, f"object {o.name}") for o in m.objects if o.topic]
    missing = [f"{t} ({what})" for t, what in wanted if t not in bag.topics]
    needs_tf = bool(m.hand.frames) or any(o.frame for o in m.objects)
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
    if m.hand.topic:
        got = _norm(bag.topics[m.hand.topic].msgtype)
        if got not in HAND_TYPES:
            raise UsageError(
                f"{where}: hand topic {m.hand.topic} has message type "
                f"{bag.topics[m.hand.topic].msgtype}, which lfd cannot read as hand keypoints; "
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


def _read(
    bag: _Bag, m: RosMapping, object_sizes: Mapping[str, Sequence[float]] | None
) -> Demonstration:
    _check_topics(bag, m)
    where = m.source or "the topic mapping"
    scale = UNITS[m.units]
    need = max(m.hand.order) + 1
    tf = _TfTree()
    tf_topics = [t for t in m.tf_topics if t in bag.topics]
    # hand / object messages: (stamp, frame_id, points or (p, q))
    hand_raw: list[tuple[int, str, np.ndarray]] = []
    obj_raw: dict[str, list[tuple[int, str, np.ndarray, np.ndarray]]] = {}
    by_topic: dict[str, list[ObjectSource]] = {}
    for o in m.objects:
        if o.topic:
            by_topic.setdefault(o.topic, []).append(o)
    topics = list(dict.fromkeys([*tf_topics, *([m.hand.topic] if m.hand.topic else []), *by_topic]))
    skipped = 0
    for topic, log_ns, msg in bag.messages(topics):
        if topic in tf_topics:
            static = topic in m.static_tf_topics
            for tr in msg.transforms:
                x = tr.transform
                p = np.array([x.translation.x, x.translation.y, x.translation.z]) * scale
                q = np.array([x.rotation.x, x.rotation.y, x.rotation.z, x.rotation.w])
                _check_transform(p, q, f"{bag.path}: {topic} at {log_ns} ns", tr.child_frame_id)
                tf.add(
                    tr.header.frame_id,
                    tr.child_frame_id,
                    _stamp(tr.header, log_ns, m.time),
                    p,
                    q,
                    static,
                )
        if topic == m.hand.topic:
            got = _hand_points(msg, _norm(bag.topics[topic].msgtype), need, scale)
            if got is None:
                skipped += 1
            else:
                header, pts = got
                hand_raw.append(
                    (
                        _stamp(header, log_ns, m.time),
                        _frame(header.frame_id),
                        pts[list(m.hand.order)],
                    )
                )
        for o in by_topic.get(topic, []):
            pos, quat = _pose_xyzq(msg.pose, scale)
            obj_raw.setdefault(o.name, []).append(
                (_stamp(msg.header, log_ns, m.time), _frame(msg.header.frame_id), pos, quat)
            )
    if skipped:
        warnings.warn(
            f"{bag.path}: skipped {skipped} message(s) on {m.hand.topic} without {need} keypoints",
            LfdWarning,
            stacklevel=3,
        )
    for f in [*m.hand.frames, *(o.frame for o in m.objects if o.frame)]:
        if f not in tf.parent:
            raise UsageError(
                f"{where} names tf frame {f!r}, which no transform in {', '.join(tf_topics)} "
                f"has as its child; tf frames in {bag.path}: {', '.join(tf.frames) or 'none'}"
            )
    ref = m.reference_frame

    def in_ref(frame_ids: list[str], times: np.ndarray, mats: np.ndarray) -> np.ndarray:
        """``mats`` (n, 4, 4) given in ``frame_ids`` -> in the reference frame."""
        out = mats.copy()
        for f in set(frame_ids):
            if f in ("", ref):
                continue
            sel = np.array([fi == f for fi in frame_ids])
            out[sel] = tf.ref_T(ref, f, times[sel], where) @ mats[sel]
        return out

    # the hand
    if m.hand.topic:
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
        t = tf.times(m.hand.frames[0])
        kp = np.empty((len(t), N_KEYPOINTS, 3))
        for i, k in enumerate(m.hand.order):
            kp[:, i] = tf.ref_T(ref, m.hand.frames[k], t, where)[:, :3, 3]
    if len(t) == 0:
        raise RecordingFormatError(
            f"{bag.path}: no hand keypoints on "
            f"{m.hand.topic or 'the tf frames ' + ', '.join(m.hand.frames[:2]) + ', ...'}"
        )
    finite = np.isfinite(kp).all(axis=2)
    hand = HandTrack(t_ns=t, keypoints=kp, confidence=finite.astype(np.float64), side=m.hand.side)

    # the objects
    declared = {o.name: o.size for o in m.objects}
    sizes = resolve_sizes(bag.path, declared, object_sizes)
    objects: dict[str, ObjectTrack] = {}
    for o in m.objects:
        if o.topic:
            items = obj_raw.get(o.name, [])
            ot = np.array([s[0] for s in items], dtype=np.int64)
            idx = _sorted_unique(ot)
            ot = ot[idx]
            mats = np.array([_matrix(items[i][2], items[i][3]) for i in idx]).reshape(-1, 4, 4)
            mats = in_ref([items[i][1] for i in idx], ot, mats)
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
    metadata: dict[str, Any] = {
        "source": "ros",
        "ros": {"bag": bag.path, "format": bag.kind, "mapping": m.to_dict()},
        "load_report": {"complete": True, "messages": sum(v.count for v in bag.topics.values())},
    }
    return Demonstration(hand=hand, objects=objects, metadata=metadata)


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
