"""Skill parameters extracted from a segment (what the reproduction needs besides the motion).

* ``pick_up``: the grasp -- the TCP pose relative to the object frame at the segment end
  (``grasp_position`` in metres, ``grasp_quaternion`` x, y, z, w; paper Eq. 2);
* ``place`` / ``stack``: the object pose in the world at the segment end (``place_position``,
  ``place_quaternion``); for ``stack`` also the object underneath (``on``) and the offset to it;
* ``push``: the object displacement (``displacement``, metres, world frame);
* ``locate``: the TCP position relative to the object at the segment end;
* every skill: ``tcp_start`` and ``tcp_end`` (world, metres).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..trajectory import Trajectory


def _pose_in_object(traj: Trajectory, k: int, t: int) -> tuple[np.ndarray, np.ndarray]:
    from scipy.spatial.transform import Rotation

    q = traj.object_quaternion[k, t]
    r_obj = Rotation.from_quat(q) if np.all(np.isfinite(q)) else Rotation.identity()
    p = r_obj.inv().apply(traj.tcp[t] - traj.object_position[k, t])
    r_tcp = (
        Rotation.from_matrix(traj.rotation[t]) if np.all(np.isfinite(traj.rotation[t])) else None
    )
    quat = (r_obj.inv() * r_tcp).as_quat() if r_tcp is not None else np.full(4, np.nan)
    return p, quat


def _vec(x: np.ndarray) -> list[float] | None:
    x = np.asarray(x, dtype=np.float64)
    return [float(v) for v in x] if np.all(np.isfinite(x)) else None


def skill_params(
    traj: Trajectory, skill: str, start: int, end: int, obj: int | None
) -> dict[str, Any]:
    """Parameters of a ``skill`` segment on samples ``start..end`` with target object ``obj``."""
    last = max(min(end, len(traj)) - 1, start)
    out: dict[str, Any] = {"tcp_start": _vec(traj.tcp[start]), "tcp_end": _vec(traj.tcp[last])}
    if obj is None or obj < 0 or obj >= len(traj.object_names):
        return out
    if skill in ("pick_up", "locate"):
        p, q = _pose_in_object(traj, obj, last)
        key = "grasp" if skill == "pick_up" else "tcp_in_object"
        out[f"{key}_position"] = _vec(p)
        if skill == "pick_up":
            out["grasp_quaternion"] = _vec(q)
    elif skill in ("place", "stack"):
        out["place_position"] = _vec(traj.object_position[obj, last])
        out["place_quaternion"] = _vec(traj.object_quaternion[obj, last])
        if skill == "stack" and len(traj.object_names) > 1:
            here = traj.object_position[obj, last]
            others = [k for k in range(len(traj.object_names)) if k != obj]
            d = [
                float(np.linalg.norm(traj.object_position[k, last, :2] - here[:2])) for k in others
            ]
            below = others[int(np.nanargmin(d))] if np.any(np.isfinite(d)) else others[0]
            out["on"] = traj.object_names[below]
            out["offset"] = _vec(here - traj.object_position[below, last])
    elif skill == "push":
        out["displacement"] = _vec(
            traj.object_position[obj, last] - traj.object_position[obj, start]
        )
    return out
