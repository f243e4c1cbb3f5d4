"""The skill grammar (paper Fig. 6), shipped as data in ``lfd/data/grammar.json``.

Defined in :mod:`lfd.skills` (the simulator uses it too); re-exported here for the segmentation.
"""

from __future__ import annotations

from ..skills import SKILLS, allowed, grammar, grammar_json, impossible_transitions

__all__ = ["SKILLS", "allowed", "grammar", "grammar_json", "impossible_transitions"]
