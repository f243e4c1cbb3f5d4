"""Hand -> parallel gripper mapping (paper Sec. III-A.2, Fig. 2).

From three keypoints, the index fingertip ``I`` (8), the thumb tip ``T`` (4) and the index base
``B`` (5): the tool centre point is ``TCP = (I + T) / 2``; the frame has its origin at ``B``,
``z`` along ``B -> TCP``, ``x`` normal to the plane of ``I``, ``T``, ``B``
(``x = (I - B) x (T - B) / |...|`` for a right hand, the opposite for a left hand so that ``x``
has the same meaning on the mirrored hand) and ``y = z x x``; ``R = [x y z]`` (columns). The
gripper opening is ``|I - T|``.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from .. import rotations
from ..demo import INDEX_MCP, INDEX_TIP, THUMB_TIP
from ..errors import DemonstrationError

__all__ = ["euler_from_rotation", "gripper_frame", "rotation_from_euler"]

EULER_SEQ = "xyz"
"""Euler convention of :attr:`lfd.trajectory.Trajectory.euler` (scipy's name: extrinsic x-y-z;
computed by :mod:`lfd.rotations`)."""

DEGENERATE_TOL = 1e-6
"""Samples whose ``|(I - B) x (T - B)|`` is below this fraction of ``|I - B| |T - B|`` (the
sine of the angle at ``B``) are degenerate: I, T and B are (nearly) collinear."""


def gripper_frame(
    keypoints: npt.ArrayLike, *, side: str = "right", strict: bool = False
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The gripper pose and opening from hand keypoints.

    Parameters
    ----------
    keypoints : array, shape (n, 21, 3)
        Hand keypoints, MediaPipe order, metres. NaN keypoints give NaN outputs.
    side : str
        ``"right"`` or ``"left"`` (mirrors the x axis).
    strict : bool
        Raise on degenerate samples instead of returning NaN for them.

    Returns
    -------
    tcp : array, shape (n, 3)
        Tool centre point ``(I + T) / 2``.
    rotation : array, shape (n, 3, 3)
        Columns are the x, y, z axes of the gripper frame; NaN for missing or degenerate
        samples (I, T and B collinear or coincident).
    opening : array, shape (n,)
        ``|I - T|``.

    Raises
    ------
    DemonstrationError
        Wrong shape, or (with ``strict``) a degenerate sample.
    """
    kp = np.asarray(keypoints, dtype=np.float64)
    if kp.ndim != 3 or kp.shape[1:] != (21, 3):
        raise DemonstrationError(f"keypoints must have shape (n, 21, 3), got {kp.shape}")
    if side not in ("right", "left"):
        raise DemonstrationError(f"hand side must be 'right' or 'left', got {side!r}")
    index, thumb, base = kp[:, INDEX_TIP], kp[:, THUMB_TIP], kp[:, INDEX_MCP]
    tcp = 0.5 * (index + thumb)
    opening = np.linalg.norm(index - thumb, axis=1)
    bi, bt = index - base, thumb - base
    normal = np.cross(bi, bt) if side == "right" else np.cross(bt, bi)
    scale = np.linalg.norm(bi, axis=1) * np.linalg.norm(bt, axis=1)
    nn = np.linalg.norm(normal, axis=1)
    axis_z = tcp - base
    nz = np.linalg.norm(axis_z, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        degenerate = ~(nn > DEGENERATE_TOL * scale) | ~(nz > 0)
        observed = np.isfinite(kp[:, [INDEX_TIP, THUMB_TIP, INDEX_MCP]]).all(axis=(1, 2))
        bad = degenerate & observed
        if strict and bad.any():
            raise DemonstrationError(
                f"{int(bad.sum())} hand samples are degenerate (index tip, thumb tip and index "
                f"base collinear), first at sample {int(np.flatnonzero(bad)[0])}"
            )
        x = normal / nn[:, None]
        z = axis_z / nz[:, None]
    y = np.cross(z, x)
    rotation = np.stack([x, y, z], axis=2)
    rotation[degenerate | ~observed] = np.nan
    return tcp, rotation, opening


def euler_from_rotation(rotation: npt.ArrayLike) -> np.ndarray:
    """XYZ Euler angles, shape (n, 3), of rotation matrices, shape (n, 3, 3); NaN stays NaN.

    The angles are not unwrapped (see :func:`lfd.preprocessing.filters.unwrap_runs`).
    """
    r = np.asarray(rotation, dtype=np.float64)
    if r.ndim != 3 or r.shape[1:] != (3, 3):
        raise DemonstrationError(f"rotations must have shape (n, 3, 3), got {r.shape}")
    return rotations.euler_from_matrix(r)


def rotation_from_euler(euler: npt.ArrayLike) -> np.ndarray:
    """Rotation matrices, shape (n, 3, 3), of XYZ Euler angles, shape (n, 3); NaN stays NaN."""
    e = np.asarray(euler, dtype=np.float64)
    if e.ndim != 2 or e.shape[1] != 3:
        raise DemonstrationError(f"Euler angles must have shape (n, 3), got {e.shape}")
    return rotations.matrix_from_euler(e)
