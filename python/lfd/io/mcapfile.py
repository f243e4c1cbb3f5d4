"""Low-level, damage-tolerant MCAP scanning: every complete chunk of a possibly truncated file.

:func:`scan` reads a recording sequentially with :class:`mcap.stream_reader.StreamReader`
(CRC-checked), which needs no summary section, so a file whose writer was killed or that was cut
at any byte offset still yields all messages of its complete chunks. The raw payloads are
decoded by :mod:`lfd.io.reader`.

A chunk may not inflate to more than its file can plausibly hold (a decompression bomb): the
uncompressed size that each chunk header declares is checked against :func:`inflate_limit`
*before* it is decompressed, and decompression stops at the declared size, so a lying header
cannot allocate more either. Records outside chunks are never compressed, so the reader's
record size limit (the file size) bounds them.
"""

from __future__ import annotations

import dataclasses
import io
import json
import os
from dataclasses import dataclass, field
from typing import Any

from mcap.records import Channel, Chunk, DataEnd, Footer, Message, Metadata, Schema
from mcap.stream_reader import StreamReader, breakup_chunk

from ..errors import RecordingFormatError

MAGIC = b"\x89MCAP0\r\n"

MAX_INFLATION = 200
"""How many times its file size a recording may inflate to, all chunks together. The shipped
recordings inflate 1.8-2.2x (tracks) and 10x (raw colour + depth frames; one chunk 10.6x):
200x leaves a margin of 20 over the most compressible real data, while only long runs of
identical bytes (a crafted bomb: 67 KB of zstd zeros inflate to 2 GiB) go beyond it."""

MIN_INFLATE_BYTES = 8 * 2**20
"""A small file may always inflate to this much (8 MiB), whatever its size."""

MAX_CHUNK_BYTES = 2**30
"""No single chunk may inflate to more than 1 GiB (lfd writes 64-256 KiB chunks)."""

INT64_MAX = 2**63 - 1


def inflate_limit(file_size: int) -> int:
    """Bytes that all chunks of a file of ``file_size`` bytes may inflate to, together."""
    return max(MIN_INFLATE_BYTES, MAX_INFLATION * file_size)


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
    schema_encoding: str = ""
    schema_data: bytes = b""

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


def _inflate(chunk: Chunk, path: str, budget: int) -> Chunk:
    """``chunk`` with its records decompressed, refusing to inflate beyond ``budget`` bytes."""
    n = chunk.uncompressed_size
    limit = min(budget, MAX_CHUNK_BYTES)
    if n > limit:
        raise RecordingFormatError(
            f"{path}: a chunk of {len(chunk.data)} bytes declares {n} uncompressed bytes, more "
            f"than the {limit} bytes this {os.path.getsize(path)}-byte file may still inflate "
            f"to ({MAX_INFLATION}x its size in all, at most {MAX_CHUNK_BYTES} bytes per chunk); "
            "refusing a possible decompression bomb"
        )
    if chunk.compression == "zstd":
        import zstandard

        reader = zstandard.ZstdDecompressor().stream_reader(
            io.BytesIO(chunk.data), read_across_frames=True
        )
        parts, got = [], 0
        while got <= n:
            part = reader.read(n + 1 - got)
            if not part:
                break
            parts.append(part)
            got += len(part)
        data = b"".join(parts)
    elif chunk.compression == "lz4":
        import lz4.frame

        data = lz4.frame.LZ4FrameDecompressor().decompress(chunk.data, max_length=n + 1)
    elif chunk.compression == "":
        data = chunk.data
    else:
        raise RecordingFormatError(f"{path}: unknown chunk compression {chunk.compression!r}")
    if len(data) != n:
        size = f"more than {n}" if len(data) > n else f"{len(data)}"
        raise ValueError(f"a chunk inflates to {size} bytes, its header says {n}")
    return dataclasses.replace(chunk, compression="", data=data)


def scan(path: str | os.PathLike[str]) -> RawRecording:
    """Read every complete record of an MCAP file.

    Raises
    ------
    RecordingFormatError
        If the file is missing, empty or does not start with the MCAP magic, if its chunks
        would inflate beyond :func:`inflate_limit` (a decompression bomb), or if a message's
        ``log_time`` does not fit in a signed 64-bit integer.
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
        reader = StreamReader(
            f, validate_crcs=True, record_size_limit=min(size, 4 * 2**30), emit_chunks=True
        )
        data_done = False
        budget = inflate_limit(size)
        try:
            for record in _records(reader, p, budget):
                if isinstance(record, Message):
                    ch = channels.get(record.channel_id)
                    if ch is None:
                        continue  # a message before its channel: not something we wrote
                    topic = ch[0].topic
                    if record.log_time > INT64_MAX:
                        raise RecordingFormatError(
                            f"{p}: a message on {topic} has log_time {record.log_time} ns, "
                            "beyond the largest time lfd reads (2**63 - 1 ns)"
                        )
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
                            schema_encoding=schema.encoding if schema is not None else "",
                            schema_data=bytes(schema.data) if schema is not None else b"",
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
        except RecordingFormatError:
            raise
        except Exception as err:
            raw.complete = data_done
            if not data_done:
                detail = str(err) or "end of file"
                raw.error = f"incomplete or damaged record: {type(err).__name__}: {detail}"
    return raw


def _records(reader: StreamReader, path: str, budget: int) -> Any:
    """The reader's records with every chunk broken up, within an inflation ``budget``."""
    left = budget
    for record in reader.records:
        if isinstance(record, Chunk):
            chunk = _inflate(record, path, left)
            left -= chunk.uncompressed_size
            yield from breakup_chunk(chunk, validate_crc=True)
        else:
            yield record
