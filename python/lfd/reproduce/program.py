"""The task program the robot executes: an ordered list of skill segments.

Both sources of a segmentation map onto it: the ground-truth labels of a recording
(:func:`from_labels`) and the segmentation engine's result, exported as JSON::

    {"segments": [{"skill": "pick_up", "start_s": 1.2, "end_s": 3.4,
                   "object": "box_1", "params": {}}, ...]}

Times are seconds since the first sample of the preprocessed trajectory. ``object`` is the
target object of the skill (``null`` for ``move``; for ``move_with`` the carried object).
``params`` is free (e.g. ``{"support": "box_2"}`` for a stack, filled in from the demonstration
when missing).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from ..errors import DemonstrationError, LfdError
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
    def from_json(cls, data: dict[str, Any] | Sequence[dict[str, Any]]) -> TaskProgram:
        """Build from the JSON layout (a dict with ``segments`` or a bare list)."""
        items = data.get("segments") if isinstance(data, dict) else data
        if not isinstance(items, list):
            raise DemonstrationError("task program JSON needs a 'segments' list")
        segs = []
        for i, item in enumerate(items):
            if not isinstance(item, dict) or "skill" not in item:
                raise DemonstrationError(f"task program segment {i} is not an object with 'skill'")
            try:
                segs.append(
                    Segment(
                        skill=str(item["skill"]),
                        start_s=float(item["start_s"]),
                        end_s=float(item["end_s"]),
                        object=item.get("object"),
                        params=dict(item.get("params") or {}),
                    )
                )
            except (KeyError, TypeError, ValueError) as err:
                if isinstance(err, LfdError):
                    raise
                raise DemonstrationError(f"task program segment {i}: {err}") from err
        return cls(segs)

    @classmethod
    def load(cls, path: str | Path) -> TaskProgram:
        """Read a task program JSON file."""
        from ..inputs import parse_json, read_text

        try:
            text = read_text(path, "task program", DemonstrationError)
        except OSError as err:
            raise DemonstrationError(f"cannot read task program {path}: {err}") from err
        return cls.from_json(
            parse_json(text, f"cannot read task program {path}", DemonstrationError)
        )

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
