"""Low-level, damage-tolerant MCAP scanning: every complete chunk of a possibly truncated file.

:func:`scan` reads a recording sequentially with :class:`mcap.stream_reader.StreamReader`
(CRC-checked), which needs no summary section, so a file whose writer was killed or that was cut
at any byte offset still yields all messages of its complete chunks. The raw payloads are
decoded by :mod:`lfd.io.reader`.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from typing import Any

from mcap.records import Channel, DataEnd, Footer, Message, Metadata, Schema
from mcap.stream_reader import StreamReader

from ..errors import RecordingFormatError

MAGIC = b"\x89MCAP0\r\n"


@dataclass
class ChannelSummary:
    """What one channel holds: topic, schema name, message count and time span (ns)."""

    topic: str
    schema: str
    encoding: str
    metadata: dict[str, str]
    count: int = 0
    first_ns: int | None = None
    last_ns: int | None = None

    @property
    def duration_s(self) -> float:
        if self.first_ns is None or self.last_ns is None:
            return 0.0
        return (self.last_ns - self.first_ns) * 1e-9

    @property
    def rate_hz(self) -> float:
        """Mean message rate, (count - 1) / duration; 0 for fewer than two messages."""
        d = self.duration_s
        return (self.count - 1) / d if self.count > 1 and d > 0 else 0.0


@dataclass
class RawRecording:
    """The messages of a recording, grouped by topic, in file order, still encoded."""

    path: str
    file_size: int
    channels: dict[str, ChannelSummary] = field(default_factory=dict)
    messages: dict[str, list[tuple[int, bytes]]] = field(default_factory=dict)
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)
    complete: bool = False
    error: str | None = None
    library: str = ""

    @property
    def message_count(self) -> int:
        return sum(len(m) for m in self.messages.values())

    @property
    def span_s(self) -> float:
        """Seconds from the first to the last message of any channel."""
        firsts = [c.first_ns for c in self.channels.values() if c.first_ns is not None]
        lasts = [c.last_ns for c in self.channels.values() if c.last_ns is not None]
        return (max(lasts) - min(firsts)) * 1e-9 if firsts else 0.0

    def json_metadata(self, record: str, key: str, default: Any = None) -> Any:
        """A JSON value stored under ``key`` of the metadata record ``record``."""
        text = self.metadata.get(record, {}).get(key)
        if text is None:
            return default
        try:
            return json.loads(text)
        except json.JSONDecodeError as err:
            raise RecordingFormatError(
                f"{self.path}: metadata {record}/{key} is not valid JSON: {err}"
            ) from err

    def describe_topics(self) -> str:
        """One line listing the topics with their message counts."""
        if not self.channels:
            return "no channels"
        return ", ".join(
            f"{c.topic} ({c.schema or 'no schema'}, {c.count} msgs)" for c in self.channels.values()
        )


def scan(path: str | os.PathLike[str]) -> RawRecording:
    """Read every complete record of an MCAP file.

    Raises
    ------
    RecordingFormatError
        If the file is missing, empty or does not start with the MCAP magic.
    """
    p = os.fspath(path)
    try:
        size = os.path.getsize(p)
        f = open(p, "rb")
    except OSError as err:
        raise RecordingFormatError(f"cannot open recording {p}: {err}") from err
    with f:
        head = f.read(len(MAGIC))
        if len(head) == 0:
            raise RecordingFormatError(f"{p} is empty, not an MCAP recording")
        if head != MAGIC[: len(head)]:
            raise RecordingFormatError(f"{p} is not an MCAP file (bad magic bytes {head!r})")
        if len(head) < len(MAGIC):
            raise RecordingFormatError(f"{p} is cut inside the MCAP magic ({size} bytes)")
        f.seek(0)
        raw = RawRecording(path=p, file_size=size)
        schemas: dict[int, Schema] = {}
        channels: dict[int, tuple[Channel, str]] = {}
        reader = StreamReader(f, validate_crcs=True, record_size_limit=min(size, 4 * 2**30))
        data_done = False
        try:
            for record in reader.records:
                if isinstance(record, Message):
                    ch = channels.get(record.channel_id)
                    if ch is None:
                        continue  # a message before its channel: not something we wrote
                    topic = ch[0].topic
                    raw.messages[topic].append((record.log_time, record.data))
                    s = raw.channels[topic]
                    s.count += 1
                    t = record.log_time
                    s.first_ns = t if s.first_ns is None else min(s.first_ns, t)
                    s.last_ns = t if s.last_ns is None else max(s.last_ns, t)
                elif isinstance(record, Schema):
                    schemas[record.id] = record
                elif isinstance(record, Channel):
                    if record.id in channels:
                        continue
                    schema = schemas.get(record.schema_id)
                    name = schema.name if schema is not None else ""
                    channels[record.id] = (record, name)
                    if record.topic not in raw.channels:
                        raw.channels[record.topic] = ChannelSummary(
                            topic=record.topic,
                            schema=name,
                            encoding=record.message_encoding,
                            metadata=dict(record.metadata),
                        )
                        raw.messages[record.topic] = []
                elif isinstance(record, Metadata):
                    raw.metadata.setdefault(record.name, {}).update(record.metadata)
                elif isinstance(record, DataEnd):
                    data_done = True
                elif isinstance(record, Footer):
                    break
                elif type(record).__name__ == "Header":
                    raw.library = getattr(record, "library", "")
            raw.complete = data_done
            if not data_done:
                raw.error = "file ends without a data-end record (writer not closed)"
        except Exception as err:
            raw.complete = data_done
            if not data_done:
                detail = str(err) or "end of file"
                raw.error = f"incomplete or damaged record: {type(err).__name__}: {detail}"
    return raw
