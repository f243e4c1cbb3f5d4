"""Follow a recording while another process writes it: every message as soon as its chunk lands.

:func:`follow` tails a growing MCAP file record by record. The writer (``lfd record``,
:class:`~lfd.io.McapRecorder`) closes a chunk at least every second and hands it to the OS, so a
follower sees the data within about a second. A record still being written at the end of the
file (a chunk half flushed) is waited for, never an error. Following stops

- at the end marker (the data-end record the writer writes when it closes the file),
- when the file stops growing for ``idle_timeout_s`` without an end marker (the writer died or
  hangs), with a :class:`~lfd.errors.RecoveredFileWarning` "the file stopped growing without an
  end marker",
- at a damaged record (bad CRC, corrupt compressed data, garbage), keeping what came before it
  with a :class:`~lfd.errors.RecoveredFileWarning`, as the offline reader
  (:func:`lfd.io.mcapfile.scan`) recovers such a file,
- on Ctrl+C (KeyboardInterrupt while waiting for data) or :meth:`Follower.stop`.

A file that gets shorter than what was already read, or whose last bytes read change (truncated
and written again in place), is refused with a :class:`~lfd.errors.RecordingFormatError`: the
messages read so far are no longer what the file holds (checked whenever its size changes, on
the :data:`TAIL_CHECKED` bytes before the read position).

The recorder writes to ``.NAME.XXXXXXXX.partial`` beside ``NAME`` and renames it when closed;
following ``NAME`` follows that partial file while it is being written (the open file survives
the rename), or ``NAME`` itself once it exists. Beside a complete ``NAME``, a partial file is
followed only while a recorder is writing it (:func:`live_partial`): one left by a recorder that
died (older than ``NAME``, or that stopped growing) is not.

Example::

    follower = lfd.io.follow("demo.mcap")
    for msg in follower:                   # LiveMessage, in file order
        if msg.kind == "hand":
            keypoints = msg.value          # (21, 3) metres, NaN = unobserved
            side = msg.side                # "right" or "left": a file may hold both hands
    print(follower.stop_reason)            # "end", "idle", "interrupted" or "stopped"
"""

from __future__ import annotations

import glob
import io
import json
import os
import threading
import time
import warnings
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import IO, Any

import numpy as np
from mcap.records import Channel, Chunk, DataEnd, Footer, Message, Metadata, Schema
from mcap.stream_reader import StreamReader, breakup_chunk

from ..errors import RecordingFormatError, RecoveredFileWarning
from ..inputs import check_input_file
from . import topics as T
from .mcapfile import INT64_MAX, MAGIC, _inflate, inflate_limit

__all__ = ["Follower", "LiveMessage", "ObjectPose", "follow", "live_partial", "partial_files"]

KINDS = (
    "hand",
    "confidence",
    "object",
    "label",
    "handover",
    "tf",
    "camera_info",
    "color",
    "depth",
    "other",
)
"""What a :class:`LiveMessage` can hold (see its ``value``)."""

RECORD_SIZE_LIMIT = 4 * 2**30
"""A record declaring more bytes than this is damage, not data still to come."""

STOPPED_GROWING = "the file stopped growing without an end marker"

TAIL_CHECKED = 4096
"""How many of the last bytes read are compared with the file whenever its size changes."""


@dataclass(frozen=True)
class ObjectPose:
    """One object observation: ``position`` (3,) metres and ``quaternion`` (4,) x, y, z, w."""

    name: str
    position: np.ndarray
    quaternion: np.ndarray


@dataclass(frozen=True)
class LiveMessage:
    """One message of a followed recording.

    Attributes
    ----------
    topic : str
        The MCAP topic.
    t_ns : int
        Its ``log_time``: capture time, nanoseconds.
    kind : str
        One of :data:`KINDS`.
    value : Any
        Decoded: ``hand`` an array (21, 3) (NaN = unobserved); ``confidence`` a pair of arrays
        (confidence (21,), visible (21,) bool or None); ``object`` an :class:`ObjectPose`;
        ``label`` a :class:`~lfd.demo.SkillLabel`; ``handover`` a :class:`~lfd.demo.Handover`;
        ``tf`` and ``camera_info`` the protobuf message; ``color`` / ``depth`` the image array
        when following with ``images=True``, else None; ``other`` None.
    data : bytes
        The encoded payload, as in the file.
    side : str or None
        The hand a ``hand`` or ``confidence`` message is of (``right`` or ``left``: a two-hand
        recording interleaves both), or the hand a ``label`` names; else None.
    """

    topic: str
    t_ns: int
    kind: str
    value: Any
    data: bytes = field(repr=False)
    side: str | None = None


def _mtime(path: str) -> float | None:
    try:
        return os.stat(path).st_mtime
    except OSError:  # gone since (renamed by its recorder)
        return None


def partial_files(path: str | os.PathLike[str]) -> list[str]:
    """The ``.NAME.*.partial`` files an unfinished recorder writes beside ``NAME``, newest first."""
    p = os.fspath(path)
    folder, name = os.path.split(p)
    pattern = os.path.join(glob.escape(folder or "."), f".{glob.escape(name)}.*.partial")
    found = [(t, f) for f in glob.glob(pattern) if (t := _mtime(f)) is not None]
    return [f for _, f in sorted(found, reverse=True)]


def live_partial(path: str | os.PathLike[str], idle_timeout_s: float | None = None) -> str | None:
    """The partial file (:func:`partial_files`) to follow for the recording ``path``, or None
    to follow ``path`` itself (or to wait for either to appear).

    Without a complete ``path``, the newest partial file (even one whose recorder died: what it
    holds is read). Beside a complete ``path``, the newest partial file only if a recorder is
    writing it: it changed after ``path`` did (a new take being recorded over it) and, with
    ``idle_timeout_s``, within that many seconds; else it is left from a recorder that died,
    and ``path`` is what was recorded.
    """
    partials = partial_files(path)
    if not partials:
        return None
    done = _mtime(os.fspath(path))
    if done is None:
        return partials[0]
    newest = _mtime(partials[0])
    if newest is None or newest < done:
        return None
    if idle_timeout_s is not None and time.time() - newest > idle_timeout_s:
        return None
    return partials[0]


class Follower:
    """A recording being followed: iterate it for its :class:`LiveMessage` s.

    Made by :func:`follow` (same parameters). After (or during) iteration:

    Attributes
    ----------
    path : str
        The recording asked for.
    source : str or None
        The file actually read (``path`` or its ``.partial`` file), once one appeared.
    metadata : dict of str -> dict
        The metadata records read so far (``demo``: objects, hand side, task ...).
    topics : dict of int -> str
        Channel id -> topic, as the channels appeared.
    complete : bool
        The end marker was reached.
    stop_reason : str or None
        ``"end"``, ``"idle"`` (stopped growing), ``"damaged"`` (a damaged record: what came
        before it is kept, as offline), ``"interrupted"`` (Ctrl+C), ``"stopped"``
        (:meth:`stop`), None while following.
    message_count, bytes_read : int
        Progress so far.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        poll_s: float = 0.05,
        idle_timeout_s: float | None = 10.0,
        start_timeout_s: float | None = 30.0,
        images: bool = False,
    ) -> None:
        self.path = os.fspath(path)
        self.poll_s = float(poll_s)
        self.idle_timeout_s = idle_timeout_s
        self.start_timeout_s = start_timeout_s
        self.images = images
        self.source: str | None = None
        self.metadata: dict[str, dict[str, str]] = {}
        self.topics: dict[int, str] = {}
        self.complete = False
        self.stop_reason: str | None = None
        self.message_count = 0
        self.bytes_read = 0
        self._stop = threading.Event()
        self._started = False
        self._channels: dict[int, Channel] = {}
        self._kinds: dict[str, tuple[str, str]] = {}  # topic -> its (schema, encoding)
        self._size = -1  # the file's size when last looked at
        self._tail = b""  # the last bytes read, ending at offset self._tail_end
        self._tail_end = 0

    # --- public ----------------------------------------------------------------------------
    def stop(self) -> None:
        """Ask the iteration to end at its next wait (thread-safe)."""
        self._stop.set()

    @property
    def objects(self) -> list[tuple[str, int, list[float] | None]]:
        """``(name, tag_id, size)`` of the objects declared so far, read as
        :func:`lfd.load` reads them (:func:`lfd.io.reader.objects_of`: the ``demo`` metadata,
        else the pose channels' metadata; malformed values raise
        :class:`~lfd.errors.RecordingFormatError`)."""
        from .mcapfile import ChannelSummary, Records
        from .reader import objects_of

        seen = Records()
        seen.path = self.source or self.path
        seen.metadata = self.metadata
        seen.channels = {
            ch.topic: ChannelSummary(ch.topic, "", ch.message_encoding, dict(ch.metadata))
            for ch in self._channels.values()
        }
        return objects_of(seen)

    @property
    def hand_side(self) -> str:
        """The hand side the ``demo`` metadata names, else that of the hand topic seen so far
        (right before left, as :func:`lfd.load`), else ``right``."""
        named = self.metadata.get(T.DEMO_METADATA, {}).get("hand_side")
        if named in T.HAND_SIDES:
            return str(named)
        seen = {T.hand_side_from_topic(t) for t in self.topics.values()}
        return next((s for s in T.HAND_SIDES if s in seen), "right")

    @property
    def sides(self) -> tuple[str, ...]:
        """The sides of the hands the ``demo`` metadata names (``hands``, else ``hand_side``),
        else those of the hand topics seen so far, right first (a hand not yet seen may be
        missing)."""
        record = self.metadata.get(T.DEMO_METADATA, {})
        try:
            named = json.loads(record["hands"]) if "hands" in record else [record["hand_side"]]
        except (KeyError, ValueError, TypeError):
            named = []
        if isinstance(named, list) and named and all(n in T.HAND_SIDES for n in named):
            return tuple(s for s in T.HAND_SIDES if s in named)
        seen = {T.hand_side_from_topic(t) for t in self.topics.values()}
        return tuple(s for s in T.HAND_SIDES if s in seen)

    @property
    def demo_metadata(self) -> dict[str, Any]:
        """The recording's metadata as :func:`lfd.load` gives it (``demo.metadata``), from the
        ``demo`` metadata record read so far; empty before it or when it is not a JSON object."""
        text = self.metadata.get(T.DEMO_METADATA, {}).get("metadata")
        try:
            value = json.loads(text) if text is not None else {}
        except ValueError:
            return {}
        return value if isinstance(value, dict) else {}

    def __iter__(self) -> Iterator[LiveMessage]:
        if self._started:
            raise RuntimeError("a Follower can be iterated once")
        self._started = True
        try:
            f = self._open()
            if f is None:
                return
            with f:
                yield from self._messages(f)
        except KeyboardInterrupt:
            self.stop_reason = "interrupted"

    # --- waiting -----------------------------------------------------------------------------
    def _wait(self) -> bool:
        """Sleep one poll interval; False when asked to stop."""
        if self._stop.wait(self.poll_s):
            self.stop_reason = "stopped"
            return False
        return True

    def _open(self) -> IO[bytes] | None:
        """Open the file to follow once it (or its ``.partial``) exists."""
        t0 = time.monotonic()
        while True:
            candidate = live_partial(self.path, self.idle_timeout_s)
            if candidate is None and os.path.exists(self.path):
                candidate = self.path
            if candidate is not None:
                check_input_file(candidate, "recording", RecordingFormatError)
                try:
                    f = open(candidate, "rb")
                except FileNotFoundError:  # renamed between the look and the open: look again
                    continue
                except OSError as err:
                    raise RecordingFormatError(f"cannot open recording {candidate}: {err}") from err
                self.source = candidate
                return f
            waited = time.monotonic() - t0
            if self.start_timeout_s is not None and waited >= self.start_timeout_s:
                raise RecordingFormatError(
                    f"no recording {self.path} (nor a .{os.path.basename(self.path)}.*.partial "
                    f"file of a recorder writing it) appeared within {self.start_timeout_s:g} s"
                )
            if not self._wait():
                return None

    def _read(self, f: IO[bytes], n: int) -> bytes | None:
        """Exactly ``n`` bytes from the current position, waiting for them to be written.

        None when following ends first (idle timeout, stop); the position is then unchanged.
        """
        start = f.tell()
        last_size = -1
        idle_since = time.monotonic()
        while True:
            size = os.fstat(f.fileno()).st_size
            if size != self._size:
                self._size = size
                self._check_unchanged(f, start, size)
            if size - start >= n:
                f.seek(start)
                data = f.read(n)
                if len(data) == n:
                    self.bytes_read = start + n
                    kept = self._tail if self._tail_end == start else b""
                    self._tail = (kept + data[-TAIL_CHECKED:])[-TAIL_CHECKED:]
                    self._tail_end = start + n
                    return data
            if size != last_size:
                last_size, idle_since = size, time.monotonic()
            elif (
                self.idle_timeout_s is not None
                and time.monotonic() - idle_since >= self.idle_timeout_s
            ):
                self.stop_reason = "idle"
                warnings.warn(
                    f"{self.source}: {STOPPED_GROWING} for {self.idle_timeout_s:g} s (the "
                    f"writer stopped or died); read {self.message_count} messages, "
                    f"{start} of its {size} bytes",
                    RecoveredFileWarning,
                    stacklevel=4,
                )
                return None
            if not self._wait():
                return None

    def _check_unchanged(self, f: IO[bytes], start: int, size: int) -> None:
        """Refuse a file shorter than the ``start`` bytes already read, or whose last bytes read
        changed: it was truncated or rewritten while followed, and what was read is gone."""
        where = self.source or self.path
        if size < start:
            raise RecordingFormatError(
                f"{where} was truncated or replaced while followed: it has {size} bytes now, "
                f"{start} were already read ({self.message_count} messages); refusing to go on "
                "with data no longer in the file"
            )
        if not self._tail or self._tail_end > size:
            return
        f.seek(self._tail_end - len(self._tail))
        again = f.read(len(self._tail))
        f.seek(start)
        if again != self._tail:
            raise RecordingFormatError(
                f"{where} was replaced while followed: the bytes already read (up to byte "
                f"{self._tail_end}) changed; refusing to go on with data no longer in the file"
            )

    # --- records -------------------------------------------------------------------------------
    def _messages(self, f: IO[bytes]) -> Iterator[LiveMessage]:
        head = self._read(f, len(MAGIC))
        if head is None:
            return
        if head != MAGIC:
            raise RecordingFormatError(f"{self.source} is not an MCAP file (bad magic {head!r})")
        schemas: dict[int, Schema] = {}
        channels = self._channels
        inflated = 0
        while True:
            header = self._read(f, 9)
            if header is None:
                return
            at = f.tell() - 9
            length = int.from_bytes(header[1:], "little")
            if length > RECORD_SIZE_LIMIT:
                self._damaged(at, f"a record declares {length} bytes")
                return
            body = self._read(f, length)
            if body is None:
                f.seek(at)
                return
            try:
                record = _parse(header + body)
                if isinstance(record, Chunk):
                    budget = inflate_limit(f.tell()) - inflated
                    chunk = _inflate(record, self.source or self.path, budget)
                    inflated += chunk.uncompressed_size
                    inner = list(breakup_chunk(chunk, validate_crc=True))
                else:
                    inner = [record]
            except RecordingFormatError:  # a decompression bomb: refused, as offline
                raise
            except Exception as err:  # damage: what the offline reader (scan) recovers from
                self._damaged(at, f"{type(err).__name__}: {err}")
                return
            for rec in inner:
                if isinstance(rec, Message):
                    ch = channels.get(rec.channel_id)
                    if ch is None:
                        continue
                    if rec.log_time > INT64_MAX:
                        raise RecordingFormatError(
                            f"{self.source}: a message on {ch.topic} has log_time "
                            f"{rec.log_time} ns, beyond 2**63 - 1"
                        )
                    self.message_count += 1
                    yield self._decode(ch.topic, rec.log_time, rec.data)
                elif isinstance(rec, Schema):
                    schemas[rec.id] = rec
                elif isinstance(rec, Channel):
                    if rec.id not in channels:
                        schema = schemas.get(rec.schema_id)
                        kind = (schema.name if schema is not None else "", rec.message_encoding)
                        first = self._kinds.setdefault(rec.topic, kind)
                        if first != kind and T.decoded_topic(rec.topic):
                            where = self.source or self.path
                            raise RecordingFormatError(
                                T.two_types_message(str(where), rec.topic, first, kind)
                            )
                    channels.setdefault(rec.id, rec)
                    self.topics.setdefault(rec.id, rec.topic)
                elif isinstance(rec, Metadata):
                    self.metadata.setdefault(rec.name, {}).update(rec.metadata)
                elif isinstance(rec, (DataEnd, Footer)):
                    self.complete = True
                    self.stop_reason = "end"
                    return

    def _damaged(self, at: int, error: str) -> None:
        """Stop at a damaged record, as :func:`lfd.io.mcapfile.scan` does offline: what came
        before it is kept, with a :class:`~lfd.errors.RecoveredFileWarning`."""
        self.stop_reason = "damaged"
        detail = " ".join(error.split())[:200]
        warnings.warn(
            f"{self.source}: incomplete or damaged record at byte {at} ({detail}); read "
            f"{self.message_count} messages before it; anything after it is lost",
            RecoveredFileWarning,
            stacklevel=4,
        )

    def _decode(self, topic: str, t_ns: int, data: bytes) -> LiveMessage:
        kind, value = decode_message(topic, t_ns, data, self.source or self.path, self.images)
        side = None
        if kind in ("hand", "confidence"):
            side = T.hand_topic_side(topic)
        elif kind == "label":
            side = value.hand
        return LiveMessage(
            topic=topic, t_ns=int(t_ns), kind=kind, value=value, data=data, side=side
        )


def _parse(raw: bytes) -> Any:
    """The one record ``raw`` holds (opcode, length, body); the reader's error if damaged."""
    reader = StreamReader(io.BytesIO(raw), skip_magic=True, emit_chunks=True)
    return next(iter(reader.records))


def decode_message(
    topic: str, t_ns: int, data: bytes, path: str = "", images: bool = False
) -> tuple[str, Any]:
    """``(kind, value)`` of one message of an lfd recording (see :class:`LiveMessage`).

    Raises
    ------
    RecordingFormatError
        The payload does not decode as its topic's schema.
    """
    from foxglove_schemas_protobuf.CameraCalibration_pb2 import CameraCalibration
    from foxglove_schemas_protobuf.CompressedImage_pb2 import CompressedImage
    from foxglove_schemas_protobuf.Event_pb2 import Event
    from foxglove_schemas_protobuf.FrameTransforms_pb2 import FrameTransforms
    from foxglove_schemas_protobuf.PoseInFrame_pb2 import PoseInFrame
    from foxglove_schemas_protobuf.PosesInFrame_pb2 import PosesInFrame
    from foxglove_schemas_protobuf.RawImage_pb2 import RawImage
    from google.protobuf.message import DecodeError

    from .hands import handovers_of_events
    from .reader import _confidence, label_of_event

    where = f"{path}: {topic} at {t_ns} ns"

    def parse(cls: Any) -> Any:
        msg = cls()
        try:
            msg.ParseFromString(data)
        except DecodeError as err:
            raise RecordingFormatError(
                f"{where}: cannot decode a {cls.DESCRIPTOR.full_name}: {err}"
            ) from err
        return msg

    if T.hand_side_from_topic(topic) is not None:
        m = parse(PosesInFrame)
        if len(m.poses) != 21:
            raise RecordingFormatError(f"{where}: {len(m.poses)} poses, not 21")
        return "hand", np.array([(p.position.x, p.position.y, p.position.z) for p in m.poses])
    if topic in (T.confidence_topic(s) for s in T.HAND_SIDES):
        conf, vis = _confidence(data, where)
        return "confidence", (
            np.array(conf, dtype=np.float64),
            None if vis is None else np.array(vis, dtype=bool),
        )
    name = T.object_name_from_topic(topic)
    if name is not None:
        m = parse(PoseInFrame)
        p, q = m.pose.position, m.pose.orientation
        return "object", ObjectPose(name, np.array([p.x, p.y, p.z]), np.array([q.x, q.y, q.z, q.w]))
    if topic == T.GROUND_TRUTH_TOPIC:
        return "label", label_of_event(parse(Event), f"{where}: ")
    if topic == T.HANDOVERS_TOPIC:
        return "handover", handovers_of_events([parse(Event)], where)[0]
    if topic == T.TF_TOPIC:
        return "tf", parse(FrameTransforms)
    if topic == T.CAMERA_INFO_TOPIC:
        return "camera_info", parse(CameraCalibration)
    for kind, base in (("color", T.COLOR_TOPIC), ("depth", T.DEPTH_TOPIC)):
        if topic in (base, T.compressed_topic(base)):
            if not images:
                return kind, None
            from .images import decode_compressed, decode_raw

            try:
                if topic == base:
                    return kind, decode_raw(parse(RawImage))
                m = parse(CompressedImage)
                return kind, decode_compressed(m.data, m.format)
            except ValueError as err:
                raise RecordingFormatError(f"{where}: {err}") from err
    return "other", None


def follow(
    path: str | os.PathLike[str],
    *,
    poll_s: float = 0.05,
    idle_timeout_s: float | None = 10.0,
    start_timeout_s: float | None = 30.0,
    images: bool = False,
) -> Follower:
    """Follow a recording another process is writing (or has written).

    Parameters
    ----------
    path : path
        The recording, ``NAME.mcap``: its ``.NAME.mcap.*.partial`` file while a recorder writes
        it (the newest one; :func:`live_partial`), else the file itself. A ``.partial`` path is
        followed as given.
    poll_s : float
        How often to look for new bytes, seconds.
    idle_timeout_s : float or None
        Stop, with a :class:`~lfd.errors.RecoveredFileWarning`, when the file has not grown
        for this long without its end marker. None waits forever (until Ctrl+C or
        :meth:`Follower.stop`).
    start_timeout_s : float or None
        How long to wait for the file to appear.
    images : bool
        Decode colour and depth frames (else their messages carry ``value=None``).

    Returns
    -------
    Follower
        Iterate it for the messages; it also tells why following stopped.

    Raises
    ------
    RecordingFormatError
        (while iterating) no file appeared in time, the file is not MCAP or not a regular
        file, a message's payload does not decode, a chunk is a decompression bomb, or the file
        was truncated or rewritten in place while followed (shorter than what was read, or the
        bytes read changed). (A
        damaged record ends following with a warning instead, see above.)
    """
    return Follower(
        path,
        poll_s=poll_s,
        idle_timeout_s=idle_timeout_s,
        start_timeout_s=start_timeout_s,
        images=images,
    )
