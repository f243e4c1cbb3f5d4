"""Robot reproduction in MuJoCo: replay, execution with skill knowledge, and DMPs (paper III-C).

Typical use::

    from lfd.reproduce import reproduce, from_labels
    program = from_labels(demo.labels, int(traj.t_ns[0]))
    result = reproduce(traj, program, "dmp", displace={"box_1": (0.10, -0.05)})
    result.path_length, result.success, result.planned_tcp, result.executed_tcp

Modules: :mod:`.robot` (the arm MJCF), :mod:`.scene`, :mod:`.ik` (mink), :mod:`.controller`,
:mod:`.program` (the task program), :mod:`.goals` (Eq. 2), :mod:`.modes`, :mod:`.dmp`,
:mod:`.measures`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import _gl  # noqa: F401  (selects the headless GL backend before mujoco loads)
from ..errors import DemonstrationError
from ..trajectory import Trajectory
from .controller import Execution, Plan, execute
from .goals import DemoFrames, pose, yaw_of
from .measures import ObjectResult, object_errors, path_length
from .modes import MODES, plan_task
from .program import Segment, TaskProgram, from_labels, from_segmentation
from .scene import ObjectSpec, choose_base

__all__ = [
    "MODES",
    "Reproduction",
    "Segment",
    "TaskProgram",
    "from_labels",
    "from_segmentation",
    "parse_displacement",
    "reproduce",
]


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
    displacement: dict[str, tuple[float, float]] = field(default_factory=dict)
    execution: Execution | None = None
    program: TaskProgram | None = None
    """The executed task program (a missing pick_up may have been inserted); ``segment``
    indexes its segments."""

    @property
    def path_length(self) -> float:
        """Executed TCP path length (m)."""
        return path_length(self.executed_tcp)

    @property
    def planned_path_length(self) -> float:
        return path_length(self.planned_tcp)

    @property
    def success(self) -> bool:
        """True when every object ended where it should."""
        return all(o.success for o in self.objects)

    def to_json(self) -> dict[str, Any]:
        """Summary as a JSON-serialisable dict."""
        track = np.linalg.norm(self.executed_tcp - self.planned_tcp, axis=1)
        return {
            "mode": self.mode,
            "path_length_m": self.path_length,
            "planned_path_length_m": self.planned_path_length,
            "execution_time_s": self.execution_time_s,
            "wall_time_s": self.wall_time_s,
            "tracking_error_m": {"mean": float(track.mean()), "max": float(track.max())},
            "success": self.success,
            "objects": {
                o.name: {
                    "success": o.success,
                    "position_error_m": o.position_error,
                    "rotation_error_deg": o.rotation_error_deg,
                }
                for o in self.objects
            },
            "base": self.base.tolist(),
            "displacement": {k: list(v) for k, v in self.displacement.items()},
            "program": self.program.to_json() if self.program is not None else None,
        }


def parse_displacement(spec: Sequence[str] | str | None) -> dict[str, tuple[float, float]]:
    """Parse ``"box_1:0.10,-0.05"`` (or several) into ``{"box_1": (0.10, -0.05)}``."""
    if spec is None:
        return {}
    items = [spec] if isinstance(spec, str) else list(spec)
    out: dict[str, tuple[float, float]] = {}
    for item in items:
        for part in item.split(";"):
            if not part.strip():
                continue
            try:
                name, vec = part.split(":")
                dx, dy = (float(v) for v in vec.split(","))
            except ValueError as err:
                raise DemonstrationError(
                    f"bad displacement {part!r}; expected NAME:DX,DY (metres)"
                ) from err
            out[name.strip()] = (dx, dy)
    return out


def reproduce(
    traj: Trajectory,
    program: TaskProgram,
    mode: str,
    *,
    displace: Mapping[str, tuple[float, float]] | None = None,
    base: np.ndarray | None = None,
    video_fps: float = 0.0,
    progress: Callable[[int, int], None] | None = None,
) -> Reproduction:
    """Plan and execute a task program in MuJoCo and measure the outcome.

    Parameters
    ----------
    traj : Trajectory
        The preprocessed demonstration.
    program : TaskProgram
        The segmentation to execute.
    mode : {"replay", "skills", "dmp"}
    displace : dict name -> (dx, dy), optional
        Shift objects' initial poses (m) in the robot's scene.
    base : array, shape (3,), optional
        Robot base; chosen automatically (:func:`choose_base`) by default.
    video_fps : float
        Record frames into ``result.execution.frames`` at this rate (0 = off).
    """
    displace = dict(displace or {})
    start_i = int(np.clip(np.searchsorted(traj.t_s, program.segments[0].start_s), 0, len(traj) - 1))
    if base is None:
        tcp = np.asarray(traj.tcp, dtype=np.float64)
        obj0 = np.nan_to_num(np.asarray(traj.object_position)[:, start_i, :])
        extra = [
            obj0[traj.object_names.index(k)] + [*v, 0.0]
            for k, v in displace.items()
            if k in traj.object_names
        ]
        pts = np.concatenate([tcp, obj0, np.array(extra).reshape(-1, 3)])
        base = choose_base(pts, keep_out=np.concatenate([obj0, np.array(extra).reshape(-1, 3)]))
    frames = DemoFrames(traj, base)
    initial: dict[str, np.ndarray] = {}
    for name, (dx, dy) in displace.items():
        if name not in frames.names:
            raise DemonstrationError(
                f"cannot displace unknown object {name!r}; known: {frames.names}"
            )
        T = frames.object_pose(name, start_i)
        initial[name] = pose(T[:3, 3] + [dx, dy, 0.0], yaw_of(T[:3, :3]))
    result = plan_task(frames, program, mode, initial=initial)
    if not displace:  # where the demonstration left the objects
        end_i = frames.index(program.segments[-1].end_s)
        result.expected = {n: frames.object_pose(n, end_i) for n in frames.names}
    specs = []
    for k, name in enumerate(frames.names):
        T = initial.get(name, frames.object_pose(name, start_i))
        c, s = np.cos(yaw_of(T[:3, :3]) / 2), np.sin(yaw_of(T[:3, :3]) / 2)
        p = T[:3, 3].copy()
        p[2] = max(p[2], frames.size[k, 2] / 2)  # never start inside the table
        specs.append(ObjectSpec(name, frames.size[k], p, np.array([0.0, 0.0, s, c])))
    plan: Plan = result.plan
    ex = execute(plan, base, specs, video_fps=video_fps, progress=progress)
    objs = object_errors(
        ex.object_names, ex.final_position, ex.final_quaternion, result.expected, frames.size
    )
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
    )
