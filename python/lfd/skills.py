"""The seven skills of the paper: their canonical names, their properties, the grammar, and a
skill on a span of samples being drafted (:class:`Draft`).

Canonical names are used everywhere (files, CLI, engine): ``pick_up, place, locate, stack, push,
move, move_with``.
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass
from functools import cache
from importlib import resources
from typing import Any

from .errors import UnknownSkillError

SKILLS: tuple[str, ...] = ("pick_up", "place", "locate", "stack", "push", "move", "move_with")
"""Canonical skill names, in the engine's index order."""


@dataclass(frozen=True)
class SkillTraits:
    """What a skill does to its target object: the one table of these properties
    (:data:`TRAITS`), read by the contact rules (:mod:`lfd.contact`), the co-motion evidence,
    the implicit Moves and the skill parameters of the segmentation.

    Attributes
    ----------
    releases : bool
        Ends by letting go of the object (Place, Stack): a Move follows, possibly implicit.
    target_still : bool
        The target does not move (Move, Locate, Pick up: a Pick up ends when the fingers have
        closed, before the lift).
    lifts : bool
        May lift a resting target (not Place, Stack: after them that is a new Pick up; not
        Push: it slides its object on the table).
    sets_down : bool
        May put a lifted target down (not Move with, Pick up: that is a Place or a Stack).
    carries : bool
        Carries its target lifted (Move with): it slides on the table only while it is lifted
        off.
    touches : bool
        The hand touches its target (not Move, Locate): with two hands, only a hand at the
        object has such a skill of it (docs/skills.md, "Two hands").
    """

    releases: bool = False
    target_still: bool = False
    lifts: bool = True
    sets_down: bool = True
    carries: bool = False
    touches: bool = True


TRAITS: dict[str, SkillTraits] = {
    "pick_up": SkillTraits(target_still=True, sets_down=False),
    "place": SkillTraits(releases=True, lifts=False),
    "locate": SkillTraits(target_still=True, touches=False),
    "stack": SkillTraits(releases=True, lifts=False),
    "push": SkillTraits(lifts=False),
    "move": SkillTraits(target_still=True, touches=False),
    "move_with": SkillTraits(sets_down=False, carries=True),
}
"""The properties of each skill: the one copy (every set of skill names below is read from it)."""


def skills_where(test: str, value: bool = True) -> frozenset[str]:
    """The skills whose property ``test`` (a :class:`SkillTraits` field) is ``value``."""
    return frozenset(s for s in SKILLS if getattr(TRAITS[s], test) is value)


RELEASES: frozenset[str] = skills_where("releases")
"""Skills that end by letting go of the object (Place, Stack)."""
TARGET_STILL: frozenset[str] = skills_where("target_still")
"""Skills whose target object does not move (Move, Locate, Pick up)."""
NO_LIFT: frozenset[str] = skills_where("lifts", False)
"""Skills in which a resting target is not lifted (Place, Stack, Push)."""
NO_SET_DOWN: frozenset[str] = skills_where("sets_down", False)
"""Skills in which a lifted target is not put down again (Move with, Pick up)."""
CARRIED: frozenset[str] = skills_where("carries")
"""Skills that carry their target lifted (Move with)."""
TOUCHING: frozenset[str] = skills_where("touches")
"""Skills whose target the hand touches (all but Move and Locate)."""


@dataclass
class Draft:
    """A skill on samples ``start..end`` (end exclusive) of a trajectory, its target object an
    index ``obj`` into the trajectory's objects (None: none), with the search's ``score``,
    ``confidence`` and ``margin`` of it (NaN where no template scored it: an inserted Move).

    The one shape of a segment while it is being made: the search's output becomes drafts once,
    every pass of the segmentation (implicit Moves, contact boundaries: :func:`lfd.contact.refine`,
    Move objects) takes and returns them, and they become
    :class:`~lfd.segmentation.result.Segment` once, at the end
    (:func:`lfd.segmentation.drafts.make_segments`). A pass that changes a draft returns a new
    one (:meth:`resized`, :func:`dataclasses.replace`) or changes its own copy.
    """

    skill: str
    start: int
    end: int
    obj: int | None = None
    score: float = math.nan
    confidence: float = math.nan
    margin: float = math.nan

    def resized(self, start: int, end: int) -> Draft:
        """The same skill, target and scores on ``start..end``."""
        return dataclasses.replace(self, start=start, end=end)

    def object_name(self, names: list[str]) -> str | None:
        """The target object's name (``names``: the trajectory's objects)."""
        return names[self.obj] if self.obj is not None else None

    @property
    def span(self) -> tuple[str, int, int, int | None]:
        """``(skill, start, end, obj)``: what the draft says, without its scores."""
        return (self.skill, self.start, self.end, self.obj)


def check_skill(name: str) -> str:
    """Return ``name`` if it is a canonical skill name, else raise :class:`UnknownSkillError`."""
    if name not in SKILLS:
        raise UnknownSkillError(f"unknown skill {name!r}; known skills: {', '.join(SKILLS)}")
    return name


def skill_index(name: str) -> int:
    """Index of a skill in :data:`SKILLS` (the engine's numbering)."""
    return SKILLS.index(check_skill(name))


# --- the skill grammar (paper Fig. 6), shipped as data in lfd/data/grammar.json ---------------
@cache
def grammar_json() -> str:
    """The grammar file's text (the engine takes it as is)."""
    return resources.files("lfd").joinpath("data/grammar.json").read_text(encoding="utf-8")


def grammar() -> dict[str, Any]:
    """The grammar as a dict: ``start``, ``transitions``, ``rising``, ``groups``."""
    return dict(json.loads(grammar_json()))


def allowed(prev: str | None, nxt: str) -> bool:
    """May skill ``nxt`` follow ``prev`` (``None`` = start of the demonstration)?"""
    g = grammar()
    if prev is None:
        return nxt in g["start"]
    return nxt in g["transitions"].get(prev, [])


def impossible_transitions(sequence: list[str]) -> list[str]:
    """Human-readable list of the transitions in ``sequence`` that the grammar forbids."""
    out = []
    prev: str | None = None
    for n, s in enumerate(sequence):
        if not allowed(prev, s):
            out.append(f"impossible skill transition {prev or 'start'} -> {s} (segment {n})")
        prev = s
    return out
