"""One arm's lane of a two-arm plan over a layout (:func:`lfd.reproduce.two_arms.plan_two_arms`):
planned from its base with the objects where the layout puts them, knowing where the other arm
puts the objects only it handles."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import UsageError
from .arm import Robot
from .program import TaskProgram


def lifted(scene: dict[str, np.ndarray], names: set[str]) -> dict[str, np.ndarray]:
    """``scene`` with the objects ``names`` taken off the table (10 m up): out of the overlap
    and crowding checks of a lane that does not know where they are."""
    out = dict(scene)
    for n in names & set(scene):
        out[n] = scene[n].copy()
        out[n][2, 3] += 10.0
    return out


def plan_lane(
    traj: Any,
    program: TaskProgram,
    mode: str,
    moved: dict[str, np.ndarray],
    base: np.ndarray,
    arm: Robot,
    displace: dict[str, Any],
    others: set[str],
    events: list[tuple[float, str, np.ndarray]],
    grasp_at: dict[str, np.ndarray] | None = None,
    grasp_across: dict[str, int] | None = None,
    push_by_grasp: set[str] | None = None,
    carry_to_grasp: bool = False,
    turn_to_across: bool = False,
) -> tuple[Any, dict[str, np.ndarray], Any]:
    """One lane planned from ``base`` with the objects where the layout puts them (``moved``):
    :func:`~lfd.reproduce.displacement.plan_layout` with the base fixed, its re-grounded
    goals checked (:func:`~lfd.reproduce.displacement.check_goals`) when displaced, against
    every object but ``others`` (those the other arm moves); ``grasp_at``, ``grasp_across``,
    ``push_by_grasp``, ``carry_to_grasp``, ``turn_to_across``: as
    :func:`~lfd.reproduce.modes.plan_task`'s."""
    from .displacement import program_start
    from .goals import DemoFrames
    from .modes import plan_task

    frames = DemoFrames(traj, base, arm)
    start_i = program_start(traj, program)
    initial = {n: moved.get(n, frames.object_pose(n, start_i)) for n in frames.names}
    result = plan_task(
        frames,
        program,
        mode,
        initial=dict(moved),
        events=events,
        grasp_at=grasp_at,
        grasp_across=grasp_across,
        push_by_grasp=push_by_grasp,
        carry_to_grasp=carry_to_grasp,
        turn_to_across=turn_to_across,
    )
    check_lane_goals((frames, initial, result), displace, others)
    return frames, initial, result


def check_lane_goals(
    lane: tuple[Any, dict[str, np.ndarray], Any],
    displace: dict[str, Any],
    others: set[str],
    side: str | None = None,
) -> None:
    """A planned lane's re-grounded goals checked when displaced
    (:func:`~lfd.reproduce.displacement.check_goals`: reach from its arm's base, the table,
    clear of the other objects) in every scene of its plan, the objects only the other arm
    moves (``others``) off the table as they start; ``side`` names the arm in the error."""
    from .displacement import check_goals

    if not displace:
        return
    frames, initial, result = lane
    away = lifted(initial, others)
    scenes = [sc | {n: away[n] for n in others if n in away} for sc in result.scenes]
    try:
        check_goals(frames, away, scenes, displace)
    except UsageError as err:
        if side is None:
            raise
        raise named_arm(err, side) from err


def named_arm(err: Exception, side: str) -> UsageError:
    """``err`` as one line naming the ``side`` arm (``left arm: ... the left arm's reach``)."""
    msg = str(err).replace("the arm's reach", f"the {side} arm's reach")
    return UsageError(f"{side} arm: {msg}")


def lane_events(
    planned: dict[str, tuple[Any, Any, Any]], side: str, others: set[str]
) -> list[tuple[float, str, np.ndarray]]:
    """Where the other arms' plans put the objects only they handle, from the end of each of
    their places, stacks and pushes on (demonstration time): ``side``'s lane then re-grounds a
    skill relative to such an object where it will be, not where it started."""
    out = []
    for o, (_, _, r) in planned.items():
        if o == side or r.program is None:
            continue
        acting = [g for g in r.program.segments if g.skill in ("place", "stack", "push")]
        if len(acting) + 1 != len(r.scenes):
            continue
        out += [
            (g.end_s, g.object, sc[g.object])
            for g, sc in zip(acting, r.scenes, strict=False)
            if g.object in others and g.object in sc
        ]
    return out
