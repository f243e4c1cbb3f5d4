"""A robot is a value: one :class:`Robot` describes an arm with its gripper (MJCF, joints and
limits, home pose, TCP, gripper geometry, reach, TCP speed limits), and the reproduction reads it
(:mod:`.scene`, :mod:`.ik`, :mod:`.controller`, :mod:`.goals`, :mod:`.modes`, :mod:`.motion`,
:mod:`.displacement`, :mod:`.timescale`). :data:`ROBOTS` names every robot; :func:`robot` builds
one (``lfd reproduce --robot NAME``).

A new robot is one module that builds a :class:`Robot` and one entry of :data:`ROBOTS`:

* ``kuka_lwr4`` (the default): the hand-written KUKA LWR 4+ with a parallel-jaw gripper
  (:mod:`.robot`);
* ``panda``: the Franka Emika Panda with its hand, from the MJCF and meshes of the
  ``robosuite`` wheel (:mod:`.panda`; the ``robots`` extra).

Conventions every robot follows (the reproduction relies on them): the arm's MJCF body tree is
placed inside ``<body name="robot_base">`` at the base position (z = 0 is the table top), the
arm joints come first in ``qpos`` and ``ctrl`` (position servos), then the two finger joints
(position servos, each opening by half the commanded opening, 0 = closed); the site ``tcp`` is
the centre between the finger pads, its z axis the approach direction and its y axis the
closing direction; the body ``gripper`` holds the palm (contacts between it and the fingers are
excluded).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cache

import numpy as np

__all__ = ["DEFAULT_ROBOT", "ROBOTS", "Limits", "Robot", "robot", "robot_names"]


@dataclass(frozen=True)
class Limits:
    """TCP limits the planned path is scaled to (SI units, :mod:`.timescale`)."""

    speed: float = 0.6
    """Largest TCP speed (m/s)."""
    acceleration: float = 3.0
    """Largest TCP acceleration (m/s²)."""
    yaw_rate: float = 2.5
    """Largest gripper yaw rate (rad/s)."""
    yaw_acceleration: float = 12.0
    """Largest gripper yaw acceleration (rad/s²)."""

    def __post_init__(self) -> None:
        from ..errors import InvalidParameterError

        vals = (self.speed, self.acceleration, self.yaw_rate, self.yaw_acceleration)
        if not all(np.isfinite(v) and v > 0 for v in vals):
            raise InvalidParameterError(f"time-scaling limits must be positive, got {self}")


OPTIONS = (
    '<option timestep="0.002" cone="elliptic" impratio="10" integrator="implicitfast"/>'
    '<compiler angle="radian"/>'
)
"""Simulation options that made grasps stable (FIELD-NOTES); the same for every robot."""


@dataclass(frozen=True)
class Robot:
    """One arm with its gripper, as the reproduction sees it.

    Attributes
    ----------
    name : str
        The registry name (``--robot NAME``).
    title : str
        What it is, in a few words (for messages and docs).
    body : str
        MJCF of the arm and gripper, placed inside ``<body name="robot_base">`` (base frame).
    defaults : str
        MJCF ``<default>`` and ``<asset>`` blocks the body needs (meshes by absolute path).
    actuators : str
        MJCF ``<actuator>`` (position servos: the arm joints, then the two fingers) and
        ``<contact>`` exclusions.
    arm_joints : tuple of str
        The arm's joint names, base to flange (their servos are the first ``ctrl`` entries).
    finger_joints : tuple of str, str
        The two finger slide joints: each opens by half the opening (0 = closed).
    joint_range : tuple of (lo, hi)
        Each arm joint's limits (rad).
    home_q : tuple of float
        A comfortable configuration: the TCP in front of the base, pointing down. The IK's
        posture task keeps the redundant elbow near it.
    wrist_yaw : tuple of float, float
        ``(offset, sign)``: with the first joint turned to heading ``phi`` and the others at
        :attr:`home_q`, the last joint at ``offset + sign * (phi - yaw)`` points the closing
        axis along ``yaw`` (:meth:`~lfd.reproduce.ik.ArmIK.seed_towards`).
    max_opening : float
        Largest distance between the finger pads (m).
    finger_below_tcp : float
        How far the fingertips reach beyond the TCP along the approach axis (m).
    finger_half_x : float
        Half width of a finger across the closing axis (m): the contact offset when pushing.
    tcp_offset : float
        Distance from the wrist centre to the TCP along the last link (m): the wrist of a
        top-down grasp is this far above the TCP.
    shoulder_z : float
        Height of the shoulder (the second joint's axis) above the base (m).
    reach : tuple of float, float
        Shoulder-wrist distances (m) the base is placed for
        (:func:`~lfd.reproduce.scene.choose_base`) and a displaced object must lie within.
    limits : Limits
        TCP speed and acceleration the plans are slowed to (:mod:`.timescale`).
    source : str
        Where the model comes from and its licence.
    """

    name: str
    title: str
    body: str
    defaults: str
    actuators: str
    arm_joints: tuple[str, ...]
    finger_joints: tuple[str, str]
    joint_range: tuple[tuple[float, float], ...]
    home_q: tuple[float, ...]
    wrist_yaw: tuple[float, float]
    max_opening: float
    finger_below_tcp: float
    finger_half_x: float
    tcp_offset: float
    shoulder_z: float
    reach: tuple[float, float]
    limits: Limits = field(default_factory=Limits)
    source: str = ""

    @property
    def dof(self) -> int:
        """Number of arm joints."""
        return len(self.arm_joints)

    def base_xml(self, base: np.ndarray | tuple[float, float, float] = (0.0, 0.0, 0.0)) -> str:
        """The arm's body tree at ``base`` (to be placed inside ``<worldbody>``)."""
        b = np.asarray(base, dtype=np.float64).reshape(3)
        return f'<body name="robot_base" pos="{b[0]:.6f} {b[1]:.6f} {b[2]:.6f}">{self.body}</body>'

    def model_xml(self, base: np.ndarray | tuple[float, float, float] = (0.0, 0.0, 0.0)) -> str:
        """A complete MJCF model with only the robot (used for inverse kinematics)."""
        return (
            f'<mujoco model="{self.name}">{OPTIONS}{self.defaults}'
            f"<worldbody>{self.base_xml(base)}</worldbody>{self.actuators}</mujoco>"
        )


def _kuka() -> Robot:
    from .robot import KUKA_LWR4

    return KUKA_LWR4


def _panda() -> Robot:
    from .panda import panda

    return panda()


ROBOTS: dict[str, Callable[[], Robot]] = {"kuka_lwr4": _kuka, "panda": _panda}
"""Every robot by name: a function that builds it (a robot from an optional package is built
when asked for, and says in one line how to install it when the package is missing)."""
DEFAULT_ROBOT = "kuka_lwr4"


def robot_names() -> tuple[str, ...]:
    """The registry's names, the default first."""
    return (DEFAULT_ROBOT, *sorted(n for n in ROBOTS if n != DEFAULT_ROBOT))


@cache
def robot(name: str = DEFAULT_ROBOT) -> Robot:
    """The robot called ``name`` (:data:`ROBOTS`).

    Raises
    ------
    UsageError
        An unknown name (the message lists the known robots).
    MissingExtraError
        The robot's model comes from a package that is not installed.
    """
    from ..errors import UsageError

    if name not in ROBOTS:
        raise UsageError(f"unknown robot {name!r}; known robots: {', '.join(robot_names())}")
    return ROBOTS[name]()
