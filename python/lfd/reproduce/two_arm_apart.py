"""Where the planned arms still meet, the plan made again (:mod:`.two_arms`): a stacked box
taken away from the other arm's press, the two bases level with the work, or both; then the
same with a square box stacked a quarter turn round.

Each base is placed for the widest reach margin over its lane
(:func:`~.two_arm_bases.choose_bases`): for an arm with a long reach (the Panda's 0.38-0.71 m)
that is often behind the work (natural ``hold_stack`` 9504: both bases 0.33-0.43 m behind
the work's centre), both arms coming at the objects from the same side and their wrists
converging where one stacks 10 cm beside the other's press. Where the planned arms (every
rule of :mod:`.two_arm_holds` and :mod:`.two_arm_clearance` applied) still touch or come
closer than :data:`APART` (5 mm: the executed arms lag their plan; closer than
:data:`~.two_arm_clearance.CLEARANCE` but further than that, a run succeeds, and a plan
again costs its whole time), the whole plan is made again: first
with a box stacked beside the other arm's press taken at its end away from the press
(:func:`~.two_arm_clearance.stack_away`: the two wrists, each about 10 cm across, overlapped
where the stack and the press were 8 cm apart, natural ``hold_stack`` 9508), then with both
bases at most one of the robot's ``base_levels`` (m; :class:`~lfd.reproduce.aloha.TwoArmRobot`)
before or behind the work's centre (along y), so that the arms come at it from its two sides,
then with both; the plan whose arms stay furthest apart is kept
(:func:`~.two_arm_clearance.clearance_score`), the first when none is further apart.

Where they still touch, each of these again with a square box stacked there a quarter turn
round where its gripper could not take it across the line to the press
(:func:`~lfd.reproduce.modes.plan_task`'s ``turn_to_across``): a Panda's hand spans 20 cm
along its closing axis, and closing along that line it reached the pressing wrist (natural
``hold_stack`` 9510: a 53 mm cube stacked 12 cm from the press, taken along the line because
an 18 cm plank lay within the open fingers' room across it; -25 mm).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ..errors import DemonstrationError, UsageError

APART = 0.005
"""The least planned distance (m) between the arms below which the plan is made again: the
executed arms lag their plan by more than a millimetre (natural ``hold_stack`` 9519: kept
plans 0.5-1.3 mm apart, the wrists touching in the run)."""


def bases_apart(
    plan: Callable[[float, bool, bool], Any],
    score: Callable[[Any], tuple[float, int, int]],
    levels: tuple[float, ...],
) -> Any:
    """``plan(level, away, turn)`` (a :class:`~lfd.reproduce.two_arms.TwoArmPlan` with both
    bases at most ``level`` before or behind the work; ``away``: a stacked object taken at its
    end away from the other arm's press, None when no stack is beside a press; ``turn``: a
    square box stacked there a quarter turn round, None when none is) with the bases anywhere,
    or where that keeps the arms further apart: the object taken away from the press, then
    the bases at one of ``levels``, then both; then each of these with the box turned (the
    module docstring; ``score``: :func:`~.two_arm_clearance.clearance_score` of a plan's arms
    at its bases). Raises as ``plan`` does with the bases anywhere."""
    out = plan(np.inf, False, False)
    if len(out.plans) != 2:
        return out
    best = score(out)
    for level, away, turn in _trials(levels):
        if best[0] >= APART:
            break  # the planned arms are apart enough (a plan again costs its whole time)
        try:
            trial = plan(level, away, turn)
        except (DemonstrationError, UsageError):
            continue  # no base so placed reaches the lane, or its goals
        if trial is not None and (s := score(trial)) > best:
            out, best = trial, s
    return out


def _trials(levels: tuple[float, ...]) -> list[tuple[float, bool, bool]]:
    """(level, away, turn) of every plan :func:`bases_apart` tries after the first, in order."""
    unturned = [(np.inf, True), *((x, a) for a in (False, True) for x in levels)]
    turned = [(np.inf, False), *unturned]  # the first plan's rules, with the box turned
    return [(x, a, False) for x, a in unturned] + [(x, a, True) for x, a in turned]
