"""The seven skills of the paper and their canonical names.

Canonical names are used everywhere (files, CLI, engine): ``pick_up, place, locate, stack, push,
move, move_with``.
"""

from __future__ import annotations

from .errors import UnknownSkillError

SKILLS: tuple[str, ...] = ("pick_up", "place", "locate", "stack", "push", "move", "move_with")
"""Canonical skill names, in the engine's index order."""

DISPLAY_NAMES: dict[str, str] = {
    "pick_up": "Pick up",
    "place": "Place",
    "locate": "Locate",
    "stack": "Stack",
    "push": "Push",
    "move": "Move",
    "move_with": "Move with",
}


def check_skill(name: str) -> str:
    """Return ``name`` if it is a canonical skill name, else raise :class:`UnknownSkillError`."""
    if name not in SKILLS:
        raise UnknownSkillError(f"unknown skill {name!r}; known skills: {', '.join(SKILLS)}")
    return name


def skill_index(name: str) -> int:
    """Index of a skill in :data:`SKILLS` (the engine's numbering)."""
    return SKILLS.index(check_skill(name))
