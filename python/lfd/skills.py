"""The seven skills of the paper and their canonical names.

Canonical names are used everywhere (files, CLI, engine): ``pick_up, place, locate, stack, push,
move, move_with``.
"""

from __future__ import annotations

import json
from functools import cache
from importlib import resources
from typing import Any

from .errors import UnknownSkillError

SKILLS: tuple[str, ...] = ("pick_up", "place", "locate", "stack", "push", "move", "move_with")
"""Canonical skill names, in the engine's index order."""


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
