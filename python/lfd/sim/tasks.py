"""Task definitions: the skill sequences the simulated demonstrator performs.

A task is a list of :class:`Step` s over object *roles* (``A``, ``B``, ``C``); each demonstration
assigns the three boxes to the roles at random and places them at random, collision-free spots
in the workspace. Every task obeys the skill grammar (:data:`TRANSITIONS`, paper Fig. 6).

Experiment tasks (paper Sec. V): ``exp1`` ... ``exp4``. Single-skill template tasks (one per
skill, named after it) contain the target skill with the minimal grammatical context around it;
their metadata names the ``target_skill``.

Repeated-lift tasks (:data:`TASK_GENERATORS`, like real motion-capture sessions): ``exp5`` picks
up the same box, lifts it and puts it down 6-10 times in a row (place -> short move -> pick_up
between cycles); ``exp6`` does the same alternating between two boxes; ``exp7`` lifts, turns and
puts one box down 4-12 times like the repeated cycles of real people (quick low lifts, turns in
the hand, and between cycles the hand staying on the box, backing off a few cm or leaving it).
The number of cycles (and ``exp7``'s choices) are drawn from the demonstration's random stream.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..errors import DemonstrationError, InvalidParameterError
from ..skills import SKILLS, grammar
from .scene import WORKSPACE_X, WORKSPACE_Y, ObjectSpec

HOLDING: frozenset[str] = frozenset(grammar()["groups"]["holding"])
"""Skills performed while holding an object."""

TRANSITIONS: dict[str, frozenset[str]] = {
    "start": frozenset(grammar()["start"]),
    **{skill: frozenset(nxt) for skill, nxt in grammar()["transitions"].items()},
}
"""Allowed skill transitions (paper Fig. 6); ``start`` is the state before the first skill."""


@dataclass(frozen=True)
class Step:
    """One skill on an object role; ``onto`` is the base role of a Move with that ends a stack;
    ``repeat`` marks a Move with of a repeated lift (the object is put down near where it was
    picked up); ``quick`` a quick low one (:data:`lfd.sim.natural.QUICK_S`,
    :data:`~lfd.sim.natural.QUICK_RISE_M`) and ``turn`` one that turns the object in the hand
    (:data:`~lfd.sim.natural.TURN_IN_HAND_DEG`). ``leave`` says how the hand leaves the object
    in a Move between two cycles of it: ``""`` it stays on it (the grasp barely opens),
    ``"near"`` it backs off a few cm (never 8 cm from the box), ``"away"`` it goes away and
    comes back (natural style; the careful demonstrator always goes away)."""

    skill: str
    role: str | None = None
    onto: str | None = None
    repeat: bool = False
    quick: bool = False
    turn: bool = False
    leave: str = ""


def _seq(*items: str) -> tuple[Step, ...]:
    steps = []
    for item in items:
        skill, _, rest = item.partition(":")
        role, _, onto = rest.partition(">")
        steps.append(Step(skill, role or None, onto or None))
    return tuple(steps)


TASKS: dict[str, tuple[Step, ...]] = {
    "exp1": _seq(
        "pick_up:A", "move_with:A", "place:A", "move:B",
        "pick_up:B", "move_with:B>C", "stack:B", "move",
    ),
    "exp2": _seq(
        "push:A", "move:B", "pick_up:B", "move_with:B", "place:B", "move:C", "push:C", "move",
    ),
    "exp3": _seq(
        "locate:A", "move:B", "pick_up:B", "move_with:B>C", "stack:B", "move:A", "push:A", "move",
    ),
    "exp4": _seq(
        "pick_up:A", "move_with:A", "place:A", "move:B", "locate:B",
        "move:C", "pick_up:C", "move_with:C", "place:C", "move",
    ),
    # single-skill templates (target skill + minimal context)
    "pick_up": _seq("pick_up:A", "move_with:A"),
    "move_with": _seq("pick_up:A", "move_with:A", "place:A"),
    "place": _seq("pick_up:A", "move_with:A", "place:A", "move"),
    "stack": _seq("pick_up:A", "move_with:A>B", "stack:A", "move"),
    "move": _seq("move:A", "pick_up:A"),
    "push": _seq("push:A", "move"),
    "locate": _seq("locate:A", "move"),
}  # fmt: skip
"""Every task by name."""


def lift_cycles(rng: np.random.Generator, roles: str = "A") -> tuple[Step, ...]:
    """6-10 pick_up -> move_with -> place cycles, on the ``roles`` in turn, joined by moves."""
    steps: list[Step] = []
    for k in range(int(rng.integers(6, 11))):
        role = roles[k % len(roles)]
        if k:
            steps.append(Step("move", role))
        steps += [Step("pick_up", role), Step("move_with", role, repeat=True), Step("place", role)]
    steps.append(Step("move"))
    return tuple(steps)


QUICK_P = 0.5
"""``exp7``: probability that a cycle's lift is quick and low."""
HAND_TURN_P = 0.7
"""``exp7``: probability that a cycle turns the object in the hand."""
LEAVE_P = {"": 0.4, "near": 0.3, "away": 0.3}
"""``exp7``: how the hand leaves the object between two cycles (:class:`Step` ``leave``)."""


def turn_cycles(rng: np.random.Generator) -> tuple[Step, ...]:
    """4-12 cycles of one object like real people's: each lift quick and low with probability
    :data:`QUICK_P`, turning the object in the hand with probability :data:`HAND_TURN_P`; between
    two cycles the hand stays, backs off or leaves (:data:`LEAVE_P`)."""
    steps: list[Step] = []
    leaves = list(LEAVE_P)
    for k in range(int(rng.integers(4, 13))):
        quick, turn = bool(rng.random() < QUICK_P), bool(rng.random() < HAND_TURN_P)
        leave = leaves[int(rng.choice(len(leaves), p=list(LEAVE_P.values())))]
        if k:
            steps.append(Step("move", "A", leave=leave))
        steps += [
            Step("pick_up", "A"),
            Step("move_with", "A", repeat=True, quick=quick, turn=turn),
            Step("place", "A"),
        ]
    steps.append(Step("move"))
    return tuple(steps)


TASK_GENERATORS: dict[str, Callable[[np.random.Generator], tuple[Step, ...]]] = {
    "exp5": lambda rng: lift_cycles(rng, "A"),
    "exp6": lambda rng: lift_cycles(rng, "AB"),
    "exp7": turn_cycles,
}
"""Tasks whose steps are drawn per demonstration (from its random stream)."""

BIMANUAL_TASKS: tuple[str, ...] = ("handover", "carry", "hold_stack", "hold_push")
"""The two-hand tasks (:mod:`lfd.sim.bimanual`): a handover, a two-handed carry of a large box,
one hand holding a plank still while the other stacks a cube on it, one hand holding a cube
still while the other pushes another. Their steps are per hand and synchronised, not a
:class:`Step` list."""

TASK_NAMES: tuple[str, ...] = (*TASKS, *TASK_GENERATORS, *BIMANUAL_TASKS)
"""Every task name (fixed, generated and two-hand)."""

EXPERIMENTS: tuple[str, ...] = ("exp1", "exp2", "exp3", "exp4")
"""The paper's experiments (Sec. V)."""
REPEAT_EXPERIMENTS: tuple[str, ...] = tuple(TASK_GENERATORS)
"""The repeated-lift experiments (not in :data:`EXPERIMENTS`: their number of cycles varies)."""
TWO_HAND_EXPERIMENTS: tuple[str, ...] = BIMANUAL_TASKS
"""The two-hand experiments (each hand's lane labelled, handovers marked)."""
NATURAL_EXPERIMENTS: tuple[str, ...] = (*EXPERIMENTS, "exp5")
"""The experiments a natural-style evaluation set covers."""
TEMPLATE_TASKS: tuple[str, ...] = SKILLS
"""One single-skill task per skill, named after it."""


def check_task(name: str) -> None:
    """Raise :class:`~lfd.errors.InvalidParameterError` for an unknown task name."""
    if name not in TASK_NAMES:
        raise InvalidParameterError(f"unknown task {name!r}; known tasks: {', '.join(TASK_NAMES)}")


def task_steps(name: str, rng: np.random.Generator | None = None) -> tuple[Step, ...]:
    """The steps of a task, checked against the grammar; a generated task draws them from
    ``rng`` (default: a generator seeded with 0)."""
    check_task(name)
    if name in BIMANUAL_TASKS:
        raise InvalidParameterError(f"{name} is a two-hand task: it has no one-hand steps")
    if name in TASK_GENERATORS:
        steps = TASK_GENERATORS[name](rng if rng is not None else np.random.default_rng(0))
    else:
        steps = TASKS[name]
    check_grammar([s.skill for s in steps])
    return steps


def check_grammar(skills: list[str]) -> None:
    """Raise :class:`DemonstrationError` if a skill sequence breaks :data:`TRANSITIONS`."""
    prev = "start"
    for skill in skills:
        if skill not in TRANSITIONS[prev]:
            raise DemonstrationError(f"skill {skill!r} cannot follow {prev!r}")
        prev = skill


def place_objects(
    rng: np.random.Generator, specs: tuple[ObjectSpec, ...]
) -> dict[str, tuple[np.ndarray, float]]:
    """Random collision-free upright poses (centre, yaw) in the workspace."""
    for _ in range(1000):
        poses: dict[str, tuple[np.ndarray, float]] = {}
        for spec in specs:
            r = 0.5 * float(np.hypot(spec.size[0], spec.size[1]))
            for _ in range(200):
                xy = np.array([rng.uniform(*WORKSPACE_X), rng.uniform(*WORKSPACE_Y)])
                if all(
                    np.linalg.norm(xy - p[:2]) > r + 0.5 * np.hypot(*o.size[:2]) + 0.06
                    for o, (p, _) in ((s, poses[s.name]) for s in specs if s.name in poses)
                ):
                    poses[spec.name] = (
                        np.array([xy[0], xy[1], 0.5 * spec.size[2]]),
                        float(rng.uniform(-np.pi / 4, np.pi / 4)),
                    )
                    break
        if len(poses) == len(specs):
            return poses
    raise DemonstrationError("could not place the objects without collisions")
