"""The simulated robot: a 7-DoF arm with KUKA LWR 4+ kinematics and a parallel-jaw gripper (MJCF).

Kinematics follow the commonly published DH table of the LWR 4+ (all ``a_i = 0``)::

    i        1       2      3      4      5      6      7
    d_i  0.3105      0   0.40      0   0.39      0  0.078   (m)
    alpha   +90    -90    -90    +90    +90    -90      0   (deg)

so in the zero configuration the arm stands straight up: shoulder (joint 2) at 0.3105 m, elbow
(joint 4) 0.40 m higher, wrist (joint 6) another 0.39 m, flange 0.078 m above the wrist. The
hinge axes of the MJCF below are the DH ``z_{i-1}`` axes expressed in the base frame (joints 2 and
6 about -y, joint 4 about +y, the others about +z), so MJCF joint angles equal DH angles; the test
suite checks the MJCF forward kinematics against the DH product. Limits are +-170 deg for the
odd joints and +-120 deg for the even ones.

The gripper hangs below the flange: a palm and two fingers on slide joints that close along the
gripper's local y axis. The tool centre point (site ``tcp``) is the centre between the finger pads,
:data:`TCP_OFFSET` below the flange. Gripper convention: z = approach direction (out of the
flange), y = closing direction. Grasp settings follow FIELD-NOTES (elliptic cones, high-friction
pads, gravity compensation on every link body, position servos).
"""

from __future__ import annotations

import numpy as np

from .arm import Limits, Robot

DH_D: tuple[float, ...] = (0.3105, 0.0, 0.40, 0.0, 0.39, 0.0, 0.078)
"""DH offsets ``d_i`` of the KUKA LWR 4+ (m)."""
DH_ALPHA_DEG: tuple[float, ...] = (90.0, -90.0, -90.0, 90.0, 90.0, -90.0, 0.0)
"""DH twists ``alpha_i`` (deg)."""
JOINT_LIMITS_DEG: tuple[float, ...] = (170.0, 120.0, 170.0, 120.0, 170.0, 120.0, 170.0)
"""Symmetric joint limits (deg)."""
JOINT_NAMES: tuple[str, ...] = tuple(f"joint{i}" for i in range(1, 8))
FINGER_JOINTS: tuple[str, str] = ("finger_left", "finger_right")
MAX_OPENING = 0.10
"""Largest distance between the finger pads (m)."""
PAD_Z = 0.10
"""Distance from the flange to the pad centres along the gripper z axis (m)."""
TCP_OFFSET = 0.078 + PAD_Z
"""Distance from the wrist centre (joint 6) to the TCP along the last link (m)."""
FINGER_BELOW_TCP = 0.018
"""How far the fingertips reach beyond the TCP along the approach axis (m)."""
FINGER_HALF_X = 0.015
"""Half width of a finger along the gripper x axis (m): the contact offset when pushing."""
_FINGER_HALF_LEN = (PAD_Z + FINGER_BELOW_TCP - 0.03) / 2  # fingers: palm bottom -> tips
_FINGER_MID = 0.03 + _FINGER_HALF_LEN
HOME_Q: tuple[float, ...] = (0.0, -0.6, 0.0, 1.5, 0.0, -1.04, 0.0)
"""A comfortable configuration (TCP in front of the base, pointing down)."""


def dh_forward(q: np.ndarray) -> np.ndarray:
    """Flange pose from the DH table (the reference the MJCF is checked against).

    Parameters
    ----------
    q : array, shape (7,)
        Joint angles in radians.

    Returns
    -------
    array, shape (4, 4)
        Homogeneous pose of the flange in the robot base frame.
    """
    q = np.asarray(q, dtype=np.float64).reshape(7)
    T = np.eye(4)
    for theta, d, alpha in zip(q, DH_D, np.radians(DH_ALPHA_DEG), strict=True):
        ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
        A = np.array(
            [
                [ct, -st * ca, st * sa, 0.0],
                [st, ct * ca, -ct * sa, 0.0],
                [0.0, sa, ca, d],
                [0.0, 0.0, 0.0, 1.0],
            ]
        )
        T = T @ A
    return T


def _arm_bodies() -> str:
    # (body offset from parent along z, hinge axis, capsule length, radius) per link, DH order.
    links = [
        (0.0, "0 0 1", 0.25, 0.065),  # link1: base -> shoulder (0.3105)
        (0.3105, "0 -1 0", 0.18, 0.06),  # link2: shoulder
        (0.0, "0 0 1", 0.36, 0.06),  # link3: shoulder -> elbow (0.40)
        (0.40, "0 1 0", 0.18, 0.055),  # link4: elbow
        (0.0, "0 0 1", 0.35, 0.055),  # link5: elbow -> wrist (0.39)
        (0.39, "0 -1 0", 0.05, 0.045),  # link6: wrist
        (0.0, "0 0 1", 0.05, 0.04),  # link7: wrist -> flange (0.078)
    ]
    opening = ""
    closing = ""
    for i, (dz, axis, length, radius) in enumerate(links, start=1):
        lim = np.radians(JOINT_LIMITS_DEG[i - 1])
        if i % 2 == 1:  # links along the arm axis
            z0, z1 = 0.03, 0.03 + length
            if i == 7:
                z0, z1 = 0.0, 0.06
            geom = f'<geom class="link" fromto="0 0 {z0:.4f} 0 0 {z1:.4f}" size="{radius}"/>'
        else:  # the joint housings
            geom = f'<geom class="link" fromto="0 -0.04 0 0 0.04 0" size="{radius}"/>'
        opening += (
            f'<body name="link{i}" pos="0 0 {dz}" gravcomp="1">'
            f'<inertial pos="0 0 0.05" mass="{2.0 - 0.2 * i:.2f}" diaginertia="0.02 0.02 0.01"/>'
            f'<joint name="joint{i}" axis="{axis}" range="{-lim:.5f} {lim:.5f}"/>{geom}'
        )
        closing = "</body>" + closing
    gripper = f"""
      <body name="gripper" pos="0 0 0.078" gravcomp="1">
        <inertial pos="0 0 0.02" mass="0.4" diaginertia="0.001 0.001 0.001"/>
        <geom name="palm" type="box" size="0.02 0.065 0.015" pos="0 0 0.015" rgba="0.2 0.2 0.2 1"/>
        <site name="flange" pos="0 0 0" size="0.005"/>
        <site name="tcp" pos="0 0 {PAD_Z}" size="0.006" rgba="1 0 0 1"/>
        <body name="finger_left" pos="0 0 0" gravcomp="1">
          <inertial pos="0 0.01 0.06" mass="0.05" diaginertia="1e-5 1e-5 1e-5"/>
          <joint name="finger_left" type="slide" axis="0 1 0" range="0 {MAX_OPENING / 2}"
                 damping="5" armature="0.01"/>
          <geom type="box" size="{FINGER_HALF_X} 0.006 {_FINGER_HALF_LEN:.4f}" pos="0 0.010 {_FINGER_MID:.4f}" rgba="0.3 0.3 0.35 1"/>
          <geom name="pad_left" class="pad" size="0.013 0.002 0.016" pos="0 0.002 {PAD_Z}"/>
        </body>
        <body name="finger_right" pos="0 0 0" gravcomp="1">
          <inertial pos="0 -0.01 0.06" mass="0.05" diaginertia="1e-5 1e-5 1e-5"/>
          <joint name="finger_right" type="slide" axis="0 -1 0" range="0 {MAX_OPENING / 2}"
                 damping="5" armature="0.01"/>
          <geom type="box" size="{FINGER_HALF_X} 0.006 {_FINGER_HALF_LEN:.4f}" pos="0 -0.010 {_FINGER_MID:.4f}" rgba="0.3 0.3 0.35 1"/>
          <geom name="pad_right" class="pad" size="0.013 0.002 0.016" pos="0 -0.002 {PAD_Z}"/>
        </body>
      </body>"""
    return opening + gripper + closing


def robot_xml(base: np.ndarray | tuple[float, float, float] = (0.0, 0.0, 0.0)) -> str:
    """MJCF body tree of the arm (to be placed inside ``<worldbody>``).

    Parameters
    ----------
    base : array, shape (3,)
        Position of the robot base in the world frame (the base sits at table height).
    """
    return KUKA_LWR4.base_xml(base)


def robot_defaults() -> str:
    """The ``<default>`` block shared by the robot models (joint damping, pad contacts)."""
    return """
  <default>
    <joint damping="2" armature="0.1"/>
    <geom rgba="0.85 0.45 0.1 1" friction="1 0.005 0.0001"/>
    <default class="link">
      <geom type="capsule" contype="0" conaffinity="0"/>
    </default>
    <default class="pad">
      <geom type="box" friction="1.5 0.02 0.002" condim="4" solref="0.01 1"
            solimp="0.95 0.99 0.001" rgba="0.1 0.1 0.1 1"/>
    </default>
  </default>"""


def robot_actuators() -> str:
    """Position servos for the 7 arm joints and the two fingers, plus contact exclusions."""
    arm = "".join(
        f'<position name="act_{j}" joint="{j}" kp="2000" kv="100" '
        f'ctrlrange="{-np.radians(lim):.4f} {np.radians(lim):.4f}"/>'
        for j, lim in zip(JOINT_NAMES, JOINT_LIMITS_DEG, strict=True)
    )
    fingers = "".join(
        f'<position name="act_{f}" joint="{f}" kp="300" kv="20" forcerange="-20 20" '
        f'ctrlrange="0 {MAX_OPENING / 2}"/>'
        for f in FINGER_JOINTS
    )
    exclude = (
        '<exclude body1="finger_left" body2="finger_right"/>'
        '<exclude body1="gripper" body2="finger_left"/>'
        '<exclude body1="gripper" body2="finger_right"/>'
    )
    return f"<actuator>{arm}{fingers}</actuator><contact>{exclude}</contact>"


def robot_model_xml(base: np.ndarray | tuple[float, float, float] = (0.0, 0.0, 0.0)) -> str:
    """A complete MJCF model with only the robot (used for inverse kinematics)."""
    return KUKA_LWR4.model_xml(base)


KUKA_LWR4 = Robot(
    name="kuka_lwr4",
    title="KUKA LWR 4+ with a parallel-jaw gripper",
    body=(
        '<geom class="link" type="cylinder" size="0.08 0.01" pos="0 0 0.01" rgba="0.5 0.5 0.5 1"/>'
        + _arm_bodies()
    ),
    defaults=robot_defaults(),
    actuators=robot_actuators(),
    arm_joints=JOINT_NAMES,
    finger_joints=FINGER_JOINTS,
    joint_range=tuple((-float(np.radians(d)), float(np.radians(d))) for d in JOINT_LIMITS_DEG),
    home_q=HOME_Q,
    wrist_yaw=(np.pi / 2, 1.0),
    max_opening=MAX_OPENING,
    finger_below_tcp=FINGER_BELOW_TCP,
    finger_half_x=FINGER_HALF_X,
    hand_radius=MAX_OPENING / 2,  # the palm hangs 70 mm above the TCP: the fingers count
    palm_above_tcp=PAD_Z - 0.03,  # the palm box's underside, 30 mm below the flange
    tcp_offset=TCP_OFFSET,
    shoulder_z=DH_D[0],
    # the elbow limit (120 deg) allows 0.395 m, the stretched arm 0.79 m
    reach=(0.43, 0.76),
    # a KUKA LWR 4+ moves its TCP at up to about 1 m/s; these leave room for the IK and the
    # position servos to keep the TCP within a few millimetres of the plan, and for a box held
    # by friction alone (chosen on the simulated demos and the real motion capture)
    limits=Limits(speed=0.6, acceleration=3.0, yaw_rate=2.5, yaw_acceleration=12.0),
    source="hand-written MJCF with the LWR 4+'s published DH kinematics (this module)",
    palm_half=(0.02, 0.065),  # the palm box
)
"""The default robot (``--robot kuka_lwr4``)."""
