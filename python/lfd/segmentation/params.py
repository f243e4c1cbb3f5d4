"""Skill parameters extracted from a segment (what the reproduction needs besides the motion).

* ``pick_up``: the grasp -- the TCP pose relative to the object frame at the segment end
  (``grasp_position`` in metres, ``grasp_quaternion`` x, y, z, w; paper Eq. 2);
* ``place`` / ``stack``: the object pose in the world at the segment end (``place_position``,
  ``place_quaternion``); for ``stack`` also the object underneath (``on``) and the offset to it;
* ``push``: the object displacement (``displacement``, metres, world frame);
* ``locate``: the TCP position relative to the object at the segment end;
* every skill: ``tcp_start`` and ``tcp_end`` (world, metres).

:func:`skill_params_batch` computes them for many segments at once (one vectorised pass, the
rotations of all of them in one :func:`poses_in_object` call); :func:`skill_params` is one
segment.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from ..skills import RELEASES
from ..trajectory import Trajectory

POSE_SKILLS: frozenset[str] = frozenset({"pick_up", "locate"})
"""Skills whose parameters hold the TCP pose in the object frame (:func:`poses_in_object`)."""


def poses_in_object(
    traj: Trajectory, objects: np.ndarray, samples: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The TCP pose in the frame of object ``objects[i]`` at sample ``samples[i]``, for every
    ``i`` at once: positions ``(m, 3)`` (metres) and quaternions ``(m, 4)`` (x, y, z, w; NaN
    where the hand orientation is not finite). A non-finite object orientation counts as the
    identity. The one place of the rotation math of the skill parameters."""
    from .. import rotations

    k = np.asarray(objects, dtype=np.intp)
    t = np.asarray(samples, dtype=np.intp)
    m = len(k)
    if m == 0:
        return np.zeros((0, 3)), np.zeros((0, 4))
    q = np.asarray(traj.object_quaternion[k, t], dtype=np.float64)
    q_ok = np.asarray(np.isfinite(q).all(axis=1))
    q_inv = rotations.inverse(rotations.normalize(np.where(q_ok[:, None], q, [0.0, 0.0, 0.0, 1.0])))
    rel = np.asarray(traj.tcp[t] - traj.object_position[k, t], dtype=np.float64)
    # R^T rel per row as a stacked matmul (what one Rotation.apply gives, bit for bit)
    p = (rotations.as_matrix(q_inv) @ rel[:, :, None])[:, :, 0]
    rot = np.asarray(traj.rotation[t], dtype=np.float64)
    r_ok = np.asarray(np.isfinite(rot).all(axis=(1, 2)))
    q_tcp = rotations.from_matrix(np.where(r_ok[:, None, None], rot, np.eye(3)))
    quat = rotations.multiply(q_inv, q_tcp)
    quat[~r_ok] = np.nan
    return p, quat


def _vec(x: np.ndarray) -> list[float] | None:
    x = np.asarray(x, dtype=np.float64)
    return [float(v) for v in x] if np.all(np.isfinite(x)) else None


def _vecs(x: np.ndarray) -> list[list[float] | None]:
    """:func:`_vec` of every row of ``x`` ``(m, d)``."""
    x = np.asarray(x, dtype=np.float64)
    ok = np.isfinite(x).all(axis=1).tolist()
    return [row if good else None for row, good in zip(x.tolist(), ok, strict=True)]


def skill_params(
    traj: Trajectory, skill: str, start: int, end: int, obj: int | None
) -> dict[str, Any]:
    """Parameters of a ``skill`` segment on samples ``start..end`` with target object ``obj``."""
    return skill_params_batch(traj, [skill], [start], [end], [obj])[0]


def skill_params_batch(
    traj: Trajectory,
    skills: Sequence[str],
    starts: Sequence[int],
    ends: Sequence[int],
    objects: Sequence[int | None],
) -> list[dict[str, Any]]:
    """:func:`skill_params` of many segments (``skills[i]`` on ``starts[i]..ends[i]`` with
    target ``objects[i]``) in one vectorised pass."""
    m = len(skills)
    if m == 0:
        return []
    n, n_obj = len(traj), len(traj.object_names)
    start = np.asarray(starts, dtype=np.intp)
    last = np.maximum(np.minimum(np.asarray(ends, dtype=np.intp), n) - 1, start)
    tcp_start, tcp_end = _vecs(traj.tcp[start]), _vecs(traj.tcp[last])
    out: list[dict[str, Any]] = [
        {"tcp_start": a, "tcp_end": b} for a, b in zip(tcp_start, tcp_end, strict=True)
    ]
    valid = [o is not None and 0 <= o < n_obj for o in objects]
    posed = [i for i in range(m) if valid[i] and skills[i] in POSE_SKILLS]
    if posed:
        k = np.array([objects[i] for i in posed], dtype=np.intp)
        p, q = poses_in_object(traj, k, last[posed])
        for i, pos, quat in zip(posed, _vecs(p), _vecs(q), strict=True):
            if skills[i] == "pick_up":
                out[i]["grasp_position"] = pos
                out[i]["grasp_quaternion"] = quat
            else:
                out[i]["tcp_in_object_position"] = pos
    placed = [i for i in range(m) if valid[i] and skills[i] in RELEASES]
    if placed:
        k, t = np.array([objects[i] for i in placed], dtype=np.intp), last[placed]
        where = _vecs(traj.object_position[k, t])
        turned = _vecs(traj.object_quaternion[k, t])
        for i, a, b in zip(placed, where, turned, strict=True):
            out[i]["place_position"] = a
            out[i]["place_quaternion"] = b
            if skills[i] == "stack" and n_obj > 1:
                out[i].update(_stacked_on(traj, objects[i], int(last[i])))
    pushed = [i for i in range(m) if valid[i] and skills[i] == "push"]
    if pushed:
        k = np.array([objects[i] for i in pushed], dtype=np.intp)
        moved = traj.object_position[k, last[pushed]] - traj.object_position[k, start[pushed]]
        for i, d in zip(pushed, _vecs(moved), strict=True):
            out[i]["displacement"] = d
    return out


def _stacked_on(traj: Trajectory, obj: int | None, t: int) -> dict[str, Any]:
    """The object under ``obj`` at sample ``t`` (nearest in the horizontal) and the offset to
    it."""
    assert obj is not None
    here = traj.object_position[obj, t]
    others = [k for k in range(len(traj.object_names)) if k != obj]
    d = [float(np.linalg.norm(traj.object_position[k, t, :2] - here[:2])) for k in others]
    below = others[int(np.nanargmin(d))] if np.any(np.isfinite(d)) else others[0]
    return {"on": traj.object_names[below], "offset": _vec(here - traj.object_position[below, t])}
