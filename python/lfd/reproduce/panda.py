"""The Franka Emika Panda with its hand, built from the MJCF and meshes in the ``robosuite`` wheel
(MIT licence; tested with robosuite 1.5.2).

robosuite's pins clash with ours, so it is installed with ``--no-deps`` (the ``robots`` extra,
docs/install.md) and never imported: its files are found with
``importlib.util.find_spec("robosuite").submodule_search_locations`` and read as XML.
``models/assets/robots/panda/robot.xml`` gives the arm (links, joints and their limits, meshes,
inertias), ``models/assets/grippers/panda_gripper.xml`` the hand, attached at the arm's
``right_hand`` body as robosuite does. What changes, to run the reproduction like the default
robot (:mod:`.robot`):

* the torque motors become position servos (the arm joints as the KUKA's, ``kp`` 2000 and ``kv``
  100; each finger 0-40 mm, a 20 N force limit), the joints get the same damping and armature
  and every body gravity compensation;
* the second finger's slide axis is flipped so both fingers open with a positive position;
* the arm links do not collide (as the KUKA's); the hand, the fingers and their pads do, the pads
  with the grasp settings of the KUKA's (high friction, elliptic cones);
* a ``tcp`` site between the finger pads (its y axis the closing axis, z the approach);
* meshes by absolute path, the cameras, sensors and marker sites dropped.
"""

from __future__ import annotations

import importlib.util
import os
import xml.etree.ElementTree as ET
from functools import cache

import numpy as np

from .aloha import SIDES, TwoArmRobot
from .arm import Limits, Robot

ROBOSUITE = "robosuite==1.5.2"
"""The tested robosuite version (:data:`lfd._extras.ROBOTS_INSTALL`)."""
HOME_Q: tuple[float, ...] = (
    0.0,
    np.pi / 16,
    0.0,
    -np.pi / 2 - np.pi / 3,
    0.0,
    np.pi - 0.2,
    np.pi / 4,
)
"""robosuite's initial Panda configuration: the hand in front of the base, pointing down."""
FINGER_RANGE = 0.04
"""Travel of each finger (m): the pads open 80 mm."""
PAD_Z = 0.0934
"""Pad centres along the hand's z axis from its base (m): finger at 0.0524, tip body 0.056 further,
the pad 0.015 back from it."""
FINGER_BELOW_TCP = 0.013
"""How far the fingertips (the finger meshes' farthest point, 12.9 mm) reach beyond the TCP."""
ARM_JOINTS = tuple(f"joint{i}" for i in range(1, 8))
FINGER_JOINTS = ("finger_joint1", "finger_joint2")
HAND_RADIUS = 0.05
"""The open fingers around the TCP (m): their outer faces 66 mm from it, as the KUKA's (whose
``hand_radius`` is 50 mm: moves add 1 cm and the object's half diagonal)."""
PALM_HALF = (0.032, 0.104)
"""The hand's collision mesh seen from above: 63 mm across the closing axis, 208 mm along it
(its underside :data:`PALM_ABOVE_TCP` above the TCP, 40 mm above the fingertips)."""
PALM_ABOVE_TCP = 0.027
"""The underside of the hand's collision mesh above the TCP (m)."""
_PAD = (
    '<default class="pad"><geom type="box" friction="1.5 0.02 0.002" condim="4" '
    'solref="0.01 1" solimp="0.95 0.99 0.001" rgba="0.1 0.1 0.1 1"/></default>'
)


def robosuite_assets() -> str:
    """robosuite's ``models/assets`` directory.

    Raises
    ------
    MissingExtraError
        robosuite is not installed (one line: how to install it).
    """
    from .._extras import message, missing
    from ..errors import MissingExtraError

    spec = importlib.util.find_spec("robosuite") if missing("robots") is None else None
    dirs = list(spec.submodule_search_locations or []) if spec is not None else []
    for d in dirs:
        assets = os.path.join(d, "models", "assets")
        if os.path.isfile(os.path.join(assets, "robots", "panda", "robot.xml")):
            return assets
    raise MissingExtraError(
        message("robots", who="the panda robot"), extra="robots", module="robosuite"
    )


def _absolute(asset: ET.Element, root: str) -> None:
    for el in asset:
        f = el.get("file")
        if f is not None:
            el.set("file", os.path.join(root, f))


def _strip(el: ET.Element, tags: tuple[str, ...]) -> None:
    for parent in el.iter():
        for child in list(parent):
            if child.tag in tags:
                parent.remove(child)


def _arm(assets: str) -> tuple[ET.Element, ET.Element]:
    """The arm's ``<asset>`` and its ``link0`` body (robot.xml)."""
    root = ET.parse(os.path.join(assets, "robots", "panda", "robot.xml")).getroot()
    asset = root.find("asset")
    link0 = root.find("./worldbody/body/body[@name='link0']")
    if asset is None or link0 is None:
        raise ValueError("robosuite's panda robot.xml has no <asset> or link0 body")
    _absolute(asset, os.path.join(assets, "robots", "panda"))
    _strip(link0, ("camera", "site"))
    for body in link0.iter("body"):
        body.set("gravcomp", "1")
    for joint in link0.iter("joint"):
        joint.attrib.pop("damping", None)  # the defaults': as the KUKA's
    for geom in link0.iter("geom"):  # the links do not collide (the KUKA's do not either)
        geom.set("contype", "0")
        geom.set("conaffinity", "0")
    return asset, link0


def _hand(assets: str) -> tuple[ET.Element, ET.Element]:
    """The hand's ``<asset>`` and its body, renamed ``gripper``, with the ``tcp`` site."""
    root = ET.parse(os.path.join(assets, "grippers", "panda_gripper.xml")).getroot()
    asset = root.find("asset")
    hand = root.find("./worldbody/body[@name='right_gripper']")
    if asset is None or hand is None:
        raise ValueError("robosuite's panda_gripper.xml has no <asset> or right_gripper body")
    _absolute(asset, os.path.join(assets, "grippers"))
    _strip(hand, ("camera", "site"))
    eef = hand.find("body[@name='eef']")  # marker sites only
    if eef is not None:
        hand.remove(eef)
    hand.set("name", "gripper")
    for body in hand.iter("body"):
        body.set("gravcomp", "1")
    for joint in hand.iter("joint"):
        for key in ("damping", "armature", "frictionloss"):
            joint.attrib.pop(key, None)
        joint.set("damping", "5")
        joint.set("armature", "0.01")
        joint.set("range", f"0 {FINGER_RANGE}")
        if joint.get("name") == "finger_joint2":  # both fingers open with a positive position
            joint.set("axis", "0 -1 0")
    for geom in hand.iter("geom"):
        if geom.get("name", "").endswith("_pad_collision"):
            for key in ("solref", "friction", "conaffinity", "contype"):
                geom.attrib.pop(key, None)
            geom.set("class", "pad")
    # the TCP between the pads; the site turned as the fingers are: y = closing, z = approach
    ET.SubElement(
        hand,
        "site",
        {
            "name": "tcp",
            "pos": f"0 0 {PAD_Z}",
            "quat": "0.707107 0 0 0.707107",
            "size": "0.006",
            "rgba": "1 0 0 1",
        },
    )
    return asset, hand


def _actuators(prefix: str = "") -> str:
    arm = "".join(
        f'<position name="{prefix}act_{j}" joint="{prefix}{j}" kp="2000" kv="100" '
        f'ctrlrange="{lo:.4f} {hi:.4f}"/>'
        for j, (lo, hi) in zip(ARM_JOINTS, JOINT_RANGE, strict=True)
    )
    fingers = "".join(
        f'<position name="{prefix}act_{f}" joint="{prefix}{f}" kp="300" kv="20" '
        f'forcerange="-20 20" ctrlrange="0 {FINGER_RANGE}"/>'
        for f in FINGER_JOINTS
    )
    bodies = [
        prefix + b
        for b in ("gripper", "leftfinger", "rightfinger", "finger_joint1_tip", "finger_joint2_tip")
    ]
    exclude = "".join(
        f'<exclude body1="{a}" body2="{b}"/>' for i, a in enumerate(bodies) for b in bodies[i + 1 :]
    )
    return f"<actuator>{arm}{fingers}</actuator><contact>{exclude}</contact>"


JOINT_RANGE: tuple[tuple[float, float], ...] = (
    (-2.8973, 2.8973),
    (-1.7628, 1.7628),
    (-2.8973, 2.8973),
    (-3.0718, -0.0698),
    (-2.8973, 2.8973),
    (-0.0175, 3.7525),
    (-2.8973, 2.8973),
)
"""The arm's joint limits (rad), as in robosuite's robot.xml (checked when the model is built)."""


@cache
def panda(prefix: str = "") -> Robot:
    """The Panda as a :class:`~lfd.reproduce.arm.Robot` (``--robot panda``), every name of its
    bodies, joints, geoms, sites and actuators prefixed with ``prefix`` (``""`` for the arm
    alone; ``"left/"``, ``"right/"`` in the two-arm scene of :func:`panda_pair`).

    Raises
    ------
    MissingExtraError
        robosuite is not installed.
    """
    assets = robosuite_assets()
    arm_asset, link0 = _arm(assets)
    hand_asset, hand = _hand(assets)
    ranges = [tuple(float(v) for v in j.get("range", "").split()) for j in link0.iter("joint")]
    if tuple(ranges) != JOINT_RANGE:
        raise ValueError(f"robosuite's panda joint limits changed: {ranges}")
    right_hand = link0.find(".//body[@name='right_hand']")
    if right_hand is None:
        raise ValueError("robosuite's panda robot.xml has no right_hand body")
    right_hand.append(hand)
    for el in link0.iter():
        for key in ("name", "joint"):
            if el.get(key):
                el.set(key, prefix + el.get(key, ""))
    defaults = (
        '<default><joint damping="2" armature="0.1"/>'
        f'<geom rgba="0.85 0.85 0.85 1" friction="1 0.005 0.0001"/>{_PAD}</default>'
        f"<asset>{''.join(ET.tostring(a, encoding='unicode') for a in (*arm_asset, *hand_asset))}"
        "</asset>"
    )
    return Robot(
        name=f"{prefix}panda",
        title="Franka Emika Panda with its hand (robosuite's MJCF)",
        body=ET.tostring(link0, encoding="unicode"),
        defaults=defaults,
        actuators=_actuators(prefix),
        arm_joints=tuple(prefix + j for j in ARM_JOINTS),
        finger_joints=(prefix + FINGER_JOINTS[0], prefix + FINGER_JOINTS[1]),
        joint_range=JOINT_RANGE,
        home_q=HOME_Q,
        wrist_yaw=WRIST_YAW,
        max_opening=2 * FINGER_RANGE,
        finger_below_tcp=FINGER_BELOW_TCP,
        finger_half_x=0.011,  # the finger meshes: 10.5 mm either side
        hand_radius=HAND_RADIUS,
        palm_above_tcp=PALM_ABOVE_TCP,
        tcp_offset=0.1065 + PAD_Z,  # link7 -> right_hand -> the pads
        shoulder_z=0.333,
        reach=REACH,
        limits=Limits(speed=0.6, acceleration=3.0, yaw_rate=2.5, yaw_acceleration=12.0),
        source=f"{ROBOSUITE} (MIT): models/assets/robots/panda, grippers/panda_gripper.xml",
        palm_half=PALM_HALF,
    )


WRIST_YAW = (-np.pi / 4, 1.0)
"""The last joint at -45 deg + (phi - yaw) points the closing axis along yaw (the hand sits turned
by -45 deg on the flange, robosuite's right_hand)."""
REACH = (0.38, 0.71)
"""Shoulder-wrist distances (m, the wrist 0.2 m above a top-down TCP) the base is placed for: the
IK reaches every top-down pose tried from 0.36 to 0.75 m (mink, any yaw), the margin as the
KUKA's."""


@cache
def two_pandas() -> TwoArmRobot:
    """Two Pandas facing each other across the table (``--robot two_pandas``): the two-arm robot
    for objects wider than the ALOHA's gripper closes across (the Panda hand opens 80 mm, the
    ViperX's 69 mm).

    Raises
    ------
    MissingExtraError
        robosuite is not installed.
    """
    one = panda()
    return TwoArmRobot(
        name="two_pandas",
        title="two Franka Emika Pandas with their hands (robosuite's MJCF)",
        arms={side: panda(f"{side}/") for side in SIDES},
        ik=one,
        source=one.source,
        base_levels=(0.2, 0.3),  # a Panda's long reach puts both bases behind the work
    )
