"""Both hands of a demonstration segmented together: one lane of skills per hand, and the
handovers that both lanes share (docs/skills.md, "Two hands").

>>> import lfd
>>> result = lfd.segment_hands(lfd.load("two_hands.mcap"))       # doctest: +SKIP
>>> result.lanes["left"].skill_sequence                           # doctest: +SKIP
['move', 'pick_up', 'move_with', 'place', 'move']
>>> result.handovers                                              # doctest: +SKIP
[Handover(start_ns=..., end_ns=..., giver='left', taker='right', object='mug')]

A one-hand demonstration gives one lane, equal to :func:`lfd.segment`'s result.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from ..demo import Handover, SkillLabel

if TYPE_CHECKING:
    from .result import Segmentation


@dataclass
class HandsSegmentation:
    """A demonstration's hands cut into skills, one lane per hand.

    Attributes
    ----------
    lanes : dict[str, Segmentation]
        Each hand's segmentation by side, the right hand first; a segment's ``object`` is held
        by that hand alone or with the other (a two-handed carry), never by a hand that does
        not touch it.
    handovers : list[Handover]
        The objects passed from one hand to the other, in time order: in the giver's lane a
        ``place`` ends at ``end_ns``, in the taker's a ``pick_up`` ends at ``start_ns`` or
        later.
    warnings : list[str]
        What checking the lanes against each other found (prefixed by the hand's side), beside
        each lane's own warnings.
    method : Method or None
        The method every lane was segmented with, once for the run (each lane's
        :class:`~lfd.segmentation.result.Run` keeps its own trajectory, features and scores).
    """

    lanes: dict[str, Segmentation]
    handovers: list[Handover] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    method: Any = field(default=None, repr=False, compare=False)

    @property
    def sides(self) -> tuple[str, ...]:
        """The sides of the lanes, the right first."""
        return tuple(self.lanes)

    def to_labels(self) -> list[SkillLabel]:
        """Every lane's segments as labels naming their hand, in time order."""
        labels = [
            SkillLabel(lab.skill, lab.start_ns, lab.end_ns, lab.object, hand=side)
            for side, seg in self.lanes.items()
            for lab in seg.to_labels()
        ]
        return sorted(labels, key=lambda lab: (lab.start_ns, lab.end_ns, lab.hand or ""))

    def to_dict(self) -> dict[str, Any]:
        """The lanes' task programs and the handovers as a JSON-ready dict."""
        return {
            "hands": {side: seg.to_dict() for side, seg in self.lanes.items()},
            "handovers": [
                {
                    "start_ns": h.start_ns,
                    "end_ns": h.end_ns,
                    "giver": h.giver,
                    "taker": h.taker,
                    "object": h.object,
                }
                for h in self.handovers
            ],
            "warnings": list(self.warnings),
        }

    def lane_runs(self) -> dict[str, Any]:
        """Each lane's :class:`~lfd.segmentation.result.Run` by side (None for a baseline)."""
        return {side: seg.run for side, seg in self.lanes.items()}
