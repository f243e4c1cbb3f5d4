"""The robot value (:class:`Robot`: an arm with its gripper, as the reproduction sees it) and the
TCP limits of time scaling (:class:`Limits`); the robots themselves are in :mod:`.robot` (the
KUKA LWR 4+) and :mod:`.panda`, their registry in :mod:`.robots`."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["OPTIONS", "Limits", "Robot"]


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
    hand_radius : float
        How far (m, horizontally) around the TCP the open fingers reach, at the fingertips'
        height (moves keep this clear of the objects, :func:`~lfd.reproduce.motion.clear`); the
        hand above them is :attr:`palm_half`.
    palm_above_tcp : float
        Height of the palm's lowest point above the TCP along the approach axis (m): a grasp or
        a push keeps it above the object's top (:data:`~lfd.reproduce.goals.PALM_CLEARANCE`).
    palm_half : tuple of float, float, or None
        The hand's outline (the gripper body the fingers hang from) seen from above: half its
        extent across the closing axis (the gripper's x) and along it (y), m. With
        :attr:`palm_above_tcp` it is a box from that height upwards that moves keep clear of the
        objects at the gripper's yaw (:func:`~lfd.reproduce.motion.palm_near`); None: the hand
        is not modelled beyond :attr:`hand_radius` and :attr:`palm_above_tcp`.
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
    hand_radius: float
    palm_above_tcp: float
    tcp_offset: float
    shoulder_z: float
    reach: tuple[float, float]
    limits: Limits = field(default_factory=Limits)
    source: str = ""
    palm_half: tuple[float, float] | None = None

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
