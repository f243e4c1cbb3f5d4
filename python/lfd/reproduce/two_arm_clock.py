"""The two arms' plans on one clock (:mod:`.two_arms`): where a step of a
:class:`~lfd.reproduce.controller.Plan` starts and ends, when its gripper opens, and a plan
made to wait."""

from __future__ import annotations

import numpy as np

from .controller import Plan


def _start(plan: Plan, k: int) -> int:
    """First tick of step ``k`` or of any later step (``len(plan)`` when none)."""
    idx = np.nonzero(plan.segment >= k)[0]
    return int(idx[0]) if idx.size else len(plan)


def _before(plan: Plan, at: int) -> int:
    """The step of the tick before ``at`` (-1 at the start: a wait belongs to no step)."""
    return int(plan.segment[at - 1]) if at > 0 else -1


def _wait(plan: Plan, at: int, n: int, segment: int) -> Plan:
    """``plan`` holding the pose of tick ``at - 1`` for ``n`` more ticks before tick ``at``."""
    if n <= 0:
        return plan
    i = max(at - 1, 0)
    rep = Plan(
        np.repeat(plan.position[i : i + 1], n, 0),
        np.repeat(plan.yaw[i : i + 1], n),
        np.repeat(plan.opening[i : i + 1], n),
        np.full(n, segment),
    )
    parts = [
        Plan(plan.position[:at], plan.yaw[:at], plan.opening[:at], plan.segment[:at]),
        rep,
        Plan(plan.position[at:], plan.yaw[at:], plan.opening[at:], plan.segment[at:]),
    ]
    return Plan.concat(parts)


def _end(plan: Plan, k: int) -> int:
    """The tick after the last of step ``k`` (its dwell and lift-off excluded)."""
    idx = np.nonzero(plan.segment == k)[0]
    return int(idx[-1]) + 1 if idx.size else _start(plan, k)


def _release(plan: Plan, k: int) -> int:
    """The tick at which the gripper opens after step ``k`` (``len(plan)`` when it does not)."""
    i0 = _end(plan, k)
    if i0 == 0 or i0 >= len(plan):
        return len(plan)
    idx = np.nonzero(plan.opening[i0:] > plan.opening[i0 - 1] + 1e-6)[0]
    return i0 + int(idx[0]) if idx.size else len(plan)
