"""A two-hand program on two arms over randomised layouts (``lfd reproduce REC --robot aloha
--randomise N``): :mod:`.randomise`'s draws, re-grounding, progress and JSON, with both arms.

Every layout moves the objects as for one arm (:func:`~lfd.reproduce.randomise.iter_layouts`:
each free object shifted up to ``max_shift`` and turned up to ``max_turn_deg``, a stack moved as
one). A draw is rejected and drawn again, as one arm's is, when for a mode

* both lanes cannot be planned (:func:`~lfd.reproduce.two_arms.plan_two_arms`): an arm has no
  base on its side from which it reaches all of its re-grounded path (``out of the right arm's
  reach``), or a lane's re-grounded task would put an object out of its arm's reach, off the
  table or into another object (:func:`~lfd.reproduce.displacement.check_goals`);
* two objects on the table are closer than :data:`~lfd.reproduce.randomise.LAYOUT_GAP`
  (between their footprints, not their circumscribed circles as for one arm: the handover's
  16 cm bar) at the start or after a skill of a lane (there only the objects the other arm does not move: where
  it has them then is not planned), or overlap where both arms leave them (the end: a push may
  end a box next to the box the other arm holds, as the demonstrator does).

Each layout's rejections are counted by kind (naming the arm) in
:attr:`~lfd.reproduce.randomise.Layout.rejected`. Each run reports the task's success, each
arm's (:meth:`~lfd.reproduce.two_arms.TwoArmReproduction.arm_success`) and every failure
naming the arm (a collision of the two arms or of an arm with the table included).
:func:`iter_two_arm_layouts` draws the same layouts one at a time, each with its plans (robot
data: ``lfd export robot-data --robot aloha``).
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import DemonstrationError, UsageError
from .aloha import TwoArmRobot
from .displacement import STACK_SLACK, Displacement, _overlap, check_program
from .goals import yaw_of
from .measures import path_length
from .program import HandsProgram, TaskProgram
from .randomise import (
    LAYOUT_GAP,
    MAX_SHIFT,
    MAX_TURN_DEG,
    Layout,
    Randomised,
    iter_layouts,
    run_randomised,
)
from .two_arm_lanes import lifted
from .two_arms import (
    TwoArmPlan,
    TwoArmReproduction,
    check_runs,
    plan_two_arms,
    prepare_two_arms,
    reproduce_two_arms,
    run_two_arm_plan,
)


def check_busy(hands: HandsProgram, robot: str) -> None:
    """Refuse, in one line, randomising a two-hand program on two arms when a hand has no
    step: the other hand's task is one arm's (``--robot kuka_lwr4`` or ``panda``)."""
    busy = [s for s in hands.sides if hands.lanes[s]]
    if len(busy) < 2:
        raise UsageError(
            f"--randomise with --robot {robot} takes a two-hand recording (here "
            f"{'only the ' + busy[0] + ' hand has' if busy else 'no hand has'} steps); "
            "--robot kuka_lwr4 or panda randomises a one-hand task"
        )


def _first_lane(trajs: dict[str, Any], hands: HandsProgram) -> str:
    """The lane that starts first (the objects' initial poses are taken where it starts)."""
    sides = [s for s in hands.sides if hands.lanes[s]]
    if not sides:
        raise DemonstrationError("the task program has no step for any hand")
    return min(sides, key=lambda s: hands.lanes[s][0].start_s)


def _check_program(
    trajs: dict[str, Any], hands: HandsProgram, modes: Sequence[str], robot: TwoArmRobot
) -> str:
    """Refuse what no layout changes (a synchronisation the arms do not run, a hand with no
    arm, an object no gripper holds: one both arms carry or one pressed is held without a
    grasp); the lane the layouts are drawn from."""
    from .two_arm_sequence import carried_by_both

    check_runs(hands)
    missing = [s for s in hands.sides if s not in robot.arms]
    if missing:
        raise DemonstrationError(f"the {missing[0]} hand has no arm on {robot.name}")
    if any(m != "replay" for m in modes):
        prepared, _, presses = prepare_two_arms(trajs, hands, robot)
        held = carried_by_both(prepared) | {str(p.object) for p in presses.values()}
        for side in hands.sides:
            steps = [g for g in prepared.lanes[side] if g.object not in held]
            if steps:
                check_program(trajs[side], TaskProgram(steps), robot.ik)
    return _first_lane(trajs, hands)


def check_two_arm_layout(
    trajs: dict[str, Any],
    hands: HandsProgram,
    displace: dict[str, Displacement],
    *,
    robot: TwoArmRobot,
    modes: Sequence[str] = ("skills", "dmp"),
    gap: float = LAYOUT_GAP,
    planned: dict[str, TwoArmPlan] | None = None,
) -> str | None:
    """Why a layout cannot be used by the two arms (one line naming the arm), or None when
    both lanes are planned, reachable and uncrowded in each of ``modes`` (replay is not
    re-grounded: it is planned as skills). ``planned`` (when given) gets each mode's plan."""
    for mode in dict.fromkeys(m if m != "replay" else "skills" for m in modes):
        try:
            plan = plan_two_arms(trajs, hands, mode, robot=robot, displace=displace)
        except (UsageError, DemonstrationError) as err:
            msg = str(err)
            m = re.match(r"the (\w+) arm .*cannot reach", msg)
            return f"out of the {m.group(1)} arm's reach: {msg}" if m else msg
        frames, start, _ = plan.planned[plan.sides[0]]
        scenes = [start]  # every object at the start, then a lane's own objects meanwhile
        for side, (_, _, result) in plan.planned.items():
            scenes += [lifted(sc, plan.others(side)) for sc in result.scenes]
        for scene in scenes:
            crowded = _crowded(frames, scene, gap)
            if crowded:
                return crowded
        overlap = _overlapping(frames, plan.expected)
        if overlap:
            return overlap
        if planned is not None:
            planned[mode] = plan
    return None


def _corners(T: np.ndarray, size: np.ndarray) -> np.ndarray:
    """The 4 corners (x, y) of an upright box's footprint."""
    c, s = np.cos(yaw_of(T[:3, :3])), np.sin(yaw_of(T[:3, :3]))
    half = np.array([[1, 1], [1, -1], [-1, -1], [-1, 1]]) * np.asarray(size[:2]) / 2
    return T[:2, 3] + half @ np.array([[c, s], [-s, c]])


def _footprint_gap(a: np.ndarray, b: np.ndarray) -> float:
    """Distance (m) between two disjoint convex footprints (corner arrays): the nearest corner
    of one to an edge of the other."""

    def to_edges(p: np.ndarray, poly: np.ndarray) -> np.ndarray:
        q, r = poly, np.roll(poly, -1, axis=0)
        e = r - q
        t = np.clip(((p[:, None] - q[None]) * e[None]).sum(axis=2) / (e**2).sum(axis=1), 0, 1)
        return np.linalg.norm(p[:, None] - (q[None] + t[..., None] * e[None]), axis=2)

    return float(min(to_edges(a, b).min(), to_edges(b, a).min()))


def _crowded(frames: Any, scene: dict[str, Any], gap: float) -> str | None:
    """The first two objects on the same level whose footprints are closer than ``gap``, as a
    message (one arm's rule, :func:`~lfd.reproduce.randomise._crowded`, measures between
    circumscribed circles: a 16 cm bar's circle would keep the boxes 8 cm from its sides)."""
    names = frames.names
    for a in range(len(names)):
        for b in range(a + 1, len(names)):
            Ta, Tb = scene[names[a]], scene[names[b]]
            sa, sb = frames.size[a], frames.size[b]
            if abs(Ta[2, 3] - Tb[2, 3]) > 0.5 * (sa[2] + sb[2]) - 0.005:
                continue  # one rests on the other
            if _overlap(Ta[:3, 3], yaw_of(Ta[:3, :3]), sa, Tb[:3, 3], yaw_of(Tb[:3, :3]), sb):
                return f"{names[a]} and {names[b]} too close (overlapping)"
            d = _footprint_gap(_corners(Ta, sa), _corners(Tb, sb))
            if d < gap:
                return f"{names[a]} and {names[b]} too close ({d:.3f} m apart)"
    return None


def _overlapping(frames: Any, scene: dict[str, Any]) -> str | None:
    """The first two objects of ``scene`` that intersect (one resting on the other aside), as
    a message: where both arms leave the objects, which no lane alone plans."""
    names = frames.names
    for a in range(len(names)):
        for b in range(a + 1, len(names)):
            Ta, Tb = scene[names[a]], scene[names[b]]
            sa, sb = frames.size[a], frames.size[b]
            if abs(Ta[2, 3] - Tb[2, 3]) > 0.5 * (sa[2] + sb[2]) - STACK_SLACK:
                continue
            if _overlap(Ta[:3, 3], yaw_of(Ta[:3, :3]), sa, Tb[:3, 3], yaw_of(Tb[:3, :3]), sb):
                return f"{names[a]} and {names[b]} overlapping at the end"
    return None


@dataclass
class _ArmSkill:
    side: str
    result: Any

    def to_json(self) -> dict[str, Any]:
        return {"arm": self.side, **self.result.to_json()}


@dataclass
class _Run:
    """A :class:`~lfd.reproduce.two_arms.TwoArmReproduction` as
    :func:`~lfd.reproduce.randomise.run_randomised` reads a run."""

    r: TwoArmReproduction

    @property
    def success(self) -> bool:
        return self.r.success

    @property
    def skills(self) -> list[_ArmSkill]:
        return [_ArmSkill(s, k) for s, ks in self.r.skills.items() for k in ks]

    @property
    def failures(self) -> list[str]:
        return self.r.failures

    @property
    def path_length(self) -> float:
        """Both arms' executed TCP paths (m)."""
        return float(sum(path_length(e.tcp) for e in self.r.executions.values()))

    @property
    def arms(self) -> dict[str, bool]:
        return {s: self.r.arm_success(s) for s in self.r.skills}


def _layout_check(
    trajs: dict[str, Any],
    hands: HandsProgram,
    robot: TwoArmRobot,
    modes: Sequence[str],
    planned: dict[str, TwoArmPlan] | None,
) -> Callable[[dict[str, Displacement]], str | None]:
    """The check of a drawn layout (:func:`check_two_arm_layout`), leaving in ``planned``
    (when given) the plans of the last layout checked, per mode."""

    def check(displace: dict[str, Displacement]) -> str | None:
        if planned is not None:
            planned.clear()
        return check_two_arm_layout(
            trajs, hands, displace, robot=robot, modes=modes, planned=planned
        )

    return check


def reproduce_two_arms_randomised(
    trajs: dict[str, Any],
    hands: HandsProgram,
    n: int,
    *,
    modes: Sequence[str] = ("skills", "dmp"),
    seed: int = 0,
    max_shift: float = MAX_SHIFT,
    max_turn_deg: float = MAX_TURN_DEG,
    progress: Callable[[int, int], None] | None = None,
    robot: TwoArmRobot | None = None,
) -> Randomised:
    """Reproduce a two-hand program on two arms in every mode on ``n`` randomised layouts
    (see the module docstring; ``trajs``: each hand's preprocessed trajectory, as
    :func:`~lfd.reproduce.two_arms.reproduce_two_arms` takes them).

    Returns
    -------
    Randomised
        As :func:`lfd.reproduce.reproduce_randomised`'s: every run also gives each arm's
        success (``arms``) and its skills name their arm (``arm``).

    Raises
    ------
    DemonstrationError
        A synchronisation the two arms do not run, or a hand with no arm.
    UsageError
        Bad settings, an object no gripper can hold, or no valid layout found.
    """
    from .aloha import aloha

    robot = robot or aloha()
    first = _check_program(trajs, hands, modes, robot)

    planned: dict[str, TwoArmPlan] = {}  # the layout's plans, made by its check, run as made

    def run(_traj: Any, _program: Any, mode: str, *, displace: Any, robot: Any) -> _Run:
        plan = planned.pop(mode, None)
        if plan is None:
            return _Run(reproduce_two_arms(trajs, hands, mode, robot=robot, displace=displace))
        return _Run(run_two_arm_plan(plan, robot))

    return run_randomised(
        trajs[first],
        hands.program(first),
        n,
        run,
        modes=modes,
        seed=seed,
        max_shift=max_shift,
        max_turn_deg=max_turn_deg,
        progress=progress,
        robot=robot,
        check=_layout_check(trajs, hands, robot, modes, planned),
    )


def iter_two_arm_layouts(
    trajs: dict[str, Any],
    hands: HandsProgram,
    n: int,
    *,
    modes: Sequence[str] = ("skills", "dmp"),
    seed: int = 0,
    max_shift: float = MAX_SHIFT,
    max_turn_deg: float = MAX_TURN_DEG,
    robot: TwoArmRobot,
    planned: dict[str, TwoArmPlan] | None = None,
) -> Iterator[Layout]:
    """The ``n`` layouts :func:`reproduce_two_arms_randomised` draws (the same, in the same
    order), one at a time (:func:`~lfd.reproduce.randomise.iter_layouts` with
    :func:`check_two_arm_layout`): robot data runs each as it comes
    (``lfd export robot-data --robot aloha``). The program is checked at once, on the call.
    ``planned`` (when given) holds, once a layout is yielded, its plan per mode (made by its
    check; :func:`~lfd.reproduce.two_arms.run_two_arm_plan` runs one as made).

    Raises
    ------
    DemonstrationError, UsageError
        As :func:`reproduce_two_arms_randomised` (no valid layout: when that layout is asked
        for).
    """
    first = _check_program(trajs, hands, modes, robot)
    return iter_layouts(
        trajs[first],
        hands.program(first),
        n,
        seed=seed,
        max_shift=max_shift,
        max_turn_deg=max_turn_deg,
        modes=modes,
        robot=robot.ik,
        check=_layout_check(trajs, hands, robot, modes, planned),
    )


def first_layout(
    trajs: dict[str, Any],
    hands: HandsProgram,
    *,
    modes: Sequence[str] = ("skills", "dmp"),
    seed: int = 0,
    max_shift: float = MAX_SHIFT,
    max_turn_deg: float = MAX_TURN_DEG,
    robot: TwoArmRobot,
) -> None:
    """Draw the first layout (nothing simulated): refuses bad settings and a program with no
    valid layout in one line before a progress bar starts."""
    for _ in iter_two_arm_layouts(
        trajs,
        hands,
        1,
        modes=modes,
        seed=seed,
        max_shift=max_shift,
        max_turn_deg=max_turn_deg,
        robot=robot,
    ):
        pass
