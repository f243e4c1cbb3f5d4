"""What a recording holds, for people and scripts (``lfd info``): channels, objects, labels."""

from __future__ import annotations

import os
import warnings
from collections.abc import Mapping, Sequence
from typing import Any

from ..errors import LfdError
from .mcapfile import scan
from .reader import is_ros_path, load


def summarise(
    path: str | os.PathLike[str],
    *,
    object_sizes: Mapping[str, Sequence[float]] | None = None,
    mapping: Any = None,
) -> dict[str, Any]:
    """A JSON-ready summary of a recording: the document of ``lfd info --json``.

    The file's channels, metadata and damage come from :func:`lfd.io.scan` (never fails on a
    damaged file; for a ROS bag, from its index: topics, types and counts); its objects, skill
    labels, metadata and camera from :func:`lfd.io.load` (with ``object_sizes`` and the ROS
    ``mapping``) when that succeeds. A failed load is reported in ``error`` (its warnings in
    ``warnings``), not raised, so a damaged file can still be summarised. Times are seconds
    from ``start_ns``, the first message. ``objects[].travel_m`` (how far each object moves),
    ``hand_approach`` (the hand's closest approach to an object) and ``problems`` (what
    segmenting it will meet: a hand that reaches no object, no object moving under ground-truth
    skills that move one) come from :mod:`lfd.io.checks`.
    """
    if is_ros_path(path):
        from .ros import bag_summary

        summary = bag_summary(path)
        t0 = summary["start_ns"]
    else:
        raw = scan(path)
        firsts = [c.first_ns for c in raw.channels.values() if c.first_ns is not None]
        t0 = min(firsts) if firsts else 0
        summary = {
            "path": raw.path,
            "file_size": raw.file_size,
            "library": raw.library,
            "complete": raw.complete,
            "damage": raw.error,
            "messages": raw.message_count,
            "duration_s": raw.span_s,
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
                for c in sorted(raw.channels.values(), key=lambda c: c.topic)
            ],
            "metadata_records": raw.metadata,
        }
    summary.update(warnings=[], problems=[], error=None)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            demo = load(path, images=False, object_sizes=object_sizes, mapping=mapping)
        except LfdError as err:
            summary["error"] = str(err)
            demo = None
    summary["warnings"] = [str(w.message) for w in caught]
    if demo is not None:
        from .checks import closest_approach, object_travel, reach_message, unmoved_objects_message

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
        }
        for problem in (
            reach_message(demo),
            unmoved_objects_message(
                demo, [lab.skill for lab in demo.labels], source="the ground truth"
            ),
        ):
            if problem is not None:
                summary["problems"].append(problem)
        for key, labels in (("labels", demo.labels), ("live_segments", demo.live_segments)):
            summary[key] = [
                {
                    "skill": lab.skill,
                    "object": lab.object,
                    "start_s": (lab.start_ns - t0) * 1e-9,
                    "end_s": (lab.end_ns - t0) * 1e-9,
                }
                for lab in labels
            ]
        summary["metadata"] = {k: v for k, v in demo.metadata.items() if k != "load_report"}
        summary["camera"] = (
            None
            if demo.camera is None
            else {"width": demo.camera.width, "height": demo.camera.height}
        )
    return summary
