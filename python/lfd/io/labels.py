"""Ground-truth skill labels: read them from a user's file, write them into a recording.

A label file is one of

* the JSON that ``lfd segment REC --json OUT`` writes (edit it to correct the segmentation): an
  object whose ``segments`` list holds ``{"skill", "start_s", "end_s", "object"}`` entries
  (other keys, e.g. ``score`` or ``start_ns``, are ignored);
* a JSON list of such entries;
* a CSV file with the columns ``skill,start_s,end_s,object`` (a header line naming them is
  optional; ``object`` may be empty or missing; lines starting with ``#`` are comments).

Times are seconds from an origin: the ``origin_ns`` key of a segmentation JSON (the first
resampled sample, where ``lfd segment`` counts from), else the **recording start**, the earliest
hand keypoint or object pose sample (:attr:`lfd.demo.Demonstration.start_ns`; ``lfd info``
shows the recording's streams). The labels must lie within the recording (from its start to
its last sample, :attr:`~lfd.demo.Demonstration.end_ns`, plus :data:`END_TOLERANCE_NS`), must
not overlap (one may start where the previous ends), must name canonical skills
(:data:`lfd.skills.SKILLS`) and objects the recording has (or none).

:func:`write_labels` copies every message of a recording unchanged (same channels, schemas,
metadata records, attachments, log and publish times, bytes) except the ground truth on
``/lfd/ground_truth``, which it replaces; the result is written atomically.
"""

from __future__ import annotations

import csv
import io
import itertools
import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ..demo import Demonstration, SkillLabel
from ..errors import LfdError, RecordingFormatError, UsageError
from ..skills import check_skill
from . import messages as M
from . import topics as T

__all__ = ["END_TOLERANCE_NS", "read_labels", "write_labels"]

END_TOLERANCE_NS = 100_000_000
"""How far (ns) a label may end after the recording's last sample: 0.1 s, three samples at
30 Hz, since a segment ends where the next sample would start."""

CSV_COLUMNS = ("skill", "start_s", "end_s", "object")


MAX_SECONDS = 9e9
"""Largest time (s) a label may give, either sign: nanoseconds beyond it do not fit in the
signed 64-bit integers recordings count time in (2**63 ns is 9.2e9 s, 292 years)."""


def _shown(value: Any) -> str:
    """``repr(value)``, cut to 40 characters (a label file may hold a 5000-digit number)."""
    text = repr(value)
    return text if len(text) <= 40 else f"{text[:37]}..."


def _number(value: Any, where: str, key: str) -> float:
    if isinstance(value, bool) or value is None:
        raise UsageError(f"{where}: {key} must be a number of seconds, got {_shown(value)}")
    try:
        x = float(value)
    except (TypeError, ValueError, OverflowError):
        raise UsageError(
            f"{where}: {key} must be a number of seconds, got {_shown(value)}"
        ) from None
    if not math.isfinite(x):
        raise UsageError(f"{where}: {key} must be a finite number of seconds, got {_shown(value)}")
    if abs(x) > MAX_SECONDS:
        raise UsageError(
            f"{where}: {key} must be within +-{MAX_SECONDS:g} s of the recording, "
            f"got {_shown(value)}"
        )
    return x


def _entries_from_json(doc: Any, where: str) -> tuple[list[dict[str, Any]], int | None]:
    origin = None
    if isinstance(doc, dict):
        if "segments" not in doc:
            raise UsageError(
                f"{where}: a JSON object must have a 'segments' list (as `lfd segment --json` "
                "writes), or give a JSON list of {skill, start_s, end_s, object}"
            )
        if doc.get("origin_ns") is not None:
            o = doc["origin_ns"]
            if isinstance(o, bool) or not isinstance(o, int) or not -(2**63) <= o < 2**63:
                raise UsageError(
                    f"{where}: origin_ns must be integer nanoseconds (64-bit), got {_shown(o)}"
                )
            origin = o
        doc = doc["segments"]
    if not isinstance(doc, list):
        raise UsageError(f"{where}: expected a list of labels, got {type(doc).__name__}")
    for i, e in enumerate(doc):
        if not isinstance(e, dict):
            raise UsageError(f"{where}: label {i} must be a JSON object, got {e!r}"[:200])
    return doc, origin


def _entries_from_csv(text: str, where: str) -> list[dict[str, Any]]:
    rows = [
        r
        for r in csv.reader(io.StringIO(text))
        if r and any(c.strip() for c in r) and not r[0].lstrip().startswith("#")
    ]
    if rows and rows[0][0].strip() == "skill":
        header = [c.strip() for c in rows[0]]
        unknown = [c for c in header if c not in CSV_COLUMNS]
        if unknown or not {"skill", "start_s", "end_s"} <= set(header):
            raise UsageError(
                f"{where}: header {','.join(header)} must name the columns "
                f"{','.join(CSV_COLUMNS)} (object optional)"
            )
        rows = rows[1:]
    else:
        header = list(CSV_COLUMNS)
    out = []
    for n, r in enumerate(rows):
        if not 3 <= len(r) <= len(header):
            raise UsageError(
                f"{where}: row {n + 1} has {len(r)} fields; expected {','.join(header)}"
            )
        out.append({k: v.strip() for k, v in zip(header, r, strict=False)})
    return out


def _read_entries(path: Path) -> tuple[list[dict[str, Any]], int | None]:
    from ..inputs import parse_json, read_text

    try:
        text = read_text(path, "--from", not_text="is not a label file (binary, not UTF-8 text)")
    except OSError as err:
        raise UsageError(f"cannot read label file {path}: {err.strerror or err}") from None
    if path.suffix.lower() == ".csv":
        return _entries_from_csv(text, str(path)), None
    what = "JSON" if path.suffix.lower() == ".json" else "JSON (or give a .csv file)"
    doc = parse_json(text, f"{path} is not valid {what}")
    return _entries_from_json(doc, str(path))


def read_labels(path: str | os.PathLike[str], demo: Demonstration) -> list[SkillLabel]:
    """Read and check the labels of ``path`` for the recording ``demo``.

    Parameters
    ----------
    path : path-like
        A ``.json`` (``lfd segment --json`` output, or a list of entries) or ``.csv`` label file,
        see the module documentation.
    demo : Demonstration
        The recording the labels are for (its start, end and objects).

    Returns
    -------
    list of SkillLabel
        In time order, absolute times (ns, the recording's clock).

    Raises
    ------
    UsageError
        Unreadable file, bad format, labels that overlap, start before the recording, end after
        it or before they start, or name an object the recording does not have.
    UnknownSkillError
        A skill name that is not canonical.
    """
    p = Path(path)
    entries, origin = _read_entries(p)
    if not entries:
        raise UsageError(f"{p}: no labels")
    t0 = demo.start_ns if origin is None else origin
    start, end = demo.start_ns, demo.end_ns
    span = f"0-{(end - t0) * 1e-9:.3f} s" if origin is None else "the recording"
    labels = []
    for i, e in enumerate(entries):
        where = f"{p}: label {i}"
        if "skill" not in e or "start_s" not in e or "end_s" not in e:
            raise UsageError(f"{where} needs skill, start_s and end_s, got {e!r}"[:200])
        skill = str(e["skill"]).strip()
        try:
            check_skill(skill)
        except LfdError as err:
            raise type(err)(f"{where}: {err}") from None
        obj = e.get("object")
        obj = None if obj in (None, "", "-") else str(obj)
        if obj is not None and obj not in demo.objects:
            raise UsageError(
                f"{where} ({skill}): unknown object {obj!r}; the recording has "
                f"{', '.join(demo.objects) or 'no objects'}"
            )
        s, f = _number(e["start_s"], where, "start_s"), _number(e["end_s"], where, "end_s")
        what = f"{where} ({skill} {s:.3f}-{f:.3f} s)"
        if f <= s:
            raise UsageError(f"{what}: ends before it starts (or is empty)")
        a, b = t0 + round(s * 1e9), t0 + round(f * 1e9)
        if a < start:
            raise UsageError(f"{what}: starts before the recording (it spans {span})")
        if b > end + END_TOLERANCE_NS:
            raise UsageError(f"{what}: ends after the recording (it spans {span})")
        labels.append(SkillLabel(skill, a, min(b, end + END_TOLERANCE_NS), obj))
    labels.sort(key=lambda lab: (lab.start_ns, lab.end_ns))
    for x, y in itertools.pairwise(labels):
        if y.start_ns < x.end_ns:
            raise UsageError(
                f"{p}: labels overlap: {x.skill} {(x.start_ns - t0) * 1e-9:.3f}-"
                f"{(x.end_ns - t0) * 1e-9:.3f} s and {y.skill} from {(y.start_ns - t0) * 1e-9:.3f} s"
                "; a label may start where the previous one ends"
            )
    return labels


def write_labels(
    recording: str | os.PathLike[str],
    labels: Sequence[SkillLabel],
    output: str | os.PathLike[str] | None = None,
) -> Path:
    """Copy ``recording`` to ``output`` (default: in place) with ``labels`` as its ground truth.

    Every message, schema, channel, metadata record and attachment is copied unchanged; the
    messages on ``/lfd/ground_truth`` are replaced by ``labels`` (``log_time`` = label start,
    appended after the other messages, as :class:`lfd.io.McapRecorder` writes them). The file is
    written atomically: on any error the destination is left as it was.

    Raises
    ------
    RecordingFormatError
        The recording is incomplete (truncated, not closed) or cannot be read.
    """
    from foxglove_schemas_protobuf.Event_pb2 import Event
    from mcap.reader import make_reader
    from mcap.writer import CompressionType, Writer
    from mcap_protobuf.schema import build_file_descriptor_set

    from ..outputs import atomic_output
    from .mcapfile import scan

    src = Path(recording)
    raw = scan(src)  # refuses non-MCAP files and decompression bombs
    if not raw.complete:
        raise RecordingFormatError(
            f"{src} is incomplete ({raw.error}); recover it first (lfd info shows what is left)"
        )
    dest = Path(output) if output is not None else src
    with atomic_output(dest) as tmp, open(src, "rb") as f, open(tmp, "wb") as out:
        reader = make_reader(f)
        header = reader.get_header()
        writer = Writer(out, chunk_size=128 * 1024, compression=CompressionType.ZSTD)
        writer.start(profile=header.profile, library=header.library)
        schemas: dict[int, int] = {}
        channels: dict[int, int] = {}
        summary = reader.get_summary()
        if summary is None:
            raise RecordingFormatError(f"{src} has no summary section; cannot copy it")
        for sid, schema in sorted(summary.schemas.items()):
            schemas[sid] = writer.register_schema(schema.name, schema.encoding, schema.data)
        gt_channel = None
        for cid, ch in sorted(summary.channels.items()):
            channels[cid] = writer.register_channel(
                ch.topic, ch.message_encoding, schemas.get(ch.schema_id, 0), dict(ch.metadata)
            )
            if ch.topic == T.GROUND_TRUTH_TOPIC:
                gt_channel = channels[cid]
        for record in reader.iter_metadata():
            writer.add_metadata(record.name, dict(record.metadata))
        for att in reader.iter_attachments():
            writer.add_attachment(att.create_time, att.log_time, att.name, att.media_type, att.data)
        for _, channel, msg in reader.iter_messages(log_time_order=False):
            if channel.topic == T.GROUND_TRUTH_TOPIC:
                continue
            writer.add_message(
                channels[msg.channel_id], msg.log_time, msg.data, msg.publish_time, msg.sequence
            )
        if labels and gt_channel is None:
            fds = build_file_descriptor_set(Event).SerializeToString()
            sid = writer.register_schema(T.EVENT_SCHEMA, "protobuf", fds)
            gt_channel = writer.register_channel(T.GROUND_TRUTH_TOPIC, "protobuf", sid, {})
        for lab in labels:
            assert gt_channel is not None
            data = M.event(lab).SerializeToString()
            writer.add_message(gt_channel, lab.start_ns, data, lab.start_ns, 0)
        writer.finish()
        out.flush()
        os.fsync(out.fileno())
    return dest
