"""Two hands in one recording: the clock rule, the lanes' checks and :func:`merge_hands`.

A recording holds one hand or two (``/hand/right/...``, ``/hand/left/...``; docs/own-recordings.md).

**The clock rule.** Both hands of a file, and its objects, must be on one clock: each hand's time
span (first to last sample) must overlap the other hand's and the objects' (the union of every
object's span). Two hands captured by one recorder always are; a hand stamped in epoch
nanoseconds (1.7e18 ns) beside one counted from zero, or two takes of different moments put in
one file, are not, and such a file is refused (:func:`clock_problem`, one line) by
:func:`lfd.load`, ``lfd info`` and :func:`lfd.save`. A one-hand file is not checked (as before).

**The lanes.** In a two-hand file every label and live segment names its hand (``hand``
metadata); a label for a hand the file lacks, a label without a hand beside two, and a handover
in a one-hand file are refused (:func:`lanes_problem`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

from ..demo import HAND_SIDES, Demonstration, Handover, SkillLabel
from ..errors import DemonstrationError, LfdError, RecordingFormatError

__all__ = [
    "clock_problem",
    "handovers_of_events",
    "lanes_problem",
    "merge_hands",
    "spans_of",
]

Span = tuple[int, int]


def _overlap(a: Span, b: Span) -> bool:
    return max(a[0], b[0]) <= min(a[1], b[1])


def _shown(span: Span) -> str:
    return f"{span[0]}-{span[1]} ns"


def clock_problem(hands: Mapping[str, Span], objects: Span | None) -> str | None:
    """What breaks the clock rule (None: the hands are on one clock, or there is one hand).

    ``hands`` maps each side to its ``(first, last)`` sample time, ``objects`` is the span of
    every object sample (None: no object)."""
    if len(hands) < 2:
        return None
    (s1, a), (s2, b) = list(hands.items())[:2]
    spans = f"the {s1} hand spans {_shown(a)}, the {s2} hand {_shown(b)}"
    if objects is not None:
        spans += f", the objects {_shown(objects)}"
    rule = "each hand's time span must overlap the other's and the objects' (one clock)"
    if not _overlap(a, b):
        return f"the two hands are not on one clock: {spans}; {rule}"
    for side, span in ((s1, a), (s2, b)):
        if objects is not None and not _overlap(span, objects):
            return f"the {side} hand is not on the objects' clock: {spans}; {rule}"
    return None


def spans_of(demo: Demonstration) -> tuple[dict[str, Span], Span | None]:
    """The hands' and the objects' time spans of ``demo`` (empty tracks left out)."""
    hands = {s: (int(h.t_ns[0]), int(h.t_ns[-1])) for s, h in demo.hands.items() if len(h)}
    objs = [o.t_ns for o in demo.objects.values() if len(o)]
    objects = (min(int(t[0]) for t in objs), max(int(t[-1]) for t in objs)) if objs else None
    return hands, objects


def lanes_problem(
    sides: Sequence[str],
    labels: Iterable[SkillLabel],
    handovers: Iterable[Handover],
    what: str = "label",
) -> str | None:
    """What makes ``labels`` and ``handovers`` wrong for a recording with the hands ``sides``
    (None: right): a label for a hand it lacks, a label naming no hand beside two hands, a
    handover naming a hand it lacks (or in a one-hand recording)."""
    have = " and ".join(sides)
    for lab in labels:
        if lab.hand is not None and lab.hand not in sides:
            return (
                f"a {what} ({lab.skill} at {lab.start_ns} ns) is for the {lab.hand} hand, which "
                f"the recording lacks (it has the {have} hand)"
            )
        if lab.hand is None and len(sides) > 1:
            return (
                f"a {what} ({lab.skill} at {lab.start_ns} ns) names no hand, and the recording "
                f"has two ({have}): each label needs its hand"
            )
    for h in handovers:
        for side in (h.giver, h.taker):
            if side not in sides:
                return (
                    f"a handover at {h.start_ns} ns ({h.giver} to {h.taker}) names the {side} "
                    f"hand, which the recording lacks (it has the {have} hand)"
                )
    return None


def handovers_of_events(events: Iterable[Any], path: str) -> list[Handover]:
    """The handovers of foxglove ``Event`` messages (metadata ``giver``, ``taker``, ``object``),
    in time order.

    Raises
    ------
    RecordingFormatError
        A handover without a giver and taker of two different sides, or that ends before it
        starts."""
    out = []
    for m in events:
        meta = {kv.key: kv.value for kv in m.metadata}
        start = int(m.start_time.seconds) * 1_000_000_000 + int(m.start_time.nanos)
        end = int(m.end_time.seconds) * 1_000_000_000 + int(m.end_time.nanos)
        try:
            out.append(
                Handover(
                    start_ns=start,
                    end_ns=end,
                    giver=meta.get("giver", ""),
                    taker=meta.get("taker", ""),
                    object=meta.get("object") or None,
                )
            )
        except LfdError as err:
            raise RecordingFormatError(f"{path}: handover at {start} ns: {err}") from None
    return sorted(out, key=lambda h: (h.start_ns, h.end_ns))


def _same_objects(right: Demonstration, left: Demonstration) -> None:
    if set(right.objects) != set(left.objects):
        raise DemonstrationError(
            f"the two hands' recordings have different objects: {sorted(right.objects)} and "
            f"{sorted(left.objects)}; merge_hands needs one take"
        )
    for name, a in right.objects.items():
        b = left.objects[name]
        if not np.allclose(a.size, b.size):
            raise DemonstrationError(
                f"object {name!r} has two sizes, {a.size.tolist()} and {b.size.tolist()}"
            )


def _merged_metadata(right: dict[str, Any], left: dict[str, Any]) -> dict[str, Any]:
    """The keys both hands' metadata agree on, and ``per_hand``: each one's other keys."""
    right = {k: v for k, v in right.items() if k != "load_report"}
    left = {k: v for k, v in left.items() if k != "load_report"}
    common = {k: v for k, v in right.items() if k in left and left[k] == v}
    per_hand = {
        side: {k: v for k, v in meta.items() if k not in common}
        for side, meta in (("right", right), ("left", left))
    }
    if any(per_hand.values()):
        common["per_hand"] = per_hand
    return common


def merge_hands(
    first: Demonstration, second: Demonstration, handovers: Sequence[Handover] = ()
) -> Demonstration:
    """One two-hand demonstration of two one-hand recordings of the same take (one file per
    hand on the same clock, e.g. ``take.right.mcap`` and ``take.left.mcap``), either order.

    The objects, camera and images are the right hand's recording's (both must have the same
    objects, same names and sizes); each recording's labels and live segments become its hand's
    lane (``hand`` set); the metadata both agree on is kept, the rest under
    ``metadata["per_hand"][side]``.

    Raises
    ------
    DemonstrationError
        Not two one-hand recordings of a right and a left hand, different objects, or hands not
        on one clock (the clock rule, :func:`clock_problem`).
    """
    for d in (first, second):
        if d.other_hand is not None:
            raise DemonstrationError("merge_hands takes two one-hand demonstrations")
    if first.hand.side == second.hand.side:
        raise DemonstrationError(
            f"merge_hands needs a right and a left hand, got two {first.hand.side} hands"
        )
    right, left = (first, second) if first.hand.side == HAND_SIDES[0] else (second, first)
    _same_objects(right, left)

    def lane(labels: list[SkillLabel], side: str) -> list[SkillLabel]:
        return [dataclasses.replace(lab, hand=side) for lab in labels]

    demo = dataclasses.replace(
        right,
        other_hand=left.hand,
        labels=sorted(
            lane(right.labels, "right") + lane(left.labels, "left"),
            key=lambda lab: (lab.start_ns, lab.end_ns),
        ),
        live_segments=lane(right.live_segments, "right") + lane(left.live_segments, "left"),
        handovers=sorted(handovers, key=lambda h: (h.start_ns, h.end_ns)),
        metadata=_merged_metadata(right.metadata, left.metadata),
    )
    problem = clock_problem(*spans_of(demo))
    if problem is not None:
        raise DemonstrationError(problem)
    return demo
