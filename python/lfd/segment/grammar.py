"""The skill grammar (paper Fig. 6) shipped as data in ``lfd/data/grammar.json``."""

from __future__ import annotations

import json
from functools import cache
from importlib import resources
from typing import Any

from ..skills import SKILLS


@cache
def grammar_json() -> str:
    """The grammar file's text (passed to the engine as is)."""
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


__all__ = ["SKILLS", "allowed", "grammar", "grammar_json", "impossible_transitions"]
