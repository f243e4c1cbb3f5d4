"""A ROS bag opened through ``rosbags`` (imported here, inside the functions: the ``ros``
extra): its topics and their messages, raw or decoded, and a damaged bag as one line."""

from __future__ import annotations

import os
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Any

from ...errors import LfdError, RecordingFormatError
from ..mcapfile import RawRecording

_MISSING = "pip install 'lfd[ros]'"


def _rosbags() -> Any:
    """The ``rosbags`` package, or a one-line :class:`LfdError` saying how to install it."""
    try:
        import rosbags.highlevel
        import rosbags.typesys
    except ImportError as err:
        raise LfdError(f"reading ROS bags needs the rosbags package: {_MISSING}") from err
    return rosbags


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

        from ...inputs import check_input_file

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
