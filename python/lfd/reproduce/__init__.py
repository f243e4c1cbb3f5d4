"""Robot reproduction in MuJoCo: replay, execution with skill knowledge, and DMPs (paper III-C).

Typical use::

    from lfd.reproduce import reproduce, from_labels
    program = from_labels(demo.labels, int(traj.t_ns[0]))
    result = reproduce(traj, program, "dmp", displace={"box_1": (0.10, -0.05)})
    result.path_length, result.success, result.planned_tcp, result.executed_tcp

Modules: :mod:`.arm` (a robot is a value: :class:`~.arm.Robot`), :mod:`.robots` (the
registry :data:`~.robots.ROBOTS`), :mod:`.robot` (the default KUKA LWR 4+), :mod:`.panda` (the Franka
Panda from robosuite's MJCF), :mod:`.scene`, :mod:`.ik` (mink), :mod:`.controller`,
:mod:`.program` (the task program), :mod:`.goals` (Eq. 2), :mod:`.modes`, :mod:`.dmp`,
:mod:`.measures`, :mod:`.outcome` (why a run failed), :mod:`.timescale` (plans slowed to the
arm's limits), :mod:`.displacement` (``--displace``),
:mod:`.randomise` (randomised layouts: :func:`reproduce_randomised`), :mod:`.video`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import _gl  # noqa: F401  (selects the headless GL backend before mujoco loads)
from ..trajectory import Trajectory
from .controller import Execution, Plan, execute
from .displacement import (
    Displacement,
    check_displacement,
    check_program,
    parse_displacement,
    plan_layout,
    program_start,
)
from .goals import yaw_of
from .measures import ObjectResult, object_errors, path_length
from .modes import MODES
from .outcome import SkillResult, skill_results
from .program import (
    HandsProgram,
    Segment,
    SyncPoint,
    TaskProgram,
    from_hand_labels,
    from_hands,
    from_labels,
    from_segmentation,
)
from .randomise import MAX_SHIFT, MAX_TURN_DEG, Randomised, random_layouts, run_randomised
from .robots import DEFAULT_ROBOT, ROBOTS, Robot, robot_names
from .robots import robot as get_robot
from .scene import ObjectSpec

SIM_MODULES = ("mujoco", "mink", "daqp")
"""What every mode runs on: the simulator, the IK and the QP solver mink calls (``daqp``)."""

__all__ = [
    "DEFAULT_ROBOT",
    "MODES",
    "PREPROCESSING",
    "ROBOTS",
    "HandsProgram",
    "Randomised",
    "Reproduction",
    "Robot",
    "Segment",
    "SkillResult",
    "SyncPoint",
    "TaskProgram",
    "check_displacement",
    "check_program",
    "from_hand_labels",
    "from_hands",
    "from_labels",
    "from_segmentation",
    "get_robot",
    "parse_displacement",
    "program_start",
    "random_layouts",
    "reproduce",
    "reproduce_randomised",
    "reproduction_report",
    "robot_names",
]


PREPROCESSING: dict[str, Any] = {"feature_cutoff_hz": "auto", "object_cutoff_hz": 10.0}
"""How a demonstration is preprocessed for the robot when the task comes from its labels or a
task program: ``lfd.preprocess(demo, **PREPROCESSING)``. (``lfd reproduce --segment`` follows
the trajectory that was segmented, ``result.run.trajectory``, preprocessed as the method's.)
The hand filtered at :func:`~lfd.preprocessing.pipeline.auto_cutoff` of its rate, the objects
hardly (tag and motion-capture poses are smooth already): the same filters as the shipped
templates', with the keypoints weighted by their confidence. The paper's 0.625 Hz is meant for
the segmentation features: on a fast real placement it leaves the placed box's filtered resting
pose 2-3 cm off (lower, and short of where it came to rest), which a robot placing where the
person placed would then miss (docs/reproduce.md)."""


@dataclass
class Reproduction:
    """The result of one reproduction run.

    Attributes
    ----------
    mode : str
    planned_tcp : array, shape (n, 3)
        The planned TCP path at 10 ms ticks (for visualisation, e.g. ``lfd.viz``).
    executed_tcp : array, shape (n, 3)
        The TCP measured in physics at the same ticks.
    segment : array, shape (n,)
        Task-program segment index per tick (-1 while dwelling).
    objects : list of ObjectResult
        Final pose error and success per object.
    base : array, shape (3,)
        Robot base position.
    """

    mode: str
    planned_tcp: np.ndarray
    executed_tcp: np.ndarray
    segment: np.ndarray
    objects: list[ObjectResult]
    base: np.ndarray
    execution_time_s: float
    wall_time_s: float
    displacement: dict[str, Displacement] = field(default_factory=dict)
    execution: Execution | None = None
    program: TaskProgram | None = None
    """The executed task program (a missing pick_up may have been inserted); ``segment``
    indexes its segments."""
    skills: list[SkillResult] = field(default_factory=list)
    """One result per segment of ``program``: ``ok``, and the reason when it went wrong."""
    robot: str = DEFAULT_ROBOT
    """The robot's name (:data:`~lfd.reproduce.robots.ROBOTS`)."""

    @property
    def path_length(self) -> float:
        """Executed TCP path length (m)."""
        return path_length(self.executed_tcp)

    @property
    def planned_path_length(self) -> float:
        return path_length(self.planned_tcp)

    @property
    def success(self) -> bool:
        """True when every object ended where it should (the task is achieved)."""
        return all(o.success for o in self.objects)

    @property
    def demo_duration_s(self) -> float:
        """Duration of the executed program in the demonstration (s)."""
        segs = self.program.segments if self.program is not None else []
        return float(segs[-1].end_s - segs[0].start_s) if segs else 0.0

    @property
    def slowdown(self) -> float | None:
        """Robot execution time over the demonstration's (None: no demonstrated time)."""
        demo = self.demo_duration_s
        return self.execution_time_s / demo if demo > 0 else None

    @property
    def failures(self) -> list[str]:
        """One line per skill that went wrong: ``"6 stack box_1: stacked box_1 off target ..."``."""
        return [f"{s.label()}: {s.reason}" for s in self.skills if not s.ok]

    def to_json(self) -> dict[str, Any]:
        """Summary as a JSON-serialisable dict."""
        track = np.linalg.norm(self.executed_tcp - self.planned_tcp, axis=1)
        return {
            "mode": self.mode,
            "path_length_m": self.path_length,
            "planned_path_length_m": self.planned_path_length,
            "execution_time_s": self.execution_time_s,
            "wall_time_s": self.wall_time_s,
            "demo_duration_s": self.demo_duration_s,
            "slowdown": self.slowdown,
            "tracking_error_m": {"mean": float(track.mean()), "max": float(track.max())},
            "success": self.success,
            "failures": self.failures,
            "skills": [s.to_json() for s in self.skills],
            "objects": {
                o.name: {
                    "success": o.success,
                    "position_error_m": o.position_error,
                    "rotation_error_deg": o.rotation_error_deg,
                }
                for o in self.objects
            },
            "robot": self.robot,
            "base": self.base.tolist(),
            "displacement": {k: list(v) for k, v in self.displacement.items()},
            "program": self.program.to_json() if self.program is not None else None,
        }


def reproduce(
    traj: Trajectory,
    program: TaskProgram,
    mode: str,
    *,
    displace: Mapping[str, Displacement] | None = None,
    base: np.ndarray | None = None,
    video_fps: float = 0.0,
    progress: Callable[[int, int], None] | None = None,
    robot: Robot | str = DEFAULT_ROBOT,
) -> Reproduction:
    """Plan and execute a task program in MuJoCo and measure the outcome.

    Parameters
    ----------
    traj : Trajectory
        The preprocessed demonstration.
    program : TaskProgram
        The segmentation to execute.
    mode : {"replay", "skills", "dmp"}
    displace : dict name -> (dx, dy) or (dx, dy, deg), optional
        Shift (m) and turn (deg, about the vertical) objects' initial poses in the robot's
        scene; an object resting on a displaced one moves with it. Every skill's goal follows
        the objects it is relative to (Eq. 2, :mod:`.goals`).
    base : array, shape (3,), optional
        Robot base; chosen automatically (:func:`~lfd.reproduce.scene.choose_base`) by default.

    Raises
    ------
    MissingExtraError
        A module of the ``sim`` extra this mode runs on is not installed.
    UsageError
        A displacement that names an unknown object, is not finite, or puts an object out of
        reach, off the table or into another object (:func:`check_displacement`), or whose
        re-grounded task would put an object out of reach or into another one
        (:func:`~lfd.reproduce.displacement.check_goals`), before anything is simulated.
    video_fps : float
        Record frames into ``result.execution.frames`` at this rate (0 = off).
    robot : Robot or str
        The arm (a :class:`~lfd.reproduce.arm.Robot` or its name in
        :data:`~lfd.reproduce.robots.ROBOTS`); default the KUKA LWR 4+.
    """
    from .._extras import require

    # MuJoCo, mink and its QP solver (daqp, looked up only at the first IK step), and the DMPs
    require("sim", SIM_MODULES + (("movement_primitives",) if mode == "dmp" else ()), who=__name__)
    arm = get_robot(robot) if isinstance(robot, str) else robot
    displace = dict(displace or {})
    # checked, base chosen and planned before anything is simulated
    frames, initial, result = plan_layout(traj, program, mode, displace, base=base, robot=arm)
    base = frames.base
    if not displace:  # where the demonstration left the objects
        end_i = frames.index(program.segments[-1].end_s)
        result.expected = {n: frames.object_pose(n, end_i) for n in frames.names}
    specs = []
    for k, name in enumerate(frames.names):
        T = initial[name]
        c, s = np.cos(yaw_of(T[:3, :3]) / 2), np.sin(yaw_of(T[:3, :3]) / 2)
        p = T[:3, 3].copy()
        p[2] = max(p[2], frames.size[k, 2] / 2)  # never start inside the table
        specs.append(ObjectSpec(name, frames.size[k], p, np.array([0.0, 0.0, s, c])))
    plan: Plan = result.plan
    ex = execute(plan, base, specs, video_fps=video_fps, progress=progress, robot=arm)
    objs = object_errors(
        ex.object_names, ex.final_position, ex.final_quaternion, result.expected, frames.size
    )
    executed = result.program if result.program is not None else program
    return Reproduction(
        mode=mode,
        planned_tcp=plan.position,
        executed_tcp=ex.tcp,
        segment=plan.segment,
        objects=objs,
        base=np.asarray(base),
        execution_time_s=plan.duration_s,
        wall_time_s=ex.wall_time_s,
        displacement=displace,
        execution=ex,
        program=result.program,
        skills=skill_results(executed, plan, ex, objs),
        robot=arm.name,
    )


def reproduction_report(
    program: TaskProgram, results: Mapping[str, Reproduction], *, recording: str | None = None
) -> dict[str, Any]:
    """The document of ``lfd reproduce --json``: the task program and every mode's result."""
    return {
        "recording": recording,
        "program": program.to_json(),
        "results": {mode: r.to_json() for mode, r in results.items()},
    }


def reproduce_randomised(
    traj: Trajectory,
    program: TaskProgram,
    n: int,
    *,
    modes: Sequence[str] = ("skills", "dmp"),
    seed: int = 0,
    max_shift: float = MAX_SHIFT,
    max_turn_deg: float = MAX_TURN_DEG,
    progress: Callable[[int, int], None] | None = None,
    robot: Robot | str = DEFAULT_ROBOT,
) -> Randomised:
    """Reproduce ``program`` in every mode on ``n`` randomised layouts (``lfd reproduce
    --randomise N``): every object shifted up to ``max_shift`` m and turned up to
    ``max_turn_deg``, reachable and collision-free for ``robot`` (:mod:`.randomise`).

    Returns
    -------
    Randomised
        The layouts and every run; ``success_rate(mode)``, ``skill_rates(mode)``,
        ``reasons(mode)``, ``to_json()`` (the document of ``--randomise --json``).

    Raises
    ------
    UsageError
        Bad settings, or no valid layout found (before anything is simulated).
    """
    return run_randomised(
        traj,
        program,
        n,
        reproduce,
        modes=modes,
        seed=seed,
        max_shift=max_shift,
        max_turn_deg=max_turn_deg,
        progress=progress,
        robot=get_robot(robot) if isinstance(robot, str) else robot,
    )
