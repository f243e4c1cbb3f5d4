"""What a recording holds, for people and scripts (``lfd info``): channels, objects, labels."""

from __future__ import annotations

import os
import warnings
from collections.abc import Mapping, Sequence
from typing import Any

from ..demo import SkillLabel
from ..errors import LfdError, RecordingFormatError, RecoveredFileWarning
from . import topics as T
from .mcapfile import Records, read, read_summary
from .reader import (
    check_hand_clock,
    check_hand_topics,
    hand_side,
    is_ros_path,
    labels_of_events,
    load,
    objects_of,
    present_sides,
)

SMALL_TOPICS = (T.GROUND_TRUTH_TOPIC, T.LIVE_SEGMENTS_TOPIC, T.HANDOVERS_TOPIC)
"""The channels ``lfd info`` reads the messages of (the skill labels it prints)."""

LABEL_BYTES = 64 * 2**20
"""At most this many bytes of those channels' messages are read (a recording's labels take a
few KiB; the limit of the engine's ``read_summary`` too)."""


def summarise(
    path: str | os.PathLike[str],
    *,
    object_sizes: Mapping[str, Sequence[float]] | None = None,
    mapping: Any = None,
    check: bool = False,
) -> dict[str, Any]:
    """A JSON-ready summary of a recording: the document of ``lfd info --json``.

    An lfd MCAP file's channels (counts, times), metadata, attachments, objects (from the
    metadata and ``object_sizes``) and skill labels come from its summary section and the two
    label channels alone (:func:`lfd.io.mcapfile.read_summary`), whatever its length. A file
    without a summary (its writer was killed) is read whole with the damage rules of
    :func:`lfd.io.load`: ``source`` says which (``"summary"`` or ``"scan"``), ``damage`` what
    was lost: ``complete`` is true only when the data section ends properly and every chunk
    passes its CRC (each is inflated and checked, nothing kept), ``damaged_chunks`` lists the
    damaged ones (ordinals, messages lost when the message indexes say, else None) and
    ``damage`` says it in one line. ``check`` also loads the tracks (:func:`lfd.io.load`) for what segmenting will
    meet: ``objects[].travel_m`` (how far each object moves), ``hand_approach`` (the hand's
    closest approach to an object) and ``problems`` (a hand that reaches no object, no object
    moving under ground-truth skills that move one; :mod:`lfd.io.checks`). A ROS bag (with its
    ``mapping``) is always loaded. A readable MCAP file with messages that lacks the hand
    keypoints or every object pose is described with that in ``problems``; a recording that cannot be used
    otherwise is reported in ``error`` (its warnings in ``warnings``), not raised, so a damaged
    file can still be summarised.
    ``hands`` lists the hands (``side``, ``samples``, ``rate_hz``), each label names its
    ``hand`` (None: the only hand of a one-hand file), ``handovers`` lists a two-hand file's
    (``giver``, ``taker``, ``object``, ``start_s``, ``end_s``). A hand topic of an unknown side
    and two hands not on one clock (:mod:`lfd.io.hands`) raise
    :class:`~lfd.errors.RecordingFormatError`.
    Times are seconds from ``start_ns``, the first message.
    """
    summary: dict[str, Any]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        if is_ros_path(path):
            from .ros import bag_summary

            summary = bag_summary(path)
            summary.update(problems=[], error=None)
            _loaded(summary, path, object_sizes, mapping)
        else:
            summary = _mcap(path, object_sizes, check)
            if check and summary["error"] is None:
                _loaded(summary, path, object_sizes, mapping)
    summary["warnings"] = list(dict.fromkeys(str(w.message) for w in caught))
    return summary


def _mcap(
    path: str | os.PathLike[str], object_sizes: Mapping[str, Sequence[float]] | None, check: bool
) -> dict[str, Any]:
    """The summary of an lfd MCAP file from its summary section (else a full read)."""
    rec: Records | None = read_summary(path, SMALL_TOPICS)
    complete, damage, source = True, None, "summary"
    if rec is None:  # no summary, or one that cannot be believed: read the file (labels kept)
        raw = read(path, images=False, topics=SMALL_TOPICS, raw_limit=LABEL_BYTES)
        rec, complete, damage, source = raw, raw.complete, raw.error, "scan"
        if damage is None and not complete:
            damage = "the file has no summary section (its writer was not closed)"
    chunk_damage = rec.damage_text()
    if chunk_damage is not None:
        complete = False
        damage = chunk_damage if damage is None else f"{damage}; {chunk_damage}"
    firsts = [c.first_ns for c in rec.channels.values() if c.first_ns is not None]
    t0 = min(firsts) if firsts else 0
    summary: dict[str, Any] = {
        "path": rec.path,
        "file_size": rec.file_size,
        "library": rec.library,
        "complete": complete,
        "damage": damage,
        "source": source,
        "messages": rec.message_count,
        "chunks": rec.chunks,
        "damaged_chunks": rec.damage,
        "duration_s": rec.span_s,
        "start_ns": t0,
        "channels": [
            {
                "topic": c.topic,
                "schema": c.schema,
                "count": c.count,
                "rate_hz": round(c.rate_hz, 3),
                "first_s": None if c.first_ns is None else (c.first_ns - t0) * 1e-9,
                "last_s": None if c.last_ns is None else (c.last_ns - t0) * 1e-9,
            }
            for c in sorted(rec.channels.values(), key=lambda c: c.topic)
        ],
        "metadata_records": rec.metadata,
        "attachments": getattr(rec, "attachments", []),
        "problems": [],
        "error": None,
        "hands": [
            {
                "side": side,
                "samples": rec.channels[T.hand_topic(side)].count,
                "rate_hz": round(rec.channels[T.hand_topic(side)].rate_hz, 3),
            }
            for side in present_sides(rec)
        ],
        "handovers": [],
    }
    check_hand_topics(rec)  # bad input, not damage: raised
    check_hand_clock(rec)
    if not complete and not check:  # else load says it
        what = "is damaged" if chunk_damage is not None else "is truncated or was not closed"
        warnings.warn(
            f"{rec.path} {what} ({damage}); recovered {rec.message_count} messages covering "
            f"{rec.span_s:.2f} s from its intact chunks",
            RecoveredFileWarning,
            stacklevel=3,
        )
    try:
        try:
            hand_side(rec, complete, damage)
        except RecordingFormatError as err:
            if rec.message_count == 0:
                raise  # nothing to describe
            # described all the same (a video without tags): it cannot be segmented
            summary["problems"].append(f"{err} (lfd segment and lfd.load refuse it)")
        specs = objects_of(rec)
        if check:
            return summary  # objects, labels and metadata from the loaded demonstration
        from .sizes import resolve_sizes

        sizes = resolve_sizes(rec.path, {n: size for n, _, size in specs}, object_sizes)
        summary["objects"] = [
            {
                "name": name,
                "tag_id": tag_id,
                "size": [float(v) for v in sizes[name]],
                "samples": rec.channels[T.object_topic(name)].count
                if T.object_topic(name) in rec.channels
                else 0,
            }
            for name, tag_id, _ in specs
        ]
        if rec.raw_truncated:
            raise RecordingFormatError(
                f"{rec.path}: its label channels ({', '.join(SMALL_TOPICS)}) hold more than "
                f"{LABEL_BYTES} bytes of messages, more than lfd info reads; not lfd labels"
            )
        labels = _labels(rec, T.GROUND_TRUTH_TOPIC)
        live = _labels(rec, T.LIVE_SEGMENTS_TOPIC)
        summary["labels"] = [_label(lab, t0) for lab in labels]
        summary["live_segments"] = [_label(lab, t0) for lab in live]
        summary["handovers"] = _handovers(rec, t0)
        _check_lanes(rec, labels, live)
        metadata = rec.json_metadata(T.DEMO_METADATA, "metadata", default={})
        summary["metadata"] = metadata if isinstance(metadata, dict) else {"metadata": metadata}
        camera = rec.json_metadata(T.CALIBRATION_METADATA, "camera")
        summary["camera"] = (
            {"width": int(camera["width"]), "height": int(camera["height"])}
            if isinstance(camera, dict) and "width" in camera and "height" in camera
            else None
        )
    except _LaneError as err:
        raise RecordingFormatError(str(err)) from None  # bad input: raised, not described
    except LfdError as err:
        summary["error"] = str(err)
    return summary


class _LaneError(LfdError):
    """A label or handover for a hand the recording lacks (raised by :func:`summarise`)."""


def _check_lanes(rec: Records, labels: list[SkillLabel], live: list[SkillLabel]) -> None:
    from .hands import handovers_of_events, lanes_problem

    sides = present_sides(rec)
    if not sides:
        return  # no hand: already a problem
    handovers = handovers_of_events(_events(rec, T.HANDOVERS_TOPIC), rec.path)
    for what, lane, given in (("label", labels, handovers), ("live segment", live, [])):
        problem = lanes_problem(sides, lane, given, what)
        if problem is not None:
            raise _LaneError(f"{rec.path}: {problem}")


def _labels(rec: Records, topic: str) -> list[SkillLabel]:
    """The skill labels of ``topic`` (Event messages) as ``lfd info`` lists them."""
    labels, skipped = labels_of_events(_events(rec, topic), f"{rec.path}: {topic}: ")
    if skipped:
        warnings.warn(f"{rec.path}: skipped {skipped}", RecoveredFileWarning, stacklevel=4)
    return labels


def _events(rec: Records, topic: str) -> list[Any]:
    from foxglove_schemas_protobuf.Event_pb2 import Event
    from google.protobuf.message import DecodeError

    events = []
    for t, data in rec.messages.get(topic, []):
        msg = Event()
        try:
            msg.ParseFromString(data)
        except DecodeError as err:
            raise RecordingFormatError(
                f"{rec.path}: cannot decode a foxglove.Event on {topic} at {t} ns: {err}"
            ) from None
        events.append(msg)
    return events


def _handovers(rec: Records, t0: int) -> list[dict[str, Any]]:
    """The handovers of a two-hand recording as ``lfd info`` lists them."""
    from .hands import handovers_of_events

    return [
        _handover(h, t0) for h in handovers_of_events(_events(rec, T.HANDOVERS_TOPIC), rec.path)
    ]


def _label(lab: Any, t0: int) -> dict[str, Any]:
    return {
        "skill": lab.skill,
        "object": lab.object,
        "hand": lab.hand,
        "start_s": (lab.start_ns - t0) * 1e-9,
        "end_s": (lab.end_ns - t0) * 1e-9,
    }


def _handover(h: Any, t0: int) -> dict[str, Any]:
    return {
        "giver": h.giver,
        "taker": h.taker,
        "object": h.object,
        "start_s": (h.start_ns - t0) * 1e-9,
        "end_s": (h.end_ns - t0) * 1e-9,
    }


def _loaded(
    summary: dict[str, Any],
    path: str | os.PathLike[str],
    object_sizes: Mapping[str, Sequence[float]] | None,
    mapping: Any,
) -> None:
    """Objects, labels, metadata, camera and the checks of the loaded recording, into
    ``summary`` (a load that fails is its ``error``)."""
    try:
        demo = load(path, images=False, object_sizes=object_sizes, mapping=mapping)
    except LfdError as err:
        summary["error"] = str(err)
        return
    from .checks import closest_approach, object_travel, reach_message, unmoved_objects_message

    t0 = summary["start_ns"]
    if not summary.get("hands"):  # a ROS bag: from its loaded hands
        summary["hands"] = [
            {
                "side": side,
                "samples": len(h),
                "rate_hz": round((len(h) - 1) / (int(h.t_ns[-1] - h.t_ns[0]) * 1e-9), 3)
                if len(h) > 1 and h.t_ns[-1] > h.t_ns[0]
                else 0.0,
            }
            for side, h in demo.hands.items()
        ]
    travel = object_travel(demo)
    summary["objects"] = [
        {
            "name": o.name,
            "tag_id": o.tag_id,
            "size": o.size.tolist(),
            "samples": len(o),
            "travel_m": travel[o.name],
        }
        for o in demo.objects.values()
    ]
    approach = closest_approach(demo)
    summary["hand_approach"] = {
        "distance_m": approach.distance_m if approach.object is not None else None,
        "object": approach.object,
        "t_s": approach.t_s,
        "hand": approach.hand,
    }
    for problem in (
        reach_message(demo),
        unmoved_objects_message(
            demo, [lab.skill for lab in demo.labels], source="the ground truth"
        ),
    ):
        if problem is not None:
            summary["problems"].append(problem)
    summary["labels"] = [_label(lab, t0) for lab in demo.labels]
    summary["live_segments"] = [_label(lab, t0) for lab in demo.live_segments]
    summary["handovers"] = [_handover(h, t0) for h in demo.handovers]
    summary["metadata"] = {k: v for k, v in demo.metadata.items() if k != "load_report"}
    summary["camera"] = (
        None if demo.camera is None else {"width": demo.camera.width, "height": demo.camera.height}
    )
