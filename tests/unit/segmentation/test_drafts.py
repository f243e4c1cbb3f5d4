"""A segment's one shape while it is made (lfd.skills.Draft) and the skills' properties as data
(lfd.skills.TRAITS): every pass and rule reads them from there."""

from __future__ import annotations

import json

import _paths
import lfd
import numpy as np
from lfd.segmentation.comotion import _charged
from lfd.segmentation.drafts import make_segments
from lfd.segmentation.grammar import grammar, implicit_move_grammar_json
from lfd.segmentation.passes import label_moves
from lfd.segmentation.pipeline import as_trajectory
from lfd.skills import (
    CARRIED,
    NO_LIFT,
    NO_SET_DOWN,
    RELEASES,
    SKILLS,
    TARGET_STILL,
    TRAITS,
    Draft,
    skills_where,
)

EXP1 = _paths.RECORDINGS / "exp1.mcap"


def test_every_skill_has_its_properties_and_the_sets_are_read_from_them() -> None:
    assert set(TRAITS) == set(SKILLS)
    assert RELEASES == skills_where("releases") and RELEASES < set(NO_LIFT)
    assert TARGET_STILL.isdisjoint(CARRIED) and CARRIED <= NO_SET_DOWN
    # the implicit-Move grammar differs from the shipped one after the releases only
    plain, implicit = grammar()["transitions"], json.loads(implicit_move_grammar_json())
    changed = {s for s in plain if plain[s] != implicit["transitions"][s]}
    assert changed == RELEASES


def test_co_motion_charges_each_skill_by_its_properties() -> None:
    charged = _charged(list(SKILLS), True, 5.0, True)  # every count present
    for skill, counts in zip(SKILLS, charged, strict=True):
        t = TRAITS[skill]
        expected = [t.target_still, not t.sets_down, not t.lifts, t.carries, t.carries]
        assert counts == tuple(k for k, on in enumerate(expected) if on), skill


def test_drafts_become_segments_once_with_their_scores() -> None:
    traj = as_trajectory(lfd.load(EXP1))
    result = lfd.segment(traj)
    names = list(traj.object_names)
    drafts = [
        Draft(s.skill, s.start, s.end, names.index(s.object) if s.object else None, s.score,
              s.confidence, s.margin)
        for s in result.segments
    ]  # fmt: skip
    remade = make_segments(result.run.trajectory, drafts)  # type: ignore[union-attr]
    assert [s.to_dict() for s in remade] == [s.to_dict() for s in result.segments]
    # a Move's object is the one the hand reaches next: taken away, label_moves gives it back
    bare = [Draft(d.skill, d.start, d.end, None if d.skill == "move" else d.obj) for d in drafts]
    moves = [i for i, d in enumerate(drafts) if d.skill == "move"]
    assert moves and [label_moves(traj, bare)[i].obj for i in moves] == [
        drafts[i].obj for i in moves
    ]
    assert np.isfinite([s.score for s in result.segments if s.skill != "move"]).all()
