"""Log a robot reproduction: planned vs executed TCP paths, the arm, tracking error."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from ..errors import DemonstrationError
from .recording import get_recording, import_rerun
from .timeline import ROBOT_TIME, as_ns, time_columns

PLANNED_COLOR = (120, 200, 120)
EXECUTED_COLOR = (255, 120, 60)
ARM_COLOR = (200, 200, 210)


def _path(a: npt.ArrayLike | None, what: str) -> np.ndarray | None:
    if a is None:
        return None
    p = np.asarray(a, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3:
        raise DemonstrationError(f"{what} path must have shape (n, 3), got {p.shape}")
    return p


def _strip(
    rec: Any, path: str, points: np.ndarray, color: tuple[int, int, int], label: str
) -> None:
    rr = import_rerun()
    ok = np.all(np.isfinite(points), axis=1)
    rec.log(
        path,
        rr.LineStrips3D([points[ok]], colors=[color], radii=0.002, labels=[label]),
        static=True,
    )


def log_robot_paths(
    planned: npt.ArrayLike | None = None,
    executed: npt.ArrayLike | None = None,
    *,
    t_ns: npt.ArrayLike | None = None,
    planned_t_ns: npt.ArrayLike | None = None,
    mode: str = "reproduction",
    link_positions: npt.ArrayLike | None = None,
    opening: npt.ArrayLike | None = None,
    base_pose: npt.ArrayLike | None = None,
    recording: Any = None,
) -> None:
    """Log one reproduction (``replay``, ``skills``, ``dmp``, ...) under ``/world/robot/<mode>``.

    Parameters
    ----------
    planned : array, shape (n, 3), optional
        The planned TCP path (world frame, metres), drawn as a static line strip.
    executed : array, shape (m, 3), optional
        The executed (measured) TCP path, drawn as a static line strip; with ``t_ns`` also the
        current TCP on the ``robot_time`` timeline.
    t_ns : array, shape (m,), optional
        Times of the executed samples, int64 ns; ``robot_time`` counts from ``t_ns[0]``.
    planned_t_ns : array, shape (n,), optional
        Times of the planned samples (same clock as ``t_ns``). With both, the TCP tracking error
        ``|executed - planned|`` (planned linearly interpolated) goes to
        ``/robot/<mode>/tcp_error``; when ``n == m`` the samples are paired without it.
    link_positions : array, shape (m, L, 3), optional
        Arm joint/link origins per executed sample, drawn as a stick figure over time.
    opening : array, shape (m,), optional
        Gripper opening per executed sample (``/robot/<mode>/opening``).
    base_pose : array, shape (4, 4), optional
        Pose of the robot base in the world frame (axes at ``/world/robot/base``).
    recording : rerun.RecordingStream, optional
    """
    rr = import_rerun()
    rec = get_recording(recording)
    base = f"/world/robot/{mode}"
    plan = _path(planned, "planned")
    exe = _path(executed, "executed")
    if plan is not None and len(plan) >= 2:
        _strip(rec, f"{base}/planned", plan, PLANNED_COLOR, f"{mode}: planned")
    if exe is not None and len(exe) >= 2:
        _strip(rec, f"{base}/executed", exe, EXECUTED_COLOR, f"{mode}: executed")
    if base_pose is not None:
        T = np.asarray(base_pose, dtype=np.float64)
        if T.shape != (4, 4):
            raise DemonstrationError(f"base_pose must be 4x4, got {T.shape}")
        rec.log(
            "/world/robot/base",
            rr.Transform3D(translation=T[:3, 3], mat3x3=T[:3, :3]),
            rr.TransformAxes3D(0.15),
            static=True,
        )
    if t_ns is None or exe is None:
        return
    t = as_ns(t_ns, "executed", len(exe))
    if t.size == 0:
        return
    t0 = int(t[0])
    idx = time_columns(t, t0, timeline=ROBOT_TIME)
    rec.log(
        f"{base}/tcp", rr.Points3D.from_fields(colors=[EXECUTED_COLOR], radii=[0.008]), static=True
    )
    rec.send_columns(f"{base}/tcp", indexes=idx, columns=rr.Points3D.columns(positions=exe))
    if link_positions is not None:
        links = np.asarray(link_positions, dtype=np.float64)
        if links.ndim != 3 or links.shape[0] != len(t) or links.shape[2] != 3:
            raise DemonstrationError(
                f"link_positions must have shape ({len(t)}, L, 3), got {links.shape}"
            )
        rec.log(f"{base}/arm", rr.LineStrips3D.from_fields(colors=[ARM_COLOR]), static=True)
        rec.send_columns(
            f"{base}/arm",
            indexes=idx,
            columns=rr.LineStrips3D.columns(strips=list(links), radii=np.full(len(t), 0.01)),
        )
    if opening is not None:
        op = np.asarray(opening, dtype=np.float64)
        if op.shape != (len(t),):
            raise DemonstrationError(f"opening must have shape ({len(t)},), got {op.shape}")
        rec.log(f"/robot/{mode}/opening", rr.SeriesLines(names=f"{mode}: opening (m)"), static=True)
        rec.send_columns(
            f"/robot/{mode}/opening", indexes=idx, columns=rr.Scalars.columns(scalars=op)
        )
    if plan is not None:
        if planned_t_ns is not None:
            tp = as_ns(planned_t_ns, "planned", len(plan))
            ref = np.column_stack([np.interp(t, tp, plan[:, j]) for j in range(3)])
        elif len(plan) == len(exe):
            ref = plan
        else:
            return
        err = np.linalg.norm(exe - ref, axis=1)
        rec.log(
            f"/robot/{mode}/tcp_error",
            rr.SeriesLines(names=f"{mode}: TCP error (m)", colors=[EXECUTED_COLOR]),
            static=True,
        )
        rec.send_columns(
            f"/robot/{mode}/tcp_error", indexes=idx, columns=rr.Scalars.columns(scalars=err)
        )


TICK_NS = 10_000_000
"""Control tick of a reproduction (10 ms): the sample period of its planned/executed paths."""


def log_reproduction(
    result: Any,
    *,
    skills: Sequence[str] | None = None,
    object_sizes: Mapping[str, npt.ArrayLike] | None = None,
    tick_ns: int = TICK_NS,
    recording: Any = None,
) -> None:
    """Log a reproduction result (``lfd.reproduce.Reproduction``) with :func:`log_robot_paths`.

    Reads ``mode``, ``planned_tcp`` (n, 3), ``executed_tcp`` (n, 3) at ``tick_ns`` ticks,
    ``segment`` (n,) task-program segment index per tick (-1 while dwelling), ``base`` (3,), and
    ``objects`` (final errors, shown as text). ``skills[k]`` names segment ``k`` in the state
    lane ``/robot/<mode>/segment``. A skill that failed (``result.skills``:
    :class:`~lfd.reproduce.SkillResult` with its reasons) is marked on the robot's timeline in
    ``/robot/<mode>/failures`` (an ERROR text log at the last tick of its segment). When ``result.execution`` holds the simulated object poses
    (``object_names``, ``object_position`` (k, n, 3), ``object_quaternion`` (k, n, 4)), the
    objects move under ``/world/robot_objects/<mode>/<name>``, drawn as boxes of
    ``object_sizes[name]`` (metres) when given.
    """
    rr = import_rerun()
    rec = get_recording(recording)
    mode = str(getattr(result, "mode", "reproduction"))
    executed = np.asarray(result.executed_tcp, dtype=np.float64)
    n = len(executed)
    t = np.arange(n, dtype=np.int64) * int(tick_ns)
    base_pose = None
    base = getattr(result, "base", None)
    if base is not None:
        base_pose = np.eye(4)
        base_pose[:3, 3] = np.asarray(base, dtype=np.float64).reshape(3)
    log_robot_paths(
        result.planned_tcp,
        executed,
        t_ns=t,
        planned_t_ns=t,
        mode=mode,
        base_pose=base_pose,
        recording=rec,
    )
    segment = getattr(result, "segment", None)
    if segment is not None and n:
        seg = np.asarray(segment, dtype=np.int64)
        if seg.shape != (n,):
            raise DemonstrationError(f"segment must have shape ({n},), got {seg.shape}")
        change = np.flatnonzero(np.r_[True, seg[1:] != seg[:-1]])

        def name(k: int) -> str:
            if k < 0:
                return ""
            return skills[k] if skills is not None and k < len(skills) else f"segment {k}"

        rec.send_columns(
            f"/robot/{mode}/segment",
            indexes=time_columns(t[change], 0, timeline=ROBOT_TIME),
            columns=rr.StateChange.columns(state=[name(int(seg[i])) for i in change]),
        )
    _log_failures(rec, rr, mode, getattr(result, "skills", None) or [], segment, t)
    execution = getattr(result, "execution", None)
    if execution is not None and n:
        _log_objects(rec, mode, execution, t, object_sizes or {})
    lines = [
        f"{o.name}: {'ok' if getattr(o, 'success', False) else 'FAILED'}, "
        f"{1000 * o.position_error:.1f} mm, {o.rotation_error_deg:.1f} deg"
        for o in getattr(result, "objects", [])
    ]
    if lines and n:
        rec.send_columns(
            f"/robot/{mode}/objects",
            indexes=time_columns(np.full(len(lines), t[-1]), 0, timeline=ROBOT_TIME),
            columns=rr.TextLog.columns(text=lines, level=["INFO"] * len(lines)),
        )


def _log_failures(
    rec: Any, rr: Any, mode: str, results: Sequence[Any], segment: Any, t: np.ndarray
) -> None:
    """Each failed skill's reasons, at the end of its segment on the robot's timeline."""
    failed = [s for s in results if not getattr(s, "ok", True)]
    if not failed or not t.size:
        return
    seg = None if segment is None else np.asarray(segment, dtype=np.int64)
    times, lines = [], []
    for s in failed:
        ticks = np.flatnonzero(seg == s.index) if seg is not None else np.zeros(0, np.int64)
        times.append(int(t[ticks[-1]] if ticks.size else t[-1]))
        lines.append(f"FAILED {s.label()}: {s.reason}")
    order = np.argsort(times, kind="stable")
    rec.send_columns(
        f"/robot/{mode}/failures",
        indexes=time_columns(np.asarray(times)[order], 0, timeline=ROBOT_TIME),
        columns=rr.TextLog.columns(text=[lines[i] for i in order], level=["ERROR"] * len(lines)),
    )


def _log_objects(
    rec: Any, mode: str, execution: Any, t: np.ndarray, sizes: Mapping[str, npt.ArrayLike]
) -> None:
    """Object poses of a reproduction over ``robot_time``."""
    rr = import_rerun()
    names = list(getattr(execution, "object_names", []))
    pos = np.asarray(getattr(execution, "object_position", np.zeros((0, 0, 3))), dtype=np.float64)
    quat = np.asarray(
        getattr(execution, "object_quaternion", np.zeros((0, 0, 4))), dtype=np.float64
    )
    if pos.shape != (len(names), len(t), 3) or quat.shape != (len(names), len(t), 4):
        return
    for k, name in enumerate(names):
        path = f"/world/robot_objects/{mode}/{rr.escape_entity_path_part(name)}"
        rec.log(path, rr.TransformAxes3D(0.05), static=True)
        if name in sizes:
            half = np.asarray(sizes[name], dtype=np.float64).reshape(3) / 2
            rec.log(
                f"{path}/box",
                rr.Boxes3D(
                    half_sizes=[half],
                    labels=[name],
                    colors=[EXECUTED_COLOR],
                    fill_mode="transparentfillmajorwireframe",
                ),
                static=True,
            )
        rec.send_columns(
            path,
            indexes=time_columns(t, 0, timeline=ROBOT_TIME),
            columns=rr.Transform3D.columns(translation=pos[k], quaternion=quat[k]),
        )
