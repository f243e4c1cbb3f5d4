"""Reproduction over randomised layouts: does the learned task generalise where the objects are?

:func:`random_layouts` draws layouts of the demonstration's objects: every object on the table is
shifted by up to ``max_shift`` (uniform over the disc) and turned by up to ``max_turn_deg``
about its vertical axis; an object that starts resting on another one is not drawn by itself, it
moves with its support (a stack is shifted and turned as one,
:func:`~lfd.reproduce.displacement.initial_poses`). A draw is rejected and drawn again when

* an object ends out of the arm's reach, off the table or overlapping another
  (:func:`~lfd.reproduce.displacement.check_displacement`, the robot base chosen for the layout);
* the re-grounded task would put an object out of reach or into another object after any place,
  stack or push (:func:`~lfd.reproduce.displacement.check_goals` on the planned scenes);
* two objects on the table, at the start or after any skill, are closer than :data:`LAYOUT_GAP`
  (between their circumscribed circles): the gripper's fingers need room beside a box.

:func:`run_randomised` (``lfd.reproduce.reproduce_randomised``) runs the requested modes on every layout and gathers success per
mode and per skill and the failure reasons (:class:`Randomised`, ``lfd reproduce --randomise``).
"""

from __future__ import annotations

import re
from collections import Counter
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import InvalidParameterError, LfdError, UsageError
from ..trajectory import Trajectory
from .aloha import TwoArmRobot
from .arm import Robot
from .displacement import Displacement, check_program, plan_layout, program_start
from .goals import DemoFrames
from .modes import MODES
from .program import TaskProgram
from .robot import KUKA_LWR4

LAYOUT_GAP = 0.03
"""Smallest gap (m) between the circumscribed circles of two objects on the table in a
randomised layout, at the start and after every skill (the demonstrator keeps 4-6 cm)."""
MAX_TRIES = 400
"""Draws per layout before giving up (:class:`~lfd.errors.UsageError`)."""
MAX_SHIFT = 0.10
"""Default largest shift of an object (m)."""
MAX_TURN_DEG = 45.0
"""Default largest turn of an object (deg)."""
MAX_LAYOUTS = 100_000
"""Most layouts one ``--randomise N`` runs (each is simulated in every mode: 100 000 layouts are
days of simulation already)."""


@dataclass
class Layout:
    """One randomised layout."""

    index: int
    displace: dict[str, Displacement]
    """``name -> (dx, dy, turn_deg)`` of every object drawn (objects on a stack move with it)."""
    rejected: dict[str, int] = field(default_factory=dict)
    """Draws rejected before this one, by reason."""

    def to_json(self) -> dict[str, Any]:
        return {
            "index": self.index,
            "displace": {k: list(v) for k, v in self.displace.items()},
            "rejected": dict(self.rejected),
        }


def _rejection_kind(message: str) -> str:
    m = re.search(r"out of the (?:\w+ )?arm's reach", message)
    if m:
        return m.group(0)
    for kind in ("off the table", "overlapping", "too close"):
        if kind in message:
            return kind
    return "other"


def _crowded(frames: DemoFrames, scene: dict[str, np.ndarray], gap: float) -> str | None:
    """The first pair of objects on the same level closer than ``gap``, as a message."""
    names = frames.names
    for a in range(len(names)):
        for b in range(a + 1, len(names)):
            Ta, Tb = scene[names[a]], scene[names[b]]
            sa, sb = frames.size[a], frames.size[b]
            if abs(Ta[2, 3] - Tb[2, 3]) > 0.5 * (sa[2] + sb[2]) - 0.005:
                continue  # one rests on the other
            ra, rb = 0.5 * np.hypot(sa[0], sa[1]), 0.5 * np.hypot(sb[0], sb[1])
            d = float(np.hypot(*(Ta[:2, 3] - Tb[:2, 3])))
            if d < ra + rb + gap:
                return f"{names[a]} and {names[b]} too close ({d - ra - rb:.3f} m apart)"
    return None


def check_layout(
    traj: Trajectory,
    program: TaskProgram,
    displace: dict[str, Displacement],
    *,
    modes: Sequence[str] = ("skills", "dmp"),
    gap: float = LAYOUT_GAP,
    robot: Robot = KUKA_LWR4,
) -> str | None:
    """Why a layout cannot be used (one line), or None when it is reachable and collision-free
    as planned in each of ``modes`` (replay is not re-grounded: it is planned as skills)."""
    for mode in dict.fromkeys(m if m != "replay" else "skills" for m in modes):
        try:
            frames, start, plan = plan_layout(traj, program, mode, displace, robot=robot)
        except UsageError as err:
            return str(err)
        for scene in [start, *plan.scenes]:
            crowded = _crowded(frames, scene, gap)
            if crowded:
                return crowded
    return None


def random_layouts(
    traj: Trajectory,
    program: TaskProgram,
    n: int,
    *,
    seed: int = 0,
    max_shift: float = MAX_SHIFT,
    max_turn_deg: float = MAX_TURN_DEG,
    gap: float = LAYOUT_GAP,
    modes: Sequence[str] = ("skills", "dmp"),
    robot: Robot = KUKA_LWR4,
) -> list[Layout]:
    """``n`` reachable, collision-free layouts (see the module docstring), reproducibly from
    ``seed``: :func:`iter_layouts` drawn all at once.

    Raises
    ------
    UsageError
        A bad ``n`` (1 to :data:`MAX_LAYOUTS`), ``max_shift`` or ``max_turn_deg``, or no valid
        layout found in :data:`MAX_TRIES` draws.
    """
    return list(
        iter_layouts(
            traj,
            program,
            n,
            seed=seed,
            max_shift=max_shift,
            max_turn_deg=max_turn_deg,
            gap=gap,
            modes=modes,
            robot=robot,
        )
    )


def check_layout_count(n: int) -> int:
    """``n`` as a number of layouts: an integer from 1 to :data:`MAX_LAYOUTS`."""
    if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= MAX_LAYOUTS:
        raise UsageError(f"--randomise {n}: the number of layouts must be from 1 to {MAX_LAYOUTS}")
    return n


def iter_layouts(
    traj: Trajectory,
    program: TaskProgram,
    n: int,
    *,
    seed: int = 0,
    max_shift: float = MAX_SHIFT,
    max_turn_deg: float = MAX_TURN_DEG,
    gap: float = LAYOUT_GAP,
    modes: Sequence[str] = ("skills", "dmp"),
    robot: Robot = KUKA_LWR4,
    check: Callable[[dict[str, Displacement]], str | None] | None = None,
) -> Iterator[Layout]:
    """:func:`random_layouts` one at a time: each layout is drawn when it is asked for (the
    same layouts, in the same order). The settings are checked at once, on the call.
    ``check(displace)``: why a layout cannot be used, or None (default :func:`check_layout`
    for ``robot``; two arms pass their own, :mod:`.two_arms_randomise`).

    Raises
    ------
    UsageError
        As :func:`random_layouts` (no valid layout: when that layout is asked for).
    """
    check_layout_count(n)
    if not (np.isfinite(max_shift) and 0.0 <= max_shift <= 0.5):
        raise UsageError(f"--max-shift {max_shift}: must be 0-0.5 m")
    if not (np.isfinite(max_turn_deg) and 0.0 <= max_turn_deg <= 180.0):
        raise UsageError(f"--max-turn {max_turn_deg}: must be 0-180 deg")
    if check is None:
        if any(m != "replay" for m in modes):
            check_program(traj, program, robot)

        def check(displace: dict[str, Displacement]) -> str | None:
            return check_layout(traj, program, displace, modes=modes, gap=gap, robot=robot)

    start_i = program_start(traj, program)
    frames = DemoFrames(traj, np.zeros(3))
    seen = np.all(np.isfinite(np.asarray(traj.object_position)[:, start_i, :]), axis=1)
    free = [
        name
        for k, name in enumerate(frames.names)
        if seen[k] and frames.support_of(name, start_i) is None
    ]
    rng = np.random.default_rng(seed)

    def draw() -> Iterator[Layout]:
        for index in range(n):
            rejected: Counter[str] = Counter()
            for _ in range(MAX_TRIES):
                displace: dict[str, Displacement] = {}
                for name in free:
                    r = max_shift * float(np.sqrt(rng.uniform()))
                    a = float(rng.uniform(-np.pi, np.pi))
                    turn = float(rng.uniform(-max_turn_deg, max_turn_deg))
                    displace[name] = (r * np.cos(a), r * np.sin(a), turn)
                problem = check(displace)
                if problem is None:
                    yield Layout(index, displace, dict(rejected))
                    break
                rejected[_rejection_kind(problem)] += 1
            else:
                kinds = ", ".join(f"{k} {v}" for k, v in rejected.most_common())
                raise UsageError(
                    f"--randomise: no reachable, collision-free layout in {MAX_TRIES} draws "
                    f"(rejected: {kinds}); try a smaller --max-shift"
                )

    return draw()


_KINDS = (
    "toppled over",
    "goal unreachable",
    "IK limit",
    "grasp failed",
    "grasp lost",
    "collision",
    "never got there",
)


def reason_kind(reason: str) -> str:
    """The kind of a failure reason (:mod:`.outcome`): ``"collision"``, ``"grasp lost"``,
    ``"placed off target"``, ..."""
    for kind in _KINDS:
        if kind in reason:
            return kind
    m = re.match(r"(placed|stacked|pushed) \S+ off target", reason)
    if m:
        return f"{m.group(1)} off target"
    return "off target"


@dataclass
class LayoutRun:
    """The outcome of one mode on one layout (the summary of a
    :class:`~lfd.reproduce.Reproduction`, without its arrays)."""

    layout: int
    mode: str
    success: bool
    skills: list[dict[str, Any]]
    """:meth:`~lfd.reproduce.outcome.SkillResult.to_json` of every skill."""
    failures: list[str]
    path_length_m: float
    error: str | None = None
    """The run could not be planned or executed (an :class:`~lfd.errors.LfdError`)."""
    arms: dict[str, bool] | None = None
    """Two arms: each arm's success (its skills, no collision); None for one arm."""

    def to_json(self) -> dict[str, Any]:
        doc = {
            "layout": self.layout,
            "mode": self.mode,
            "success": self.success,
            "path_length_m": self.path_length_m,
            "failures": self.failures,
            "skills": self.skills,
            "error": self.error,
        }
        return doc if self.arms is None else doc | {"arms": dict(self.arms)}


@dataclass
class Randomised:
    """Success over randomised layouts (``lfd reproduce --randomise``)."""

    layouts: list[Layout]
    runs: list[LayoutRun]
    modes: tuple[str, ...]
    settings: dict[str, Any] = field(default_factory=dict)

    def success_rate(self, mode: str) -> float:
        runs = [r for r in self.runs if r.mode == mode]
        return sum(r.success for r in runs) / max(len(runs), 1)

    def skill_rates(self, mode: str) -> dict[str, tuple[int, int]]:
        """Per skill name: (ok, total) over every layout's instances of that skill."""
        out: dict[str, list[int]] = {}
        for r in self.runs:
            if r.mode != mode:
                continue
            for s in r.skills:  # of two arms, per arm: "right push"
                c = out.setdefault(f"{s['arm']} {s['skill']}" if "arm" in s else s["skill"], [0, 0])
                c[0] += bool(s["ok"])
                c[1] += 1
        return {k: (v[0], v[1]) for k, v in out.items()}

    def reasons(self, mode: str) -> Counter[str]:
        """How often each kind of failure (:func:`reason_kind`) occurred, per failed skill."""
        c: Counter[str] = Counter()
        for r in self.runs:
            if r.mode != mode:
                continue
            if r.error:
                c["error: " + r.error.split(":")[0]] += 1
            for s in r.skills:
                for reason in (s["reason"] or "").split("; "):
                    if reason:
                        c[reason_kind(reason)] += 1
        return c

    def to_json(self) -> dict[str, Any]:
        return {
            "settings": self.settings,
            "summary": {
                mode: {
                    "success_rate": self.success_rate(mode),
                    "layouts": sum(1 for r in self.runs if r.mode == mode),
                    "skills": {k: list(v) for k, v in self.skill_rates(mode).items()},
                    "reasons": dict(self.reasons(mode)),
                }
                for mode in self.modes
            },
            "layouts": [
                lay.to_json()
                | {"results": {r.mode: r.to_json() for r in self.runs if r.layout == lay.index}}
                for lay in self.layouts
            ],
        }


def run_randomised(
    traj: Trajectory,
    program: TaskProgram,
    n: int,
    run: Callable[..., Any],
    *,
    modes: Sequence[str] = ("skills", "dmp"),
    seed: int = 0,
    max_shift: float = MAX_SHIFT,
    max_turn_deg: float = MAX_TURN_DEG,
    progress: Callable[[int, int], None] | None = None,
    robot: Robot | TwoArmRobot = KUKA_LWR4,
    check: Callable[[dict[str, Displacement]], str | None] | None = None,
) -> Randomised:
    """Reproduce ``program`` on ``n`` random layouts (:func:`random_layouts`) in every mode
    (``lfd.reproduce.reproduce_randomised`` with ``run`` = ``lfd.reproduce.reproduce``; two
    arms: :func:`~lfd.reproduce.two_arms_randomise.reproduce_two_arms_randomised`).

    Parameters
    ----------
    run : callable
        ``run(traj, program, mode, displace=..., robot=...)`` -> a
        :class:`~lfd.reproduce.Reproduction` (or anything with its ``success``, ``skills``,
        ``failures`` and ``path_length``, and of two arms ``arms``: each arm's success).
    robot : Robot or TwoArmRobot
        The robot: the layouts are checked against its reach, and it runs them.
    check : callable, optional
        ``check(displace)``: why a layout cannot be used, or None (:func:`iter_layouts`).
    progress : callable (done, total), optional
        Called after every run.

    Raises
    ------
    UsageError
        Bad settings, or no valid layout (for the first layout: before anything is
        simulated; for a later one: the runs so far are lost, as with any error).
    """
    for mode in modes:
        if mode not in MODES:
            raise InvalidParameterError(f"unknown mode {mode!r}; choose from {', '.join(MODES)}")
    layouts: list[Layout] = []
    runs: list[LayoutRun] = []
    total = n * len(modes)
    # each layout is drawn just before it runs: the first runs start at once, whatever n
    for lay in iter_layouts(
        traj,
        program,
        n,
        seed=seed,
        max_shift=max_shift,
        max_turn_deg=max_turn_deg,
        modes=modes,
        robot=robot if isinstance(robot, Robot) else robot.ik,
        check=check,
    ):
        layouts.append(lay)
        for mode in modes:
            try:
                r = run(traj, program, mode, displace=lay.displace, robot=robot)
                one = LayoutRun(
                    lay.index,
                    mode,
                    r.success,
                    [s.to_json() for s in r.skills],
                    r.failures,
                    r.path_length,
                    arms=getattr(r, "arms", None),
                )
            except LfdError as err:
                one = LayoutRun(lay.index, mode, False, [], [str(err)], 0.0, error=str(err))
            runs.append(one)
            if progress is not None:
                progress(len(runs), total)
    settings = {
        "n": n,
        "seed": seed,
        "max_shift_m": max_shift,
        "max_turn_deg": max_turn_deg,
        "gap_m": LAYOUT_GAP,
        "robot": robot.name,
    }
    return Randomised(layouts, runs, tuple(modes), settings)
