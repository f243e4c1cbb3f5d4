"""The skill grammar (paper Fig. 6), shipped as data in ``lfd/data/grammar.json``.

Defined in :mod:`lfd.skills` (the simulator uses it too); re-exported here for the segmentation.
"""

from __future__ import annotations

import json
from functools import cache

from ..skills import SKILLS, allowed, grammar, grammar_json, impossible_transitions

__all__ = [
    "SKILLS",
    "allowed",
    "grammar",
    "grammar_json",
    "implicit_move_grammar_json",
    "impossible_transitions",
    "needs_implicit_move",
]

RELEASES: tuple[str, ...] = ("place", "stack")
"""Skills after which the hand may re-grasp without a visible Move."""


@cache
def implicit_move_grammar_json() -> str:
    """The grammar with a Move that may be *implicit*: a Place or Stack may be followed directly
    by whatever may follow a Move (the segmentation then inserts the Move; see
    :func:`lfd.segmentation.pipeline.insert_implicit_moves`)."""
    g = grammar()
    after_move = list(g["transitions"]["move"])
    for skill in RELEASES:
        g["transitions"][skill] = list(dict.fromkeys([*g["transitions"][skill], *after_move]))
    g["description"] = g.get("description", "") + " (Move after Place/Stack may be implicit)"
    return json.dumps(g)


def needs_implicit_move(prev: str, nxt: str) -> bool:
    """Does the transition ``prev -> nxt`` stand for ``prev -> move -> nxt``?"""
    return prev in RELEASES and not allowed(prev, nxt) and allowed("move", nxt)
