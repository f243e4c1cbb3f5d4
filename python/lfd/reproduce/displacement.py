"""``--displace NAME:DX,DY``: parse and check object displacements before anything is simulated.

A displacement shifts an object's initial position in the robot's scene, in metres. It is
refused (:class:`~lfd.errors.UsageError`, one line) when it is not a finite number, names an
unknown object, is implausibly large (centimetres typed as metres), puts the object out of the
arm's reach or off the table, or makes it overlap another object.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np

from ..errors import UsageError
from ..trajectory import Trajectory
from .goals import DemoFrames, pose, quat_to_matrix, yaw_of
from .program import TaskProgram

if TYPE_CHECKING:
    from .modes import PlanResult
from .arm import Robot
from .robot import KUKA_LWR4
from .scene import TABLE_HALF, choose_base, table_centre

MAX_DISPLACEMENT = 1.0
"""Largest accepted displacement (m); the arm reaches about 0.8 m, so more is a typo."""
REACH_SLACK = 0.03
"""Allowed shortfall below the robot's shortest reach (:attr:`~lfd.reproduce.arm.Robot.reach`:
the KUKA's elbow limit is at 0.395 m, 0.035 m below its 0.43 m)."""
MAX_TURN_DEG = 360.0
"""Largest turn (degrees, either sign) a displacement may give: one full turn; more is a typo
(a turn is refused, not reduced modulo 360)."""
OVERLAP_MARGIN = 0.002
"""Two objects closer than this (m) count as overlapping."""
STACK_SLACK = 0.005
"""Final poses this close (m) to resting one on the other are a stack, not an overlap."""


Displacement = tuple[float, ...]
"""``(dx, dy)`` in metres, or ``(dx, dy, turn)`` with a turn about the vertical in degrees."""


def parse_displacement(spec: Sequence[str] | str | None) -> dict[str, Displacement]:
    """Parse ``"box_1:0.10,-0.05"`` (or several, also ``;``-separated) into ``{"box_1": (0.1, -0.05)}``.

    A third value turns the object about its vertical axis, in degrees, at most
    :data:`MAX_TURN_DEG` either way: ``"box_1:0.10,-0.05,30"`` -> ``{"box_1": (0.1, -0.05, 30.0)}``.
    Numbers are read with :func:`lfd.inputs.parse_number` (``1_0`` is refused).

    Raises
    ------
    UsageError
        Not ``NAME:DX,DY[,DEG]``, a value that is not a finite number, a turn of more than
        :data:`MAX_TURN_DEG`, or an object displaced twice.
    """
    from ..inputs import parse_number

    if spec is None:
        return {}
    items = [spec] if isinstance(spec, str) else list(spec)
    out: dict[str, Displacement] = {}
    for item in items:
        for part in item.split(";"):
            if not part.strip():
                continue
            try:
                name, vec = part.split(":")
                vals = tuple(parse_number(v) for v in vec.split(","))
                if len(vals) not in (2, 3):
                    raise ValueError(vec)
            except ValueError as err:
                raise UsageError(
                    f"--displace {part!r}: expected NAME:DX,DY[,DEG] (metres, degrees), "
                    "e.g. box_1:0.08,-0.05"
                ) from err
            if not all(np.isfinite(v) for v in vals):
                raise UsageError(
                    f"--displace {part!r}: DX, DY (and DEG) must be finite numbers (metres)"
                )
            name = name.strip()
            if not name:
                raise UsageError(f"--displace {part!r}: missing object name before ':'")
            if len(vals) > 2 and abs(vals[2]) > MAX_TURN_DEG:
                raise UsageError(
                    f"--displace {name}: a turn of {vals[2]:g} degrees; give at most "
                    f"{MAX_TURN_DEG:g} either way"
                )
            if name in out:
                raise UsageError(f"--displace {name}:... is given twice; give each object once")
            out[name] = vals
    return out


def _turn(d: Displacement) -> float:
    """The turn of a displacement (rad)."""
    return float(np.radians(d[2])) if len(d) > 2 else 0.0


def initial_poses(
    frames: DemoFrames, displace: Mapping[str, Displacement], start_i: int
) -> dict[str, np.ndarray]:
    """Upright 4x4 initial poses of the displaced objects (shifted, turned about their centre).

    An object resting on a displaced object at the start (and not displaced itself) moves
    rigidly with its support: a stack is shifted and turned as one.
    """
    out: dict[str, np.ndarray] = {}
    for name, d in displace.items():
        T = frames.object_pose(name, start_i)
        out[name] = pose(T[:3, 3] + [d[0], d[1], 0.0], yaw_of(T[:3, :3]) + _turn(d))
    for name in frames.names:
        sup = frames.support_of(name, start_i) if name not in displace else None
        if sup in out and sup is not None:
            out[name] = (
                out[sup]
                @ np.linalg.inv(frames.object_pose(sup, start_i))
                @ (frames.object_pose(name, start_i))
            )
    return out


def program_start(traj: Trajectory, program: TaskProgram) -> int:
    """Sample index of ``traj`` where ``program`` starts (the objects' initial poses)."""
    i = np.searchsorted(traj.t_s, program.segments[0].start_s)
    return int(np.clip(i, 0, len(traj) - 1))


def _fmt(v: float) -> str:
    """``v`` for a message: 4 decimals at most, in ``:g`` form (``1e+308``, not 309 digits)."""
    return f"{round(v, 4):g}" if v else "0"


def _unmoved(d: Displacement) -> bool:
    """A zero displacement: the object where the demonstration shows it (``lfd export
    robot-data`` checks the demonstration as shown so, with no ``--displace`` given)."""
    return not any(d)


def _where(name: str, d: Displacement, x: float, y: float) -> tuple[str, bool]:
    """How an error names an object at ``(x, y)`` after displacement ``d``: by the
    ``--displace`` given, or, for a zero one, by the demonstration (no displacement was given);
    and whether it was displaced (a smaller displacement is a remedy)."""
    if _unmoved(d):
        return f"{name} is at ({x:.3f}, {y:.3f}) m where the demonstration shows it", False
    return f"--displace {name}:{_fmt(d[0])},{_fmt(d[1])} puts {name} at ({x:.3f}, {y:.3f}) m", True


def check_displacement(
    traj: Trajectory,
    displace: Mapping[str, Displacement],
    start_i: int,
    *,
    base: np.ndarray | None = None,
    robot: Robot = KUKA_LWR4,
) -> np.ndarray:
    """Check displacements against the demonstration and choose the robot base.

    Parameters
    ----------
    traj : Trajectory
        The preprocessed demonstration.
    displace : dict name -> (dx, dy)
        Displacements in metres.
    start_i : int
        Sample index of the program's start (the objects' initial poses).
    base : array, shape (3,), optional
        The robot base; default: chosen to reach the demonstrated TCP path and the objects at
        their demonstrated and displaced positions.
    robot : Robot
        Whose reach counts.

    Returns
    -------
    array, shape (3,)
        The robot base (:func:`~lfd.reproduce.scene.choose_base`) including the displaced objects.

    Raises
    ------
    UsageError
        Unknown object, non-finite or implausibly large displacement, a displaced object out of
        reach, off the table or overlapping another object.
    """
    names = list(traj.object_names)
    for name, (dx, dy, *_) in displace.items():
        if name not in names:
            known = ", ".join(names) or "none"
            raise UsageError(f"--displace: unknown object {name!r}; known objects: {known}")
        if not (np.isfinite(dx) and np.isfinite(dy)):
            raise UsageError(f"--displace {name}: DX and DY must be finite numbers (metres)")
        if np.hypot(dx, dy) > MAX_DISPLACEMENT:
            msg = (
                f"--displace {name}:{_fmt(dx)},{_fmt(dy)} moves {name} by "
                f"{_fmt(round(float(np.hypot(dx, dy)), 2))} m (at most {MAX_DISPLACEMENT:g} m); displacements are in metres"
            )
            if np.hypot(dx, dy) / 100 <= 0.3:  # centimetres typed as metres
                msg += f"; did you mean {name}:{_fmt(dx / 100)},{_fmt(dy / 100)}?"
            raise UsageError(msg)
    opos = np.asarray(traj.object_position, dtype=np.float64)[:, start_i, :]
    oquat = np.asarray(traj.object_quaternion, dtype=np.float64)[:, start_i, :]
    size = np.asarray(traj.object_size, dtype=np.float64).reshape(-1, 3)
    known = np.all(np.isfinite(opos), axis=1)
    for name in displace:
        if not known[names.index(name)]:
            raise UsageError(f"--displace {name}: {name} is not seen at the start of the task")
    obj0 = np.nan_to_num(opos)
    pos = obj0.copy()
    for name, (dx, dy, *_) in displace.items():
        pos[names.index(name), :2] += (dx, dy)
    if base is None:
        moved = pos[[names.index(n) for n in displace]].reshape(-1, 3)
        tcp = np.asarray(traj.tcp, dtype=np.float64)
        keep_out = np.concatenate([obj0, moved])
        base = choose_base(np.concatenate([tcp, keep_out]), keep_out=keep_out, robot=robot)
    base = np.asarray(base, dtype=np.float64)
    shoulder = np.array([base[0], base[1], robot.shoulder_z])
    reach_min, reach_max = robot.reach
    centre = table_centre(base)
    yaw = [yaw_of(quat_to_matrix(q)) if np.all(np.isfinite(q)) else 0.0 for q in oquat]
    for name, d in displace.items():
        yaw[names.index(name)] += _turn(d)
    for name, d in displace.items():
        k = names.index(name)
        what, displaced = _where(name, d, pos[k, 0], pos[k, 1])
        remedy = "; use a smaller displacement" if displaced else ""
        top = pos[k] + [0.0, 0.0, size[k, 2] / 2 + robot.tcp_offset]  # wrist above a top grasp
        reach = float(np.linalg.norm(top - shoulder))
        if reach > reach_max or reach < reach_min - REACH_SLACK:
            raise UsageError(
                f"{what}, out of the arm's reach ({reach:.3f} m from the shoulder; it reaches "
                f"{reach_min - REACH_SLACK:.2f}-{reach_max:.2f} m){remedy}"
            )
        if np.any(np.abs(pos[k, :2] - centre) + size[k, :2].max() / 2 > TABLE_HALF):
            raise UsageError(f"{what}, off the table{remedy}")
        for j, other in enumerate(names):
            if j == k or not known[j]:
                continue
            if _overlap(pos[k], yaw[k], size[k], pos[j], yaw[j], size[j]):
                raise UsageError(
                    f"{what}, overlapping {other} at ({pos[j, 0]:.3f}, {pos[j, 1]:.3f}) m"
                    + ("; choose a displacement that leaves them apart" if displaced else "")
                )
    return base


def _overlap(
    p: np.ndarray, yaw_p: float, size_p: np.ndarray, q: np.ndarray, yaw_q: float, size_q: np.ndarray
) -> bool:
    """Whether two upright boxes intersect (separating axis test, with a small margin)."""
    if abs(p[2] - q[2]) >= (size_p[2] + size_q[2]) / 2 + OVERLAP_MARGIN:
        return False
    axes = [np.array([np.cos(a), np.sin(a)]) for a in (yaw_p, yaw_p + np.pi / 2)]
    axes += [np.array([np.cos(a), np.sin(a)]) for a in (yaw_q, yaw_q + np.pi / 2)]
    d = q[:2] - p[:2]

    def half(yaw: float, size: np.ndarray, u: np.ndarray) -> float:
        c, s = np.cos(yaw), np.sin(yaw)
        return 0.5 * (abs(u @ [c, s]) * size[0] + abs(u @ [-s, c]) * size[1])

    return all(
        abs(float(u @ d)) < half(yaw_p, size_p, u) + half(yaw_q, size_q, u) + OVERLAP_MARGIN
        for u in axes
    )


def check_goals(
    frames: DemoFrames,
    initial: Mapping[str, np.ndarray],
    scenes: Sequence[Mapping[str, np.ndarray]],
    displace: Mapping[str, Displacement],
) -> None:
    """Refuse a displacement whose re-grounded task is impossible, before anything is simulated.

    ``scenes``: every object's planned pose after each place, stack and push and at the end
    (:attr:`~lfd.reproduce.modes.PlanResult.scenes`). Every object the task moves (its pose
    differs from ``initial``) must be within the arm's reach, on the table, and clear of every
    other object in each scene.

    Raises
    ------
    UsageError
        Naming the displacement, the object and where the task would put it.
    """
    base, robot = frames.base, frames.robot
    shoulder = np.array([base[0], base[1], robot.shoulder_z])
    reach_min, reach_max = robot.reach
    centre = table_centre(base)
    spec = " ".join(f"{n}:{','.join(_fmt(v) for v in d)}" for n, d in displace.items())
    given = "" if all(_unmoved(d) for d in displace.values()) else f"--displace {spec}: "
    names = frames.names
    for scene in scenes:
        for k, name in enumerate(names):
            T, T0 = scene[name], initial[name]
            if np.linalg.norm(T[:3, 3] - T0[:3, 3]) < 1e-6:
                continue
            p = T[:3, 3]
            what = f"{given}the task would put {name} at ({p[0]:.3f}, {p[1]:.3f}) m"
            top = p + np.array([0.0, 0.0, frames.size[k, 2] / 2 + robot.tcp_offset])
            reach = float(np.linalg.norm(top - shoulder))
            if reach > reach_max or reach < reach_min - REACH_SLACK:
                raise UsageError(
                    f"{what}, out of the arm's reach ({reach:.3f} m from the shoulder)"
                )
            if np.any(np.abs(p[:2] - centre) + frames.size[k, :2].max() / 2 > TABLE_HALF):
                raise UsageError(f"{what}, off the table")
            for j, other in enumerate(names):
                Q = scene[other]
                h = (frames.size[k, 2] + frames.size[j, 2]) / 2
                if j == k or abs(Q[2, 3] - p[2]) > h - STACK_SLACK:  # one rests on the other
                    continue
                yaw_p, yaw_q = yaw_of(T[:3, :3]), yaw_of(Q[:3, :3])
                if _overlap(p, yaw_p, frames.size[k], Q[:3, 3], yaw_q, frames.size[j]):
                    raise UsageError(
                        f"{what}, overlapping {other} at ({Q[0, 3]:.3f}, {Q[1, 3]:.3f}) m; "
                        "choose a displacement that leaves room"
                    )


def check_program(traj: Trajectory, program: TaskProgram, robot: Robot = KUKA_LWR4) -> None:
    """Refuse a task the robot cannot do whatever the layout, before anything is simulated:
    a pick_up of an object wider than the gripper closes across
    (:func:`~lfd.reproduce.goals.check_grasp_fits`).

    Raises
    ------
    UsageError
        One line naming the object and the widths.
    """
    from .modes import check_grasps

    check_grasps(DemoFrames(traj, np.zeros(3), robot), program)


def plan_layout(
    traj: Trajectory,
    program: TaskProgram,
    mode: str,
    displace: Mapping[str, Displacement],
    *,
    base: np.ndarray | None = None,
    robot: Robot = KUKA_LWR4,
) -> tuple[DemoFrames, dict[str, np.ndarray], PlanResult]:
    """Check a displacement, choose the robot base and plan the re-grounded task.

    With displaced objects (and no ``base`` given) the base is chosen twice: first for the
    demonstrated path and the objects (:func:`check_displacement`), then for the planned,
    re-grounded path and every object pose of the plan (a place that follows a displaced box
    may leave the demonstration's workspace), and the task is planned again from there.

    Returns
    -------
    frames : DemoFrames
        The demonstration seen from the chosen base (``frames.base``).
    initial : dict name -> 4x4
        Initial pose of every object.
    result : PlanResult

    Raises
    ------
    UsageError
        :func:`check_displacement` and :func:`check_goals`, before anything is simulated.
    """
    from .modes import plan_task

    start_i = program_start(traj, program)
    fixed = base is not None
    base = check_displacement(traj, displace, start_i, base=base, robot=robot)
    frames = DemoFrames(traj, base, robot)
    moved = initial_poses(frames, displace, start_i)
    initial = {n: moved.get(n, frames.object_pose(n, start_i)) for n in frames.names}
    result = plan_task(frames, program, mode, initial=moved)
    if displace and not fixed:
        objs = np.array([T[:3, 3] for sc in [initial, *result.scenes] for T in sc.values()])
        new = choose_base(np.concatenate([result.plan.position, objs]), keep_out=objs, robot=robot)
        if np.linalg.norm(new - base) > 1e-9:
            base = check_displacement(traj, displace, start_i, base=new, robot=robot)
            frames = DemoFrames(traj, base, robot)
            result = plan_task(frames, program, mode, initial=moved)
    if displace:
        check_goals(frames, initial, result.scenes, displace)
    return frames, initial, result
