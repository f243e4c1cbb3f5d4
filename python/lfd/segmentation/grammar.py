"""The skill grammar (paper Fig. 6), shipped as data in ``lfd/data/grammar.json``.

Defined in :mod:`lfd.skills` (the simulator uses it too); re-exported here for the segmentation.
"""

from __future__ import annotations

import json
from functools import cache

from .. import _hmmseg
from ..skills import RELEASES, SKILLS, allowed, grammar, grammar_json, impossible_transitions

__all__ = [
    "SKILLS",
    "allowed",
    "compiled_grammar",
    "grammar",
    "grammar_json",
    "implicit_move_grammar_json",
    "impossible_transitions",
    "needs_implicit_move",
    "needs_move_between",
]


@cache
def implicit_move_grammar_json() -> str:
    """The grammar with a Move that may be *implicit*: a Place or Stack may be followed directly
    by whatever may follow a Move (the segmentation then inserts the Move; see
    :func:`lfd.segmentation.passes.insert_implicit_moves`)."""
    g = grammar()
    after_move = list(g["transitions"]["move"])
    for skill in sorted(RELEASES):  # after a release the hand may re-grasp at once
        g["transitions"][skill] = list(dict.fromkeys([*g["transitions"][skill], *after_move]))
    g["description"] = g.get("description", "") + " (Move after Place/Stack may be implicit)"
    return json.dumps(g)


@cache
def compiled_grammar(skills: tuple[str, ...], implicit_moves: bool) -> _hmmseg.Grammar:
    """The grammar as the engine's search takes it, bound to the skill order ``skills`` (the
    templates'): the shipped grammar, or with ``implicit_moves`` the one whose Move after a
    release may be implicit (:func:`implicit_move_grammar_json`). Parsed and checked once per
    skill order (a bad grammar is an :class:`~lfd.errors.ModelFormatError`, a ``ValueError``)."""
    rules = implicit_move_grammar_json() if implicit_moves else grammar_json()
    return _hmmseg.Grammar(rules, list(skills))


@cache
def needs_implicit_move(prev: str, nxt: str) -> bool:
    """Does the transition ``prev -> nxt`` stand for ``prev -> move -> nxt``?"""
    return prev in RELEASES and not allowed(prev, nxt) and allowed("move", nxt)


def needs_move_between(
    prev: str, prev_object: str | None, nxt: str, nxt_object: str | None
) -> bool:
    """Does ``prev`` on ``prev_object`` followed by ``nxt`` on ``nxt_object`` stand for a Move
    between them? After a release (:func:`needs_implicit_move`), and after a Locate of one object
    followed by a skill on another: the grammar lets a Locate lead straight into a Pick up or
    Push of the object it located, but the hand has to travel to another object."""
    if needs_implicit_move(prev, nxt):
        return True
    return (
        prev == "locate"
        and nxt != "move"
        and allowed("move", nxt)
        and prev_object is not None
        and nxt_object is not None
        and prev_object != nxt_object
    )
