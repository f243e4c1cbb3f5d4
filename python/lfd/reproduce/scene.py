"""The reproduction scene: table (top at z = 0), the robot at table height, the demo's cuboids.

World frame = the reference marker frame of the demonstration (Z up). Objects are free bodies
(0.1 kg) at their demonstrated initial poses, optionally displaced. The robot base is placed by
:func:`choose_base` so that every demonstrated TCP point is reachable with a top-down gripper.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .arm import OPTIONS, Robot
from .robot import KUKA_LWR4

TABLE_HALF = 1.2
"""Half side of the square table top (m)."""


def table_centre(base: np.ndarray) -> np.ndarray:
    """Centre (x, y) of the table top: 0.4 m in front of the robot base."""
    return np.array([base[0] + 0.4, base[1]])


@dataclass
class ObjectSpec:
    """A cuboid of the scene.

    Attributes
    ----------
    name : str
    size : array, shape (3,)
        Box dimensions (m).
    position : array, shape (3,)
        Initial centre (m).
    quaternion : array, shape (4,)
        Initial orientation (x, y, z, w).
    """

    name: str
    size: np.ndarray
    position: np.ndarray
    quaternion: np.ndarray


def choose_base(
    points: np.ndarray, keep_out: np.ndarray | None = None, *, robot: Robot = KUKA_LWR4
) -> np.ndarray:
    """Robot base position (z = 0) from which all TCP points are reachable top-down.

    Maximises the smallest reach margin (shoulder-wrist distance inside the robot's
    :attr:`~lfd.reproduce.arm.Robot.reach`) over a grid of candidate bases, keeping 0.14 m away from the ``keep_out`` points (objects).

    Parameters
    ----------
    points : array, shape (n, 3)
        TCP positions the robot must reach (world frame).
    keep_out : array, shape (m, 2) or (m, 3), optional
        Positions the base must stay clear of.
    robot : Robot
        Whose reach (and wrist above the TCP, shoulder height) counts.

    Returns
    -------
    array, shape (3,)
    """
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    pts = pts[np.all(np.isfinite(pts), axis=1)]
    if pts.shape[0] > 400:
        pts = pts[np.linspace(0, pts.shape[0] - 1, 400).astype(int)]
    wrist = pts + np.array([0.0, 0.0, robot.tcp_offset])
    lo, hi = pts[:, :2].min(axis=0) - 0.8, pts[:, :2].max(axis=0) + 0.8
    gx, gy = np.meshgrid(np.arange(lo[0], hi[0], 0.02), np.arange(lo[1], hi[1], 0.02))
    cand = np.stack([gx.ravel(), gy.ravel()], axis=1)
    dxy = wrist[None, :, :2] - cand[:, None, :]
    dz = wrist[None, :, 2] - robot.shoulder_z
    d = np.sqrt(np.sum(dxy**2, axis=2) + dz**2)
    margin = np.minimum(d - robot.reach[0], robot.reach[1] - d).min(axis=1)
    # keep the base away from the objects and from the TCP path itself
    clear = np.sqrt(np.sum(dxy**2, axis=2)).min(axis=1) >= 0.2
    if keep_out is not None and len(keep_out):
        ko = np.asarray(keep_out, dtype=np.float64)[:, :2]
        clear &= np.sqrt(((cand[:, None, :] - ko[None]) ** 2).sum(axis=2)).min(axis=1) >= 0.14
    # prefer the robot behind the workspace (-x side), as in the paper's set-up
    centre = pts[:, :2].mean(axis=0)
    score = margin - 0.02 * np.clip(cand[:, 0] - centre[0] + 0.3, 0.0, None)
    score[~clear] = -np.inf
    best = cand[int(np.argmax(score))]
    return np.array([best[0], best[1], 0.0])


def scene_xml(
    base: np.ndarray,
    objects: list[ObjectSpec],
    *,
    table_half: float = TABLE_HALF,
    robot: Robot = KUKA_LWR4,
) -> str:
    """MJCF of the full scene: floor-less table, robot, free-body cuboids, a camera and lights."""
    bodies = []
    for ob in objects:
        s = np.asarray(ob.size) / 2
        p = ob.position
        x, y, z, w = ob.quaternion
        bodies.append(
            f'<body name="{ob.name}" pos="{p[0]:.6f} {p[1]:.6f} {p[2]:.6f}" '
            f'quat="{w:.6f} {x:.6f} {y:.6f} {z:.6f}"><freejoint name="{ob.name}"/>'
            f'<geom name="{ob.name}" type="box" size="{s[0]:.5f} {s[1]:.5f} {s[2]:.5f}" '
            f'mass="0.1" friction="1 0.005 0.0001" condim="4" rgba="{_colour(ob.name)}"/></body>'
        )
    c = np.asarray(base)[:2]
    t = table_centre(np.asarray(base))
    return f"""<mujoco model="lfd_reproduce">{OPTIONS}{robot.defaults}
  <visual><quality offsamples="0"/><global offwidth="1280" offheight="960"/></visual>
  <worldbody>
    <light pos="{c[0]:.3f} {c[1]:.3f} 2.5" dir="0 0 -1" directional="true"/>
    <geom name="table" type="box" pos="{t[0]:.3f} {t[1]:.3f} -0.02"
          size="{table_half} {table_half} 0.02" rgba="0.75 0.7 0.62 1" friction="1 0.005 0.0001"/>
    {robot.base_xml(base)}
    {"".join(bodies)}
  </worldbody>{robot.actuators}
</mujoco>"""


def _colour(name: str) -> str:
    palette = ["0.85 0.2 0.2 1", "0.2 0.55 0.9 1", "0.2 0.75 0.3 1", "0.9 0.8 0.2 1"]
    return palette[sum(map(ord, name)) % len(palette)]
