"""What a segmentation is set to besides its templates: the stage-2 searches and grammar uses,
their defaults and the paper's, and :class:`SegmentParams` (stage 1, stage 2, the co-motion
evidence, the passes). :class:`~lfd.segmentation.method.Method` holds them with the templates;
:func:`~lfd.segmentation.pipeline.segment_trajectory` runs them."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

from .._hmmseg import EndState, GrammarMode
from ..contact import ContactParams
from .stage1 import Stage1Params

Search = Literal["dp", "greedy"]
"""The stage-2 search: the segmental DP or the paper's greedy loop."""
GrammarUse = GrammarMode
"""How the skill grammar is used (the engine's ``GrammarMode``: "off", "warn", "enforce")."""

DEFAULT_SEARCH: Search = "dp"
"""The default stage-2 search: the segmental DP (11/12 exact sequences on held-out demos, against
6/12 for the paper's greedy loop; docs/segmentation.md)."""
DEFAULT_GRAMMAR: GrammarUse = "enforce"
"""The default grammar use: only allowed skill transitions are considered."""
PAPER_SEARCH: Search = "greedy"
"""The paper's algorithm: the greedy cut loop of Eq. 3-5..."""
PAPER_GRAMMAR: GrammarUse = "warn"
"""...keeping the best result and warning about impossible transitions (Fig. 6)."""


@dataclass(frozen=True)
class SegmentParams:
    """Parameters of the segmentation beyond the templates.

    Attributes
    ----------
    stage1 : Stage1Params
        Stage-1 hysteresis and minimum section length.
    end : {"final", "any"}
        ``final``: a segment must end in the last state of the skill's left-right HMM (a
        complete execution); ``any``: the plain forward likelihood of Eq. 3.
    min_rise : float
        A run of sections is "rising" (Fig. 5: only Move / Move with) if the TCP climbs at least
        this much (metres) in one go (largest rise inside the run)...
    dominance : float
        ...and its summed climb is at least ``dominance`` times its summed descent (0: off).
    max_segment_s : float
        Longest skill segment considered (seconds; the template skills last 1-4 s); bounds the
        forward passes.
    lookahead : bool
        Greedy search: value each candidate cut by its per-sample score together with the best
        segment that may follow it, instead of its own per-sample score alone (measured in
        docs/segmentation.md: 14 -> 19 of 24 exact sequences with the grammar enforced).
    penalty : float
        Per-segment penalty of the DP (nats).
    min_duration_s : float
        A demonstration shorter than this cannot hold a skill (DemonstrationError).
    co_motion : float
        Co-motion evidence (beyond the paper): a skill acts on its own object only, so every
        sample of a segment in which another object moves (speed above ``v_th``), or in which
        the target itself moves during a Move or Locate, costs this many nats
        (:func:`~lfd.segmentation.comotion.co_motion_penalty`; 0: off). Without it a segment
        can explain a real carry of one box as an empty-hand Move "relative to" a box that
        stays put.
    co_motion_grace_s : float
        Object motion this close to a segment's ends is not charged (boundaries are uncertain
        by about this much).
    co_motion_slide_s : float
        A carried target (Move with) moves while it still rests on the table only as it is
        lifted off (0.07-0.23 s in the ground truth of the tuning demos; a Push slides its box
        0.37-1 s): beyond this much sliding, every sliding sample costs ``co_motion`` nats
        (:data:`lfd.skills.CARRIED`; negative: off). Without it a Push is read live as Pick
        up -> Move with until the missing Place shows it.
    co_motion_left_s : float
        A carried target moves with the hand: beyond this many seconds in which the hand moves
        (:func:`~lfd.segmentation.comotion.moving_hand`) while the target stays (at most 0.4 s
        in the ground truth of the tuning demos, median 0), every such sample of a Move with
        costs ``co_motion`` nats (negative: off). Without it a Push, or a Move away from a box,
        is read live as a Move with that is never put down.
    implicit_moves : bool
        A Move between a release (Place, Stack) and the next skill may be shorter than a stage-1
        section: when the hand re-grasps the object it has just put down, it opens a little,
        rises a few millimetres and closes again in 0.1-0.3 s. With this on the search may go
        from the release straight to the next skill and the Move is inserted around the
        TCP's highest point between them (:func:`~lfd.segmentation.passes.insert_implicit_moves`).
    implicit_move_s : float
        Length of an inserted Move (seconds).
    contacts : ContactParams or None
        Put the boundaries of the skills that touch an object where contact says
        (:func:`lfd.contact.refine`: a Pick up from the last sample the hand was 8 cm from the
        object to its first motion, a Place or Stack to the release, the Moves around them);
        None: the search's boundaries as they are (the paper).
    co_motion_window_s, co_motion_displacement : float
        An object moves at a sample when it is displaced by more than ``co_motion_displacement``
        metres between ``co_motion_window_s`` before and after it
        (:func:`~lfd.segmentation.comotion.moving_objects`; a displacement, unlike a speed
        threshold, ignores tag noise and interpolated gaps).
    """

    stage1: Stage1Params = field(default_factory=Stage1Params)
    end: EndState = "final"
    min_rise: float = 0.025
    dominance: float = 0.0
    max_segment_s: float = 10.0
    lookahead: bool = True
    penalty: float = 10.0
    min_duration_s: float = 0.5
    co_motion: float = 20.0
    co_motion_grace_s: float = 0.0
    co_motion_slide_s: float = 0.25
    co_motion_left_s: float = 0.4
    co_motion_window_s: float = 1.0 / 6.0
    implicit_moves: bool = True
    implicit_move_s: float = 0.2
    co_motion_displacement: float = 0.015
    contacts: ContactParams | None = field(default_factory=ContactParams)

    def __post_init__(self) -> None:
        from ..rules import check_fields
        from .schema import SEGMENT_RULES

        check_fields(self, SEGMENT_RULES, "params.")


PAPER_PARAMS = SegmentParams(
    stage1=Stage1Params(object_criteria=False, min_section_s=0.2),
    min_rise=0.02,
    co_motion=0.0,
    implicit_moves=False,
    contacts=None,
)
"""The paper's pipeline around the search (with :data:`PAPER_SEARCH`, :data:`PAPER_GRAMMAR` and the
paper-recipe templates, ``lfd segment --paper``): stage 1 on the hand signals only (sections
>= 0.2 s), a 2 cm rise threshold, no co-motion evidence, no implicit moves."""
