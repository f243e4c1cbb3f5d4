"""The task program the robot executes: an ordered list of skill segments.

Both sources of a segmentation map onto it: the ground-truth labels of a recording
(:func:`from_labels`) and the segmentation engine's result, exported as JSON::

    {"segments": [{"skill": "pick_up", "start_s": 1.2, "end_s": 3.4,
                   "object": "box_1", "params": {}}, ...]}

Times are seconds since the first sample of the preprocessed trajectory. ``object`` is the
target object of the skill (a name, or ``null`` for ``move``; for ``move_with`` the carried
object). ``params`` is a JSON object, free but for the object names it gives (e.g.
``{"support": "box_2"}`` for a stack, filled in from the demonstration when missing).
:meth:`TaskProgram.from_json` also reads the document ``lfd reproduce --program --json`` writes,
``{"recording": ..., "program": {"segments": [...]}}``.

A program read from a file is checked before any work: at most :data:`MAX_SEGMENTS` segments,
each with ``skill``, ``start_s`` and ``end_s``, times finite numbers (not booleans) within
:data:`lfd.inputs.MAX_SECONDS` (the rule of ``lfd label``); :meth:`TaskProgram.check_within`
then checks them against the recording the program runs on.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import DemonstrationError
from ..skills import check_skill


@dataclass
class Segment:
    """One skill segment of a task program."""

    skill: str
    start_s: float
    end_s: float
    object: str | None = None
    params: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        check_skill(self.skill)
        self.start_s = float(self.start_s)
        self.end_s = float(self.end_s)
        if not self.end_s >= self.start_s:
            raise DemonstrationError(
                f"segment {self.skill!r}: end {self.end_s} s before start {self.start_s} s"
            )


MAX_SEGMENTS = 2000
"""Most segments a task program read from JSON may have (:meth:`TaskProgram.from_json` refuses
more before any work). Real programs have tens to hundreds of steps; each step costs planning
time (3000 ``move`` steps took 70 s, 1.4 million ran for minutes in 4.4 GB)."""
OBJECT_PARAMS = ("support", "reference")
"""The ``params`` of a segment that name an object (a string, or null): a stack's support, a
place's reference (:mod:`lfd.reproduce.modes`)."""


def _segment_from_json(item: Any, where: str) -> Segment:
    """One segment of a task program's JSON, every key checked (one line naming ``where``)."""
    from ..inputs import seconds, shown

    if not isinstance(item, dict):
        raise DemonstrationError(f"{where} must be a JSON object, got {shown(item)}")
    missing = [k for k in ("skill", "start_s", "end_s") if k not in item]
    if missing:
        raise DemonstrationError(
            f'{where}: missing "{missing[0]}" (a segment has skill, start_s, end_s, object, params)'
        )
    if not isinstance(item["skill"], str):
        raise DemonstrationError(
            f"{where}: skill must be a skill's name, got {shown(item['skill'])}"
        )
    obj = item.get("object")
    if obj is not None and not isinstance(obj, str):
        raise DemonstrationError(
            f"{where}: object must be an object's name or null, got {shown(obj)}"
        )
    params = item.get("params")
    if params is None:
        params = {}
    if not isinstance(params, dict):
        raise DemonstrationError(
            f'{where}: params must be a JSON object ({{}} or e.g. {{"support": "box_2"}}), '
            f"got {shown(params)}"
        )
    for key in OBJECT_PARAMS:
        if params.get(key) is not None and not isinstance(params[key], str):
            raise DemonstrationError(
                f"{where}: params.{key} must be an object's name, got {shown(params[key])}"
            )
    start = seconds(item["start_s"], where, "start_s")
    end = seconds(item["end_s"], where, "end_s")
    return Segment(item["skill"], start, end, obj, dict(params))


@dataclass
class TaskProgram:
    """An ordered list of :class:`Segment` (the robot's task)."""

    segments: list[Segment]

    def __post_init__(self) -> None:
        if not self.segments:
            raise DemonstrationError("a task program needs at least one segment")
        for a, b in zip(self.segments, self.segments[1:], strict=False):
            if b.start_s < a.start_s:
                raise DemonstrationError("task program segments must be in time order")

    def __len__(self) -> int:
        return len(self.segments)

    @property
    def skills(self) -> list[str]:
        """The skill names in order."""
        return [s.skill for s in self.segments]

    def to_json(self) -> dict[str, Any]:
        """A JSON-serialisable dict (see the module docstring)."""
        return {"segments": [asdict(s) for s in self.segments]}

    @classmethod
    def from_json(cls, data: Any, what: str = "task program") -> TaskProgram:
        """Build from the JSON layout (see the module docstring): a dict with ``segments``, a
        bare list of segments, or ``lfd reproduce --program --json``'s ``{"program": ...}``;
        ``what`` starts every error message (``"task program PATH"`` when read from a file).

        Raises
        ------
        DemonstrationError
            Not that layout (a two-hand program, ``hands``, is refused: a one-arm program is
            one hand's ``segments``), more than :data:`MAX_SEGMENTS` segments, a segment
            missing a key or with an object or ``params`` of the wrong type, or an empty
            program or one out of time order.
        UsageError
            A time that is not a finite number of seconds within
            :data:`lfd.inputs.MAX_SECONDS` (:func:`lfd.inputs.seconds`).
        UnknownSkillError
            A skill name that is not canonical.
        """
        if isinstance(data, dict) and "segments" not in data and "program" in data:
            data = data["program"]  # the document `lfd reproduce --program --json` writes
        if isinstance(data, dict) and "hands" in data:
            raise DemonstrationError(
                f"{what} is a two-hand program ('hands'), which a one-arm run does "
                'not read: give one hand\'s {"segments": [...]} (`lfd reproduce REC --hand '
                "right --program --json OUT` writes the right hand's)"
            )
        items = data.get("segments") if isinstance(data, dict) else data
        if not isinstance(items, list):
            raise DemonstrationError(f"{what} JSON needs a 'segments' list")
        if len(items) > MAX_SEGMENTS:
            raise DemonstrationError(
                f"{what} has {len(items)} segments; at most {MAX_SEGMENTS} are run"
            )
        return cls(
            [_segment_from_json(item, f"{what} segment {i}") for i, item in enumerate(items)]
        )

    def check_within(self, duration_s: float, what: str = "task program") -> None:
        """Refuse segments outside the recording they run on: each must start at or after its
        start and end by its end (``duration_s`` after it), within
        :data:`~lfd.inputs.END_TOLERANCE_NS` (0.1 s) either side: program times count from
        the first sample of the preprocessed trajectory, a little after the recording's start.

        Raises
        ------
        DemonstrationError
            A segment that starts before the recording or ends after it (one line, naming the
            first).
        """
        from ..inputs import END_TOLERANCE_NS

        tol = END_TOLERANCE_NS * 1e-9
        for i, s in enumerate(self.segments):
            where = f"{what} segment {i} ({s.skill} {s.start_s:.3f}-{s.end_s:.3f} s)"
            span = f"it spans 0-{duration_s:.3f} s"
            if s.start_s < -tol:
                raise DemonstrationError(f"{where}: starts before the recording ({span})")
            if s.end_s > duration_s + tol:
                raise DemonstrationError(f"{where}: ends after the recording ({span})")

    @classmethod
    def load(cls, path: str | Path) -> TaskProgram:
        """Read a task program JSON file."""
        from ..inputs import parse_json, read_text

        try:
            text = read_text(path, "task program", DemonstrationError)
        except OSError as err:
            raise DemonstrationError(f"cannot read task program {path}: {err}") from err
        doc = parse_json(text, f"cannot read task program {path}", DemonstrationError)
        return cls.from_json(doc, f"task program {path}")

    def save(self, path: str | Path) -> None:
        """Write the program as JSON."""
        Path(path).write_text(json.dumps(self.to_json(), indent=2))


def from_labels(labels: Sequence[Any], t0_ns: int) -> TaskProgram:
    """Task program from :class:`lfd.demo.SkillLabel` s (ground truth) or anything alike.

    Parameters
    ----------
    labels : sequence of SkillLabel
        Objects with ``skill``, ``start_ns``, ``end_ns`` and ``object``.
    t0_ns : int
        Time origin (the first sample of the trajectory), nanoseconds.
    """
    if not labels:
        raise DemonstrationError("the recording has no skill labels; pass --task program.json")
    return TaskProgram(
        [
            Segment(
                skill=lab.skill,
                start_s=(int(lab.start_ns) - t0_ns) * 1e-9,
                end_s=(int(lab.end_ns) - t0_ns) * 1e-9,
                object=lab.object,
            )
            for lab in labels
        ]
    )


def from_segmentation(seg: Any, t0_ns: int) -> TaskProgram:
    """Task program from a segmentation result with a ``segments`` or ``labels`` list.

    Accepts anything whose items have ``skill`` and either ``start_ns``/``end_ns`` or
    ``start_s``/``end_s`` plus an optional ``object`` (the segment helper's result type).
    """
    items = getattr(seg, "segments", None) or getattr(seg, "labels", None) or seg
    segs = []
    for it in items:
        if hasattr(it, "start_ns"):
            start, end = (int(it.start_ns) - t0_ns) * 1e-9, (int(it.end_ns) - t0_ns) * 1e-9
        else:
            start, end = float(it.start_s), float(it.end_s)
        segs.append(Segment(it.skill, start, end, getattr(it, "object", None)))
    return TaskProgram(segs)


# --- two hands: a lane of skills per hand and the points where the lanes wait for each other --
SYNC_TOLERANCE_S = 0.3
"""Two hands' steps that end within this long of each other end "together" (a two-handed
carry; a taker's grasp at a handover's start), as the handovers are scored (docs/skills.md)."""
HOLD_STILL_M = 0.03
"""A held object is still when it stays within this of where it was as the other hand's step
began (the object tracks, when given)."""
SYNC_KINDS = ("handover", "hold_until", "carry")
"""The synchronisation points of a two-hand program (docs/reproduce.md)."""


@dataclass
class SyncPoint:
    """Where one hand's step waits for the other hand's.

    ``handover``: the giver's ``place`` of ``object`` (step ``step`` of ``hand``) lets go only
    after the taker's ``pick_up`` of it (step ``other_step`` of ``other``) has grasped it.
    ``hold_until``: the ``hand`` holds ``object`` still (its ``move_with``, step ``step``) until
    the other hand's step ``other_step`` ends. ``carry``: both hands carry ``object`` together
    (their ``move_with`` steps start and end together). ``t_s``: when, in the demonstration.
    """

    kind: str
    hand: str
    step: int
    other: str
    other_step: int
    object: str | None
    t_s: float

    def describe(self, lanes: dict[str, list[Segment]]) -> str:
        """One line, e.g. ``handover of box_1 at 7.90 s: left 3 place lets go after right 1
        pick_up has grasped``."""
        mine, theirs = lanes[self.hand][self.step], lanes[self.other][self.other_step]
        a = f"{self.hand} {self.step} {mine.skill}"
        b = f"{self.other} {self.other_step} {theirs.skill}"
        obj = self.object or "-"
        if self.kind == "handover":
            return f"handover of {obj} at {self.t_s:.2f} s: {a} lets go after {b} has grasped"
        if self.kind == "hold_until":
            return f"hold {obj} at {self.t_s:.2f} s: {a} holds it still until {b} ends"
        return f"carry {obj} at {self.t_s:.2f} s: {a} and {b} carry it together"


@dataclass
class HandsProgram:
    """A two-hand (or one-hand) task program: each hand's skills in time order and the points
    where one hand waits for the other (:class:`SyncPoint`).

    Build it with :func:`from_hands` (a :class:`~lfd.segmentation.HandsSegmentation`) or
    :func:`from_hand_labels` (ground-truth labels naming their hands, and the handovers).
    """

    lanes: dict[str, list[Segment]]
    sync: list[SyncPoint] = field(default_factory=list)

    @property
    def sides(self) -> tuple[str, ...]:
        return tuple(self.lanes)

    def program(self, side: str) -> TaskProgram:
        """The ``side`` hand's skills as a one-arm task program."""
        return TaskProgram(list(self.lanes[side]))

    def acting(self, side: str) -> list[tuple[int, Segment]]:
        """The ``side`` hand's steps that handle an object: every skill but ``move``."""
        return [(i, s) for i, s in enumerate(self.lanes[side]) if s.skill != "move"]

    def one_arm_side(self) -> str:
        """The hand that does all of the task, for a robot with one arm: the only hand whose
        steps handle objects (the other only moves); of two idle hands the first with steps.

        Raises
        ------
        DemonstrationError
            Both hands handle objects (one line naming the first step of each and the first
            handover), or no hand has a step.
        """
        busy = [side for side in self.sides if self.acting(side)]
        if len(busy) == 1:
            return busy[0]
        if not busy:
            with_steps = [side for side in self.sides if self.lanes[side]]
            if not with_steps:
                raise DemonstrationError("the task program has no step for any hand")
            return with_steps[0]
        firsts = []
        for side in busy:
            _, s = self.acting(side)[0]
            firsts.append(f"the {side} hand's {s.skill} of {s.object or '-'} at {s.start_s:.1f} s")
        handovers = [p for p in self.sync if p.kind == "handover"]
        what = ", ".join(firsts)
        if handovers:
            h = handovers[0]
            more = f" (and {len(handovers) - 1} more)" if len(handovers) > 1 else ""
            what += f"; a handover of {h.object or '-'} at {h.t_s:.1f} s{more}"
        raise DemonstrationError(
            f"both hands handle objects ({what}) and the robot has one arm: a two-hand task "
            "is not reproduced; --hand right or --hand left reproduces one hand's part"
        )

    def to_json(self) -> dict[str, Any]:
        """``{"hands": {side: {"segments": [...]}}, "sync": [...]}`` (docs/reproduce.md)."""
        return {
            "hands": {
                side: {"segments": [asdict(s) for s in segs]} for side, segs in self.lanes.items()
            },
            "sync": [asdict(p) for p in self.sync],
        }

    def lines(self) -> list[str]:
        """The program as text: each hand's steps, then the synchronisation points."""
        out = []
        for side, segs in self.lanes.items():
            out.append(f"{side} hand:")
            out += [
                f"  {i:>2} {s.skill:<10} {s.object or '-':<10} {s.start_s:7.2f} - {s.end_s:7.2f} s"
                for i, s in enumerate(segs)
            ]
        if self.sync:
            out.append("synchronisation:")
            out += [f"  {p.describe(self.lanes)}" for p in self.sync]
        return out


def from_hand_labels(
    labels: Sequence[Any],
    t0_ns: int,
    *,
    sides: Sequence[str],
    handovers: Sequence[Any] = (),
    objects: Mapping[str, Any] | None = None,
) -> HandsProgram:
    """A :class:`HandsProgram` from labels naming their hand (``SkillLabel.hand``; None: the
    only hand of ``sides``) and the handovers (:class:`lfd.Handover`); ``objects`` (the
    demonstration's tracks, optional) tell a held object that stays still (:func:`sync_points`)."""
    lanes: dict[str, list[Segment]] = {side: [] for side in sides}
    for lab in sorted(labels, key=lambda lab: int(lab.start_ns)):
        side = lab.hand if lab.hand is not None else sides[0]
        if side not in lanes:
            raise DemonstrationError(
                f"label {lab.skill!r} is for the {side} hand, which the task lacks"
            )
        lanes[side].append(_segment_of(lab, t0_ns))
    return HandsProgram(lanes, sync_points(lanes, handovers, t0_ns, objects))


def from_hands(result: Any, t0_ns: int, objects: Mapping[str, Any] | None = None) -> HandsProgram:
    """A :class:`HandsProgram` from a :class:`~lfd.segmentation.HandsSegmentation` (its
    ``lanes`` of segments by side and its ``handovers``); ``objects`` as
    :func:`from_hand_labels`."""
    lanes = {
        side: [_segment_of(s, t0_ns) for s in seg.segments] for side, seg in result.lanes.items()
    }
    return HandsProgram(lanes, sync_points(lanes, result.handovers, t0_ns, objects))


def _segment_of(item: Any, t0_ns: int) -> Segment:
    start, end = (int(item.start_ns) - t0_ns) * 1e-9, (int(item.end_ns) - t0_ns) * 1e-9
    return Segment(item.skill, start, end, getattr(item, "object", None))


def sync_points(
    lanes: dict[str, list[Segment]],
    handovers: Sequence[Any],
    t0_ns: int,
    objects: Mapping[str, Any] | None = None,
) -> list[SyncPoint]:
    """The synchronisation points of two lanes, in time order: one per handover (the giver's
    ``place`` waits for the taker's ``pick_up``), per two-handed carry (both ``move_with`` of
    one object, overlapping) and per hold (a ``move_with`` during which the other hand's step
    on another object ends: the holding hand waits for it; the last such step counts). With
    ``objects`` (tracks by name: ``t_ns``, ``position``), a hold needs the held object still
    during that step (within :data:`HOLD_STILL_M`); without, the labels alone decide."""
    points = [p for h in handovers if (p := _handover_point(lanes, h, t0_ns)) is not None]
    sides = list(lanes)
    for a, b in ((x, y) for x in sides for y in sides if x != y):
        for i, s in enumerate(lanes[a]):
            if s.skill != "move_with":
                continue
            for j, o in enumerate(lanes[b]):
                both = o.skill == "move_with" and o.object == s.object
                if both and a < b and o.start_s < s.end_s and s.start_s < o.end_s:
                    t = max(s.start_s, o.start_s)
                    points.append(SyncPoint("carry", a, i, b, j, s.object, t))
            inside = [
                j
                for j, o in enumerate(lanes[b])
                if o.skill != "move"
                and o.object != s.object
                and s.start_s < o.end_s <= s.end_s + SYNC_TOLERANCE_S
            ]
            if inside and _still(objects, s.object, lanes[b][inside[-1]], t0_ns):
                j = inside[-1]
                points.append(SyncPoint("hold_until", a, i, b, j, s.object, lanes[b][j].end_s))
    return sorted(points, key=lambda p: (p.t_s, SYNC_KINDS.index(p.kind), p.hand))


def _still(objects: Mapping[str, Any] | None, name: str | None, step: Segment, t0_ns: int) -> bool:
    """Whether object ``name`` stays within :data:`HOLD_STILL_M` of where it was as ``step``
    began, while it runs (True without its track: the labels decide)."""
    track = objects.get(name) if objects is not None and name is not None else None
    if track is None or not len(track.t_ns):
        return True
    t = (np.asarray(track.t_ns, dtype=np.int64) - t0_ns) * 1e-9
    pos = np.asarray(track.position, dtype=np.float64)
    during = (t >= step.start_s) & (t <= step.end_s) & np.all(np.isfinite(pos), axis=1)
    if not during.any():
        return True
    p = pos[during]
    return bool(np.max(np.linalg.norm(p - p[0], axis=1)) <= HOLD_STILL_M)


def _handover_point(lanes: dict[str, list[Segment]], handover: Any, t0_ns: int) -> SyncPoint | None:
    """The giver's ``place`` of the object ending nearest the handover's end, after the taker's
    ``pick_up`` of it ending nearest its start (None when a lane lacks either)."""
    giver, taker = lanes.get(handover.giver), lanes.get(handover.taker)
    if giver is None or taker is None:
        return None
    start, end = (int(handover.start_ns) - t0_ns) * 1e-9, (int(handover.end_ns) - t0_ns) * 1e-9
    obj = handover.object

    def nearest(segs: list[Segment], skill: str, t: float) -> int | None:
        found = [
            (abs(s.end_s - t), i)
            for i, s in enumerate(segs)
            if s.skill == skill and (obj is None or s.object == obj)
        ]
        return min(found)[1] if found else None

    g, k = nearest(giver, "place", end), nearest(taker, "pick_up", start)
    if g is None or k is None:
        return None
    return SyncPoint("handover", handover.giver, g, handover.taker, k, obj, start)
