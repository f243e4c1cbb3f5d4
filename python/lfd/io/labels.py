"""Ground-truth skill labels: read them from a user's file, write them into a recording.

A label file is one of

* the JSON that ``lfd segment REC --json OUT`` writes (edit it to correct the segmentation): an
  object whose ``segments`` list holds ``{"skill", "start_s", "end_s", "object"}`` entries
  (other keys, e.g. ``score`` or ``start_ns``, are ignored);
* a JSON list of such entries;
* a CSV file with the columns ``skill,start_s,end_s,object,hand`` (a header line naming them is
  optional; ``object`` and ``hand`` may be empty or missing; lines starting with ``#`` are
  comments);
* for a two-hand recording, the JSON of a two-hand ``lfd segment --json``:
  ``{"hands": {"right": <one-hand report>, "left": <one-hand report>}, "handovers": [...]}``
  (each lane's segments are its hand's labels, each with its own ``origin_ns``).

A label gives both its times in seconds (``start_s``, ``end_s``) or both in absolute nanoseconds
(``start_ns``, ``end_ns``; seconds win when an entry has both pairs, as ``lfd segment --json``
writes them); one of each (``start_ns`` with ``end_s``) or a start without its end is refused.
A file holds at most :data:`MAX_LABELS` labels and handovers together (a CSV is not read past
them); a UTF-8 byte order mark (as Excel writes a CSV) is skipped (:func:`lfd.inputs.read_text`).

Each entry may name its ``hand`` (``right`` or ``left``); in a two-hand recording every label
must, and a label for a hand the recording lacks is refused. Handovers (two-hand recordings) are
a ``handovers`` list beside ``segments`` or ``hands``: ``{"giver", "taker", "object", "start_s",
"end_s"}`` (or absolute ``start_ns``, ``end_ns``, as ``lfd segment --json`` writes them); every
key is required (the object too: the task program finds the giver's place and the taker's
pick_up by it).

Times are seconds from an origin: the ``origin_ns`` key of a segmentation JSON (the first
resampled sample, where ``lfd segment`` counts from), else the **recording start**, the earliest
hand keypoint or object pose sample (:attr:`lfd.demo.Demonstration.start_ns`; ``lfd info``
shows the recording's streams). The labels must lie within the recording (from its start to
its last sample, :attr:`~lfd.demo.Demonstration.end_ns`, plus :data:`END_TOLERANCE_NS`), must
not overlap (one may start where the previous ends), must name canonical skills
(:data:`lfd.skills.SKILLS`) and objects the recording has (or none). Overlaps are checked per
hand: the two hands' lanes run side by side.

:func:`write_labels` copies every message of a recording unchanged (same channels, schemas,
metadata records, attachments, log and publish times, bytes) except the ground truth on
``/lfd/ground_truth``, which it replaces (and the handovers on ``/lfd/ground_truth/handovers``
when new ones are given); the result is written atomically.
"""

from __future__ import annotations

import csv
import io
import itertools
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ..demo import HAND_SIDES, Demonstration, Handover, SkillLabel
from ..errors import LfdError, RecordingFormatError, UsageError
from ..inputs import END_TOLERANCE_NS, MAX_SECONDS, seconds, shown
from ..skills import check_skill
from . import messages as M
from . import topics as T
from .summary import LABEL_BYTES

__all__ = [
    "END_TOLERANCE_NS",
    "MAX_LABELS",
    "MAX_SECONDS",
    "read_annotations",
    "read_labels",
    "seconds",
    "write_labels",
]

CSV_COLUMNS = ("skill", "start_s", "end_s", "object", "hand")

LABEL_MESSAGE_BYTES = 1024
"""Most bytes one label's (or handover's) message takes on its channel: two times, the skill
(or giver and taker), the hand and an object name of
:data:`~lfd.io.writer.MAX_OBJECT_NAME` characters of up to 4 UTF-8 bytes each, with their
protobuf framing (under 900 bytes; a test checks it)."""

MAX_LABELS = LABEL_BYTES // LABEL_MESSAGE_BYTES // 2
"""Most labels and handovers (together) a label file may give: 32768, hours of skills a second
long. Their messages fill at most half of :data:`lfd.io.summary.LABEL_BYTES`, what ``lfd info``
reads of a recording's label channels (the other half is left to the live segments a recording
may hold), so a labelled recording stays readable; a bigger file is refused before its labels are
built (2.7 million rows took 6 GB and minutes)."""


def _count(n: int, where: str) -> None:
    """Refuse ``n`` labels and handovers of one file if they are more than :data:`MAX_LABELS`."""
    if n > MAX_LABELS:
        raise UsageError(
            f"{where}: more than {MAX_LABELS} labels and handovers, the most a label file may give"
        )


Entry = tuple[dict[str, Any], int | None]
"""One label or handover of a file and the origin (ns) its seconds count from (None: the
recording's start)."""


def _origin(doc: dict[str, Any], where: str) -> int | None:
    o = doc.get("origin_ns")
    if o is None:
        return None
    if isinstance(o, bool) or not isinstance(o, int) or not -(2**63) <= o < 2**63:
        raise UsageError(f"{where}: origin_ns must be integer nanoseconds (64-bit), got {shown(o)}")
    return o


def _objects(doc: Any, where: str, what: str = "label") -> list[dict[str, Any]]:
    if not isinstance(doc, list):
        raise UsageError(f"{where}: expected a list of {what}s, got {type(doc).__name__}")
    for i, e in enumerate(doc):
        if not isinstance(e, dict):
            raise UsageError(f"{where}: {what} {i} must be a JSON object, got {e!r}"[:200])
    return doc


def _lanes_from_json(doc: dict[str, Any], where: str) -> list[Entry]:
    """The labels of a two-hand report, ``{"hands": {side: one-hand report}}``."""
    lanes = doc["hands"]
    if not isinstance(lanes, dict) or not lanes:
        raise UsageError(f"{where}: hands must be an object {{side: report}}, got {shown(lanes)}")
    entries: list[Entry] = []
    for side, report in lanes.items():
        at = f"{where}: hands.{side}"
        if side not in HAND_SIDES:
            raise UsageError(f"{at}: a hand is one of {', '.join(HAND_SIDES)}")
        if not isinstance(report, dict) or "segments" not in report:
            raise UsageError(f"{at} must be a one-hand report with a 'segments' list")
        origin = _origin(report, at)
        for e in _objects(report["segments"], at):
            if e.get("hand") not in (None, "", side):
                raise UsageError(f"{at}: a segment names the {e['hand']!r} hand")
            entries.append(({**e, "hand": side}, origin))
    return entries


def _nanoseconds(value: Any, where: str, key: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not -(2**63) <= value < 2**63:
        raise UsageError(f"{where}: {key} must be integer nanoseconds (64-bit), got {shown(value)}")
    return value


def _entries_from_json(doc: Any, where: str) -> tuple[list[Entry], list[Entry] | None]:
    """The label entries and, when the file gives them, the handover entries."""
    if not isinstance(doc, dict):
        return [(e, None) for e in _objects(doc, where)], None
    if "segments" not in doc and "hands" not in doc:
        raise UsageError(
            f"{where}: a JSON object must have a 'segments' list (as `lfd segment --json` "
            "writes) or 'hands' (a two-hand report), or give a JSON list of "
            "{skill, start_s, end_s, object, hand}"
        )
    origin = _origin(doc, where)
    if "hands" in doc:
        entries = _lanes_from_json(doc, where)
    else:
        entries = [(e, origin) for e in _objects(doc["segments"], where)]
    handovers = None
    if "handovers" in doc:
        handovers = [(e, origin) for e in _objects(doc["handovers"], where, "handover")]
    return entries, handovers


def _entries_from_csv(text: str, where: str) -> list[dict[str, Any]]:
    """The rows of a label CSV as entries, read no further than :data:`MAX_LABELS` of them."""
    reader = csv.reader(io.StringIO(text))
    header: list[str] | None = None
    out: list[dict[str, Any]] = []
    try:
        for r in reader:
            if not r or not any(c.strip() for c in r) or r[0].lstrip().startswith("#"):
                continue
            if header is None:
                header = _csv_header(r, where)
                if header is not None:
                    continue
                header = list(CSV_COLUMNS)
            if not 3 <= len(r) <= len(header):
                raise UsageError(
                    f"{where}: row {len(out) + 1} has {len(r)} fields; expected {','.join(header)}"
                )
            out.append({k: v.strip() for k, v in zip(header, r, strict=False)})
            _count(len(out), where)
    except csv.Error as err:  # a field longer than csv.field_size_limit(), ...
        raise UsageError(f"{where}: line {reader.line_num} is not CSV: {err}") from None
    return out


def _csv_header(row: list[str], where: str) -> list[str] | None:
    """The columns a CSV's first row names, None when it is a label (no header line)."""
    if row[0].strip() != "skill":
        return None
    header = [c.strip() for c in row]
    unknown = [c for c in header if c not in CSV_COLUMNS]
    if unknown or not {"skill", "start_s", "end_s"} <= set(header):
        raise UsageError(
            f"{where}: header {','.join(header)} must name the columns "
            f"{','.join(CSV_COLUMNS)} (object optional)"
        )
    twice = sorted({c for c in header if header.count(c) > 1})
    if twice:
        raise UsageError(f"{where}: header {','.join(header)} names {', '.join(twice)} twice")
    return header


def _read_entries(path: Path) -> tuple[list[Entry], list[Entry] | None]:
    from ..inputs import parse_json, read_text

    try:
        text = read_text(path, "--from", not_text="is not a label file (binary, not UTF-8 text)")
    except OSError as err:
        raise UsageError(f"cannot read label file {path}: {err.strerror or err}") from None
    if path.suffix.lower() == ".csv":
        return [(e, None) for e in _entries_from_csv(text, str(path))], None
    what = "JSON" if path.suffix.lower() == ".json" else "JSON (or give a .csv file)"
    doc = parse_json(text, f"{path} is not valid {what}")
    entries, handovers = _entries_from_json(doc, str(path))
    _count(len(entries) + len(handovers or ()), str(path))
    return entries, handovers


def _in_nanoseconds(e: dict[str, Any], where: str, needs: str) -> bool:
    """Whether entry ``e`` gives its times in nanoseconds (``start_ns``, ``end_ns``) rather than
    seconds (``start_s``, ``end_s``, which win when both pairs are whole); anything else (one time
    of each, a start without its end) is refused, naming what is missing."""
    if "start_s" in e and "end_s" in e:
        return False
    if "start_ns" in e and "end_ns" in e:
        return True
    start = next((k for k in ("start_s", "start_ns") if k in e), None)
    end = next((k for k in ("end_s", "end_ns") if k in e), None)
    if start is not None and end is not None:
        problem = f"it mixes {start} with {end}"
    elif start is not None:
        problem = f"it has {start} but no {start.replace('start', 'end')}"
    elif end is not None:
        problem = f"it has {end} but no {end.replace('end', 'start')}"
    else:
        problem = "it gives no times"
    raise UsageError(
        f"{where} needs {needs} (or start_ns and end_ns: both times in one unit); {problem}"
    )


class _Span:
    """Where a file's seconds land on the recording's clock, and the checks of a span."""

    def __init__(self, path: Path, demo: Demonstration) -> None:
        self.path, self.start, self.end = path, demo.start_ns, demo.end_ns

    def origin(self, origin: int | None) -> int:
        return self.start if origin is None else origin

    def __call__(
        self, e: dict[str, Any], origin: int | None, where: str, name: str, needs: str
    ) -> tuple[int, int]:
        """The span of entry ``e`` in recording nanoseconds (``start_s``/``end_s`` from its
        origin, or absolute ``start_ns``/``end_ns``), checked to lie in the recording; an entry
        without both times in one unit is refused: ``f"{where} needs {needs} ..."``."""
        t0 = self.origin(origin)
        if _in_nanoseconds(e, where, needs):
            a, b = (_nanoseconds(e[k], where, k) for k in ("start_ns", "end_ns"))
            s, f = (a - t0) * 1e-9, (b - t0) * 1e-9
        else:
            s, f = seconds(e["start_s"], where, "start_s"), seconds(e["end_s"], where, "end_s")
            a, b = t0 + round(s * 1e9), t0 + round(f * 1e9)
        what = f"{where} ({name} {s:.3f}-{f:.3f} s)"
        span = f"0-{(self.end - t0) * 1e-9:.3f} s" if origin is None else "the recording"
        if b <= a:
            raise UsageError(f"{what}: ends before it starts (or is empty)")
        if a < self.start:
            raise UsageError(f"{what}: starts before the recording (it spans {span})")
        if b > self.end + END_TOLERANCE_NS:
            raise UsageError(f"{what}: ends after the recording (it spans {span})")
        return a, min(b, self.end + END_TOLERANCE_NS)


def _side(value: Any, where: str, demo: Demonstration, key: str = "hand") -> str | None:
    """The hand an entry names, checked against the recording's hands (None: the only one)."""
    side = None if value in (None, "", "-") else str(value).strip()
    have = " and ".join(demo.sides)
    if side is None:
        if len(demo.sides) > 1:
            raise UsageError(
                f"{where} names no {key}, and the recording has two ({have}): give its hand"
            )
        return None
    if side not in HAND_SIDES:
        raise UsageError(f"{where}: {key} {shown(side)} is not a hand ({', '.join(HAND_SIDES)})")
    if side not in demo.sides:
        raise UsageError(
            f"{where} is for the {side} hand, which the recording lacks (it has the {have} hand)"
        )
    return side if len(demo.sides) > 1 else None  # a one-hand file's labels name no hand


def _object(value: Any, where: str, demo: Demonstration) -> str | None:
    obj = None if value in (None, "", "-") else str(value)
    if obj is not None and obj not in demo.objects:
        raise UsageError(
            f"{where}: unknown object {obj!r}; the recording has "
            f"{', '.join(demo.objects) or 'no objects'}"
        )
    return obj


def _label(
    e: dict[str, Any], origin: int | None, where: str, span: _Span, demo: Demonstration
) -> SkillLabel:
    if "skill" not in e:
        raise UsageError(f"{where} needs skill, start_s and end_s, got {e!r}"[:200])
    skill = str(e["skill"]).strip()
    try:
        check_skill(skill)
    except LfdError as err:
        raise type(err)(f"{where}: {err}") from None
    obj = _object(e.get("object"), f"{where} ({skill})", demo)
    hand = _side(e.get("hand"), f"{where} ({skill})", demo)
    a, b = span(e, origin, where, skill, "skill, start_s and end_s")
    return SkillLabel(skill, a, b, obj, hand)


def _handover(
    e: dict[str, Any], origin: int | None, where: str, span: _Span, demo: Demonstration
) -> Handover:
    if len(demo.sides) < 2:
        raise UsageError(f"{where}: a handover needs two hands; the recording has one")
    for key in ("giver", "taker"):
        if key not in e:
            raise UsageError(f"{where} needs giver, taker, start_s and end_s, got {e!r}"[:200])
    giver = _side(e["giver"], where, demo, "giver")
    taker = _side(e["taker"], where, demo, "taker")
    if giver == taker:
        raise UsageError(f"{where}: the {giver} hand cannot give to itself")
    obj = _object(e.get("object"), where, demo)
    if obj is None:  # the giver's place and the taker's pick_up are found by their object
        raise UsageError(
            f"{where} ({giver} to {taker}) names no object; give the object handed over "
            f"(one of {', '.join(demo.objects) or 'none'})"
        )
    a, b = span(e, origin, where, f"{giver} to {taker}", "giver, taker, start_s and end_s")
    assert giver is not None and taker is not None
    return Handover(a, b, giver, taker, obj)


def read_annotations(
    path: str | os.PathLike[str], demo: Demonstration
) -> tuple[list[SkillLabel], list[Handover] | None]:
    """Read and check the labels and handovers of ``path`` for the recording ``demo``
    (:func:`read_labels`; the handovers are None when the file gives none: a recording's own
    are then kept)."""
    p = Path(path)
    entries, handover_entries = _read_entries(p)
    if not entries:
        raise UsageError(f"{p}: no labels")
    span = _Span(p, demo)
    labels = [_label(e, o, f"{p}: label {i}", span, demo) for i, (e, o) in enumerate(entries)]
    labels.sort(key=lambda lab: (lab.start_ns, lab.end_ns))
    for side in demo.sides:
        lane = [lab for lab in labels if lab.hand in (side, None)]
        for x, y in itertools.pairwise(lane):
            if y.start_ns < x.end_ns:
                t0 = span.origin(next((o for _, o in entries), None))
                hand = f" of the {side} hand" if len(demo.sides) > 1 else ""
                raise UsageError(
                    f"{p}: labels{hand} overlap: {x.skill} {(x.start_ns - t0) * 1e-9:.3f}-"
                    f"{(x.end_ns - t0) * 1e-9:.3f} s and {y.skill} from "
                    f"{(y.start_ns - t0) * 1e-9:.3f} s; a label may start where the previous "
                    "one ends"
                )
    if handover_entries is None:
        return labels, None
    handovers = [
        _handover(e, o, f"{p}: handover {i}", span, demo)
        for i, (e, o) in enumerate(handover_entries)
    ]
    return labels, sorted(handovers, key=lambda h: (h.start_ns, h.end_ns))


def read_labels(path: str | os.PathLike[str], demo: Demonstration) -> list[SkillLabel]:
    """Read and check the labels of ``path`` for the recording ``demo``.

    Parameters
    ----------
    path : path-like
        A ``.json`` (``lfd segment --json`` output, one hand or two, or a list of entries) or
        ``.csv`` label file, see the module documentation.
    demo : Demonstration
        The recording the labels are for (its start, end, hands and objects).

    Returns
    -------
    list of SkillLabel
        In time order, absolute times (ns, the recording's clock); each names its hand in a
        two-hand recording (None in a one-hand one).

    Raises
    ------
    UsageError
        Unreadable file, bad format, labels of one hand that overlap, start before the
        recording, end after it or before they start, name an object the recording does not
        have, a hand it lacks, or (two hands) no hand.
    UnknownSkillError
        A skill name that is not canonical.
    """
    return read_annotations(path, demo)[0]


def write_labels(
    recording: str | os.PathLike[str],
    labels: Sequence[SkillLabel],
    output: str | os.PathLike[str] | None = None,
    handovers: Sequence[Handover] | None = None,
) -> Path:
    """Copy ``recording`` to ``output`` (default: in place) with ``labels`` as its ground truth
    (and ``handovers``, when given, as its handovers; None keeps the recording's).

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
        gt_channel = ho_channel = None
        for cid, ch in sorted(summary.channels.items()):
            channels[cid] = writer.register_channel(
                ch.topic, ch.message_encoding, schemas.get(ch.schema_id, 0), dict(ch.metadata)
            )
            if ch.topic == T.GROUND_TRUTH_TOPIC:
                gt_channel = channels[cid]
            if ch.topic == T.HANDOVERS_TOPIC:
                ho_channel = channels[cid]
        for record in reader.iter_metadata():
            writer.add_metadata(record.name, dict(record.metadata))
        for att in reader.iter_attachments():
            writer.add_attachment(att.create_time, att.log_time, att.name, att.media_type, att.data)
        for _, channel, msg in reader.iter_messages(log_time_order=False):
            if channel.topic == T.GROUND_TRUTH_TOPIC or (
                channel.topic == T.HANDOVERS_TOPIC and handovers is not None
            ):
                continue
            writer.add_message(
                channels[msg.channel_id], msg.log_time, msg.data, msg.publish_time, msg.sequence
            )
        event_schema: list[int] = []

        def new_channel(topic: str) -> int:
            if not event_schema:
                fds = build_file_descriptor_set(Event).SerializeToString()
                event_schema.append(writer.register_schema(T.EVENT_SCHEMA, "protobuf", fds))
            return writer.register_channel(topic, "protobuf", event_schema[0], {})

        if labels and gt_channel is None:
            gt_channel = new_channel(T.GROUND_TRUTH_TOPIC)
        for lab in labels:
            assert gt_channel is not None
            data = M.event(lab).SerializeToString()
            writer.add_message(gt_channel, lab.start_ns, data, lab.start_ns, 0)
        if handovers and ho_channel is None:
            ho_channel = new_channel(T.HANDOVERS_TOPIC)
        for h in handovers or ():
            assert ho_channel is not None
            data = M.handover_event(h).SerializeToString()
            writer.add_message(ho_channel, h.start_ns, data, h.start_ns, 0)
        writer.finish()
        out.flush()
        os.fsync(out.fileno())
    return dest
