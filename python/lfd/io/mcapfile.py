"""Low-level, damage-tolerant MCAP reading: every complete chunk of a possibly truncated file.

:func:`read` is how recordings are read: the engine's reader (``crates/lfd-mcap``, Rust, the
``mcap`` crate) decodes the hand keypoints, their confidence and the object poses straight into
arrays (:attr:`RawRecording.tracks`) and keeps the other messages encoded; :func:`read_summary`
reads only a file's summary section (what ``lfd info`` shows), checked against its chunk and
message indexes, every chunk CRC-checked. Both apply the limits below. The engine's reader also
steps over damage that :func:`scan`, the pure-Python reader (the ``mcap`` package, which ROS
bags in MCAP, ``lfd.io.follow`` and the tests comparing the two readers use), stops at: a chunk
that fails its CRC is lost alone, a bad length field is skipped to the next plausible record,
and :attr:`RawRecording.damage` names what was lost (:func:`damage_text`, docs/cli.md).

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
import os
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from ..errors import RecordingFormatError
from .topics import decoded_topic, two_types_message

if TYPE_CHECKING:  # the mcap package is imported by the pure-Python reader only, on use
    from mcap.records import Chunk
    from mcap.stream_reader import StreamReader

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


class Records:
    """What :class:`RawRecording` and :class:`Summary` share: channels and metadata records."""

    path: str
    file_size: int
    library: str
    channels: dict[str, ChannelSummary]
    messages: dict[str, list[tuple[int, bytes]]]
    metadata: dict[str, dict[str, str]]

    #: Damaged regions stepped over (dicts: ``offset``, ``end``, ``chunks``: the ordinals of
    #: the chunks lost or None, ``messages``: lost or None when unknown, ``why``).
    damage: list[dict[str, Any]]
    #: Chunks in the file: read (:class:`RawRecording`) or indexed (:class:`Summary`).
    chunks: int
    #: Whether encoded payloads were dropped beyond a byte limit (``raw_limit``).
    raw_truncated: bool

    @property
    def message_count(self) -> int:
        return sum(c.count for c in self.channels.values())

    def damage_text(self) -> str | None:
        """The damage as one plain line (None without damage): which chunks, how many
        messages lost (``unknown`` when no index says)."""
        return damage_text(self.damage, self.chunks)

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
        return metadata_json(self.path, record, key, text)

    def describe_topics(self) -> str:
        """One line listing the topics with their message counts."""
        if not self.channels:
            return "no channels"
        return ", ".join(
            f"{c.topic} ({c.schema or 'no schema'}, {c.count} msgs)" for c in self.channels.values()
        )


@dataclass
class RawRecording(Records):
    """The messages of a recording, grouped by topic, in file order, still encoded.

    From :func:`read`, the hand keypoints, their confidence and the object poses are in
    :attr:`tracks` instead (decoded arrays, file order, by topic) and not in :attr:`messages`;
    :func:`scan` leaves :attr:`tracks` empty."""

    path: str
    file_size: int
    channels: dict[str, ChannelSummary] = field(default_factory=dict)
    messages: dict[str, list[tuple[int, bytes]]] = field(default_factory=dict)
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)
    complete: bool = False
    error: str | None = None
    library: str = ""
    tracks: dict[str, dict[str, Any]] = field(default_factory=dict)
    #: Topics whose messages :func:`read` was asked not to keep (:meth:`encoded` reads them).
    unread: frozenset[str] = frozenset()
    damage: list[dict[str, Any]] = field(default_factory=list)
    chunks: int = 0
    raw_truncated: bool = False

    def encoded(self, topic: str) -> list[tuple[int, bytes]]:
        """The messages of ``topic``, still encoded: :attr:`messages`, or for a topic in
        :attr:`unread`, read from the file then (a second pass, kept for later calls)."""
        if topic in self.unread:
            from .._hmmseg import read_recording

            doc = read_recording(self.path, True, [topic])
            self.messages[topic] = list(doc["raw"].get(topic, []))
            self.unread = self.unread - {topic}
        return self.messages.get(topic, [])


def metadata_json(path: str, record: str, key: str, text: str) -> Any:
    """``text``, the value stored under ``key`` of the metadata record ``record`` of the
    recording ``path``, parsed as JSON; not JSON: a :class:`~lfd.errors.RecordingFormatError`
    naming the file, the record and the key (:meth:`Records.json_metadata`, and the followed
    recording's calibration record: :class:`lfd.io.camera_pose.FollowedCamera`)."""
    from ..inputs import parse_json

    return parse_json(
        text, f"{path}: metadata {record}/{key} is not valid JSON", RecordingFormatError
    )


def damage_text(damage: Sequence[Mapping[str, Any]], chunks: int = 0) -> str | None:
    """Damaged regions as one plain line: ``chunk 10 of 19 damaged (why): 137 messages lost``;
    None without damage."""
    if not damage:
        return None
    parts = []
    of = f" of {chunks}" if chunks else ""
    for d in damage:
        ids = d.get("chunks")
        if ids is None:
            where = f"bytes {d['offset']}-{d['end']} (chunks unknown)"
        elif not ids:
            where = f"bytes {d['offset']}-{d['end']} (no chunk)"
        elif len(ids) == 1:
            where = f"chunk {ids[0]}{of}"
        else:
            where = f"chunks {', '.join(str(i) for i in ids)}{of}"
        n = d.get("messages")
        lost = "unknown messages lost" if n is None else f"{n} messages lost"
        why = " ".join(str(d["why"]).split())
        parts.append(f"{where} damaged ({why}): {lost}")
    return "; ".join(parts)


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
    from mcap.records import Channel, DataEnd, Footer, Message, Metadata, Schema
    from mcap.stream_reader import StreamReader

    from ..inputs import check_input_file

    p = check_input_file(path, "recording", RecordingFormatError)
    try:
        size = os.path.getsize(p)
        f = open(p, "rb")
    except OSError as err:
        raise RecordingFormatError(f"cannot open recording {p}: {err}") from err
    with f:
        _check_magic(f.read(len(MAGIC)), p, size)
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
                    if ch is not None:  # else a message before its channel: not ours
                        _add_message(raw, ch[0].topic, record.log_time, record.data)
                elif isinstance(record, Schema):
                    schemas[record.id] = record
                elif isinstance(record, Channel):
                    if record.id not in channels:
                        schema = schemas.get(record.schema_id)
                        channels[record.id] = (record, _add_channel(raw, record, schema))
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


def _check_magic(head: bytes, p: str, size: int) -> None:
    """Refuse a file that does not start with the MCAP magic (``head``: its first bytes)."""
    if len(head) == 0:
        raise RecordingFormatError(f"{p} is empty, not an MCAP recording")
    if head != MAGIC[: len(head)]:
        raise RecordingFormatError(f"{p} is not an MCAP file (bad magic bytes {head!r})")
    if len(head) < len(MAGIC):
        raise RecordingFormatError(f"{p} is cut inside the MCAP magic ({size} bytes)")


def _add_message(raw: RawRecording, topic: str, t: int, data: bytes) -> None:
    """A message of :func:`scan` on ``topic`` at ``t`` (ns) kept, its channel counted."""
    if t > INT64_MAX:
        raise RecordingFormatError(
            f"{raw.path}: a message on {topic} has log_time {t} ns, "
            "beyond the largest time lfd reads (2**63 - 1 ns)"
        )
    raw.messages[topic].append((t, data))
    s = raw.channels[topic]
    s.count += 1
    s.first_ns = t if s.first_ns is None else min(s.first_ns, t)
    s.last_ns = t if s.last_ns is None else max(s.last_ns, t)


def _add_channel(raw: RawRecording, record: Any, schema: Any) -> str:
    """A channel record of :func:`scan` (``schema``: its schema record, None if unknown): its
    topic summarised on first sight, refused if a decoded topic changes type; its schema name."""
    name = schema.name if schema is not None else ""
    known = raw.channels.get(record.topic)
    kind = (name, record.message_encoding)
    if known is not None and (known.schema, known.encoding) != kind:
        if decoded_topic(record.topic):
            raise RecordingFormatError(
                two_types_message(raw.path, record.topic, (known.schema, known.encoding), kind)
            )
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
    return name


def _records(reader: StreamReader, path: str, budget: int) -> Any:
    """The reader's records with every chunk broken up, within an inflation ``budget``."""
    from mcap.records import Chunk
    from mcap.stream_reader import breakup_chunk

    left = budget
    for record in reader.records:
        if isinstance(record, Chunk):
            chunk = _inflate(record, path, left)
            left -= chunk.uncompressed_size
            yield from breakup_chunk(chunk, validate_crc=True)
        else:
            yield record


def _channels(docs: Sequence[Mapping[str, Any]]) -> dict[str, ChannelSummary]:
    return {
        d["topic"]: ChannelSummary(
            topic=d["topic"],
            schema=d["schema"],
            encoding=d["encoding"],
            metadata=dict(d["metadata"]),
            count=int(d["count"]),
            first_ns=d["first_ns"],
            last_ns=d["last_ns"],
            schema_encoding=d["schema_encoding"],
            schema_data=bytes(d["schema_data"]),
        )
        for d in docs
    }


def read(
    path: str | os.PathLike[str],
    *,
    images: bool = True,
    topics: Iterable[str] | None = None,
    raw_limit: int | None = None,
) -> RawRecording:
    """Read every complete record of an MCAP file with the engine's reader: :func:`scan`'s
    result, but the hand keypoints (``/hand/<side>/keypoints``), their confidence and the object
    poses (``/objects/<name>/pose``) decoded into :attr:`RawRecording.tracks` (file order). With
    ``images=False`` the image messages are counted but not kept. With ``topics``, only those
    topics' encoded messages are kept (every topic is still counted in
    :attr:`RawRecording.channels`); the others are :attr:`RawRecording.unread`, read on demand
    by :meth:`RawRecording.encoded`. With ``raw_limit``, at most that many bytes of encoded
    payloads are kept (:attr:`RawRecording.raw_truncated` says some were dropped).

    Raises
    ------
    RecordingFormatError
        As :func:`scan`.
    """
    from .._hmmseg import read_recording
    from ..inputs import check_input_file

    keep = None if topics is None else list(topics)
    doc = read_recording(
        check_input_file(path, "recording", RecordingFormatError), images, keep, raw_limit
    )
    raw = RawRecording(
        path=os.fspath(path),
        file_size=int(doc["file_size"]),
        channels=_channels(doc["channels"]),
        metadata={k: dict(v) for k, v in doc["metadata"].items()},
        complete=bool(doc["complete"]),
        error=doc["error"],
        library=doc["library"],
        damage=[dict(d) for d in doc["damage"]],
        chunks=int(doc["chunks"]),
        raw_truncated=bool(doc["raw_truncated"]),
    )
    raw.messages = {topic: [] for topic in raw.channels}
    raw.messages.update(doc["raw"])
    for kind in ("hands", "confidence", "poses"):
        for topic, arrays in doc[kind].items():
            raw.tracks[topic] = dict(arrays)
    if keep is not None:
        raw.unread = frozenset(raw.channels) - set(keep) - set(raw.tracks)
    return raw


@dataclass
class Summary(Records):
    """What a file's summary section holds (:func:`read_summary`): its channels with their
    counts and times, metadata records and attachments, without reading the messages; and the
    messages of the few topics asked for."""

    path: str
    file_size: int
    library: str
    channels: dict[str, ChannelSummary]
    metadata: dict[str, dict[str, str]]
    attachments: list[dict[str, Any]]
    messages: dict[str, list[tuple[int, bytes]]]
    damage: list[dict[str, Any]] = field(default_factory=list)
    chunks: int = 0
    raw_truncated: bool = False


def read_summary(
    path: str | os.PathLike[str], topics: list[str] | tuple[str, ...] = ()
) -> Summary | None:
    """The summary section of an MCAP file and the messages of ``topics`` (read from the chunks
    that hold them, found by the chunk indexes); None when the file has none (a recording whose
    writer was killed: :func:`read` recovers it) or one that cannot be believed (chunk indexes
    that do not point at their chunks, chunks without message indexes, statistics that disagree
    with them). Every chunk is inflated and CRC-checked, nothing kept: :attr:`Summary.damage`
    names the damaged ones and the messages their message indexes say they held.

    Raises
    ------
    RecordingFormatError
        Not an MCAP file, or as :func:`scan` for the chunks it reads.
    """
    from .._hmmseg import read_summary as engine_summary
    from ..inputs import check_input_file

    doc = engine_summary(check_input_file(path, "recording", RecordingFormatError), list(topics))
    if doc is None:
        return None
    return Summary(
        path=os.fspath(path),
        file_size=int(doc["file_size"]),
        library=doc["library"],
        channels=_channels(doc["channels"]),
        metadata={k: dict(v) for k, v in doc["metadata"].items()},
        attachments=[dict(a) for a in doc["attachments"]],
        messages={t: list(doc["raw"].get(t, [])) for t in topics},
        damage=[dict(d) for d in doc["damage"]],
        chunks=int(doc["chunks"]),
        raw_truncated=bool(doc["raw_truncated"]),
    )
