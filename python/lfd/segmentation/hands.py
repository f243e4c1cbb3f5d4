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

from collections.abc import Sequence
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

    def report(
        self,
        ground_truth: Sequence[SkillLabel] = (),
        handovers: Sequence[Handover] = (),
        *,
        recording: str | None = None,
    ) -> dict[str, Any]:
        """The document of ``lfd segment --json`` on a two-hand recording: ``hands`` (each
        lane's one-hand document, :meth:`Segmentation.report`, against that hand's labels of
        ``ground_truth``), ``handovers`` (seconds from the first sample too), ``warnings``
        (across the lanes) and ``metrics``: per hand, and ``handovers``
        (:func:`~lfd.segmentation.metrics.handover_scores` against ``handovers``) when there
        is ground truth."""
        from .metrics import handover_scores

        hands = {
            side: seg.report(
                [lab for lab in ground_truth if lab.hand in (side, None)], recording=recording
            )
            for side, seg in self.lanes.items()
        }
        origin = min(seg.origin_ns for seg in self.lanes.values())
        doc: dict[str, Any] = {
            "recording": recording,
            "method": next(iter(self.lanes.values())).method,
            "origin_ns": origin,
            "hands": hands,
            "handovers": [
                {
                    **h,
                    "start_s": (h["start_ns"] - origin) * 1e-9,
                    "end_s": (h["end_ns"] - origin) * 1e-9,
                }
                for h in self.to_dict()["handovers"]
            ],
            "warnings": list(self.warnings),
            "metrics": {},
        }
        if self.method is not None:
            doc["method_detail"] = self.method.describe()
        if ground_truth:
            doc["metrics"] = {side: hands[side]["metrics"] for side in self.lanes}
            scores = handover_scores(self.handovers, handovers)
            doc["metrics"]["handovers"] = {k: (v if v == v else None) for k, v in scores.items()}
        return doc

    def lane_runs(self) -> dict[str, Any]:
        """Each lane's :class:`~lfd.segmentation.result.Run` by side (None for a baseline)."""
        return {side: seg.run for side, seg in self.lanes.items()}
