"""The topic mapping of a ROS bag (:func:`read_mapping`, schema in docs/ros.md): which topic or
tf frames are the hand, which each object, the reference frame, units and clock."""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from ...demo import NO_TAG, shared_tag_problem, tag_id_problem
from ...errors import UsageError
from ..sizes import check_size

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
    tag_id: int = NO_TAG


@dataclass(frozen=True)
class RosMapping:
    """A bag's topic mapping (see docs/ros.md); read one with :func:`read_mapping`.

    ``hand`` is the only hand, or the right hand of two (``[hands.right]`` and
    ``[hands.left]``); ``other_hand`` the left hand of two."""

    hand: HandSource
    objects: tuple[ObjectSource, ...]
    reference_frame: str = "world"
    units: str = "m"
    time: str = "header"
    tf_topics: tuple[str, ...] = ("/tf", "/tf_static")
    static_tf_topics: tuple[str, ...] = ("/tf_static",)
    source: str = field(default="", compare=False)
    other_hand: HandSource | None = None

    @property
    def hands(self) -> tuple[HandSource, ...]:
        """The mapped hands, the right first."""
        return (self.hand,) if self.other_hand is None else (self.hand, self.other_hand)

    def to_dict(self) -> dict[str, Any]:
        """The mapping as plain data (kept in the demonstration's metadata)."""
        hands = []
        for source in self.hands:
            hand: dict[str, Any] = {"side": source.side, "order": list(source.order)}
            if source.topic:
                hand["topic"] = source.topic
            if source.frames:
                hand["frames"] = list(source.frames)
            hands.append(hand)
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
            **(
                {"hand": hands[0]}
                if len(hands) == 1
                else {"hands": {h.pop("side"): h for h in hands}}
            ),
            "objects": objects,
        }


_TOP_KEYS = (
    "reference_frame",
    "units",
    "time",
    "tf_topics",
    "static_tf_topics",
    "hand",
    "hands",
    "objects",
)
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


def _hands(doc: Mapping[str, Any], where: str) -> tuple[HandSource, HandSource | None]:
    """The ``[hand]`` table (one hand), or ``[hands.right]`` and/or ``[hands.left]``."""
    if "hand" in doc and "hands" in doc:
        raise UsageError(f"{where}: give [hand] (one hand) or [hands.right]/[hands.left], not both")
    if "hands" not in doc:
        hand_doc = doc.get("hand")
        if not isinstance(hand_doc, dict):
            raise UsageError(
                f"{where}: missing the [hand] table (hand.topic or hand.frames), or "
                "[hands.right] and [hands.left] for two hands"
            )
        return _hand(hand_doc, where, "hand", None), None
    hands_doc = doc["hands"]
    if not isinstance(hands_doc, dict) or not hands_doc:
        raise UsageError(f"{where}: [hands] must hold [hands.right] and/or [hands.left]")
    _keys(hands_doc, ("right", "left"), f"{where}: [hands]")
    sources = []
    for side in ("right", "left"):
        if side in hands_doc:
            if not isinstance(hands_doc[side], dict):
                raise UsageError(f"{where}: hands.{side} must be a table (topic or frames)")
            sources.append(_hand(hands_doc[side], where, f"hands.{side}", side))
    if len(sources) == 2 and sources[0].topic and sources[0].topic == sources[1].topic:
        raise UsageError(
            f"{where}: hands.right and hands.left name the same topic {sources[0].topic}; "
            "each hand needs its own"
        )
    return sources[0], (sources[1] if len(sources) == 2 else None)


def _parse_mapping(doc: Mapping[str, Any], where: str) -> RosMapping:
    _keys(doc, _TOP_KEYS, where)
    hand, other_hand = _hands(doc, where)
    objects = _objects(doc, where)
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
        other_hand=other_hand,
        objects=tuple(objects),
        reference_frame=ref,
        units=units,
        time=time,
        tf_topics=tf_topics,
        static_tf_topics=static,
        source=where,
    )


def _hand(hand_doc: Mapping[str, Any], where: str, name: str, side: str | None) -> HandSource:
    """One hand's table, ``[hand]`` or ``[hands.<side>]`` (whose side is its name)."""
    _keys(hand_doc, _HAND_KEYS if side is None else _HAND_KEYS[:3], f"{where}: [{name}]")
    topic = hand_doc.get("topic")
    frames = hand_doc.get("frames")
    if (topic is None) == (frames is None):
        raise UsageError(f"{where}: [{name}] needs exactly one of {name}.topic and {name}.frames")
    if topic is not None:
        topic = _string(topic, f"{where}: {name}.topic")
    frame_names: tuple[str, ...] = ()
    if frames is not None:
        frame_names = tuple(_frame(f) for f in _strings(frames, f"{where}: {name}.frames"))
        if len(frame_names) != N_KEYPOINTS:
            raise UsageError(
                f"{where}: {name}.frames must name the {N_KEYPOINTS} keypoint frames, "
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
            f'{where}: {name}.order must be "mediapipe" or {N_KEYPOINTS} distinct indices '
            f"(the message index of each MediaPipe keypoint), got {order_doc!r}"[:240]
        )
    if frame_names and max(order) >= N_KEYPOINTS:
        raise UsageError(f"{where}: {name}.order indexes {name}.frames, so must be below 21")
    if side is None:
        side = hand_doc.get("side", "right")
        if side not in ("right", "left"):
            raise UsageError(f'{where}: hand.side must be "right" or "left", got {side!r}')
    return HandSource(topic=topic, frames=frame_names, order=order, side=str(side))


def _objects(doc: Mapping[str, Any], where: str) -> list[ObjectSource]:
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
        tag = o.get("tag_id", NO_TAG)
        problem = tag_id_problem(tag, untagged=True)
        if problem is not None:
            raise UsageError(f"{at}.tag_id {problem}")
        objects.append(ObjectSource(name, otopic, oframe, size, int(tag)))
    problem = shared_tag_problem({o.name: o.tag_id for o in objects})
    if problem is not None:
        raise UsageError(f"{where}: {problem}; each tag is on one object ({NO_TAG}: no tag)")
    return objects


def read_mapping(path: str | os.PathLike[str]) -> RosMapping:
    """Read a topic mapping file (TOML; schema in docs/ros.md).

    Raises
    ------
    UsageError
        The file is missing, not TOML, or a key is unknown, missing or of the wrong type (the
        message names the key).
    """
    from ...inputs import parse_toml, read_text

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
