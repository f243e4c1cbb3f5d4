"""The two-arm ALOHA (two Trossen ViperX 300s arms with their parallel grippers), built from the
MJCF and meshes in the ``gym-aloha`` wheel (Apache-2.0; tested with gym-aloha 0.1.5).

gym-aloha pins mujoco < 3.9 and dm-control, so it is installed with ``--no-deps`` (the ``aloha``
extra) and never imported: ``vx300s_left.xml`` (one arm, 6 joints and two finger slides) and
``vx300s_dependencies.xml`` (the meshes) are found with
``importlib.util.find_spec("gym_aloha").submodule_search_locations`` and read as XML.

One arm is a :class:`~lfd.reproduce.robots.Robot` (:func:`viperx`, its names prefixed so that
two fit in one scene); the pair is a :class:`TwoArmRobot` (:func:`aloha`). What changes from
gym-aloha's arm, to run the reproduction like the default robot:

* the servos as the KUKA's (position, ``kp`` 2000, ``kv`` 100 for every arm joint; fingers
  ``kp`` 300 with a 20 N limit), damping and armature from the defaults, no joint friction
  loss (gym-aloha's 30-60 N m friction stands in for motor brakes), gravity compensation;
* the fingers re-zeroed so that 0 is closed (the pads touch) and both open with a positive
  position, each by half the opening (0..:data:`FINGER_RANGE`); each finger collides as a flat
  pad (:data:`PAD_HALF`, the grasp settings of the KUKA's), its tapered mesh only seen;
* the base turned so the arm points along the base frame's +x (as the other robots), the links
  kept out of collisions (the gripper and fingers collide), the pads with the grasp settings;
* a ``tcp`` site between the pads (y the closing axis, z the approach = the gripper link's +x);
* meshes by absolute path, the cameras and calibration sites dropped.
"""

from __future__ import annotations

import importlib.util
import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from functools import cache

import numpy as np

from .arm import Limits, Robot

GYM_ALOHA = "gym-aloha==0.1.5"
"""The tested gym-aloha version."""
INSTALL = f"pip install --no-deps {GYM_ALOHA}"  # as lfd._extras.ALOHA_INSTALL
ARM_JOINTS = ("waist", "shoulder", "elbow", "forearm_roll", "wrist_angle", "wrist_rotate")
FINGER_JOINTS = ("left_finger", "right_finger")
JOINT_RANGE: tuple[tuple[float, float], ...] = (
    (-3.14158, 3.14158),
    (-1.85005, 1.25664),
    (-1.76278, 1.6057),
    (-3.14158, 3.14158),
    (-1.8675, 2.23402),
    (-3.14158, 3.14158),
)
"""The arm's joint limits (rad), as in gym-aloha's vx300s_left.xml (checked when built)."""


def aloha_assets() -> str:
    """gym-aloha's ``assets`` directory.

    Raises
    ------
    MissingExtraError
        gym-aloha is not installed (one line: how to install it).
    """
    from ..errors import MissingExtraError

    spec = importlib.util.find_spec("gym_aloha")
    dirs = list(spec.submodule_search_locations or []) if spec is not None else []
    for d in dirs:
        assets = os.path.join(d, "assets")
        if os.path.isfile(os.path.join(assets, "vx300s_left.xml")):
            return assets
    raise MissingExtraError(
        f"the aloha robot needs gym-aloha's model files (gym-aloha is missing): {INSTALL}",
        extra="aloha",
    )


FINGER_CLOSED = 0.0224
"""gym-aloha's finger position (m) at which the two pads touch (its range starts at 0.021, where
the custom finger meshes overlap by 2.8 mm): the new zero."""
FINGER_RANGE = 0.057 - FINGER_CLOSED
"""Travel of each finger (m): the pads open 69 mm."""
TCP_X = 0.137
"""The TCP along the gripper link's x axis from its origin (m): 17 mm short of the fingertips
(the finger meshes reach 0.154 m), where the pads are."""
FINGER_LINK_X = 0.0687
"""Where the finger bodies sit on the gripper link, along its x axis (m, gym-aloha's MJCF)."""
FINGER_BELOW_TCP = 0.017
WRIST_TO_GRIPPER = 0.069744
"""From the wrist_angle axis to the gripper link (m, vx300s_left.xml)."""
SHOULDER_Z = 0.079 + 0.04805
"""Height of the shoulder axis above the base (m)."""
HOME_Q: tuple[float, ...] = (0.0, -0.35, 0.55, 0.0, 1.37, 0.0)
"""The TCP about 0.3 m in front of the base, 0.1 m above the table, pointing down."""
WRIST_YAW = (np.pi / 2, 1.0)
"""The last joint at 90 deg + (phi - yaw) points the closing axis along yaw."""
REACH = (0.2, 0.55)
"""Shoulder-wrist distances (m, the wrist 0.207 m above a top-down TCP) the base is placed for:
the IK reaches every top-down pose tried up to 0.55 m within 1.3 mm (any yaw; 0.606 m stretched)."""
PAD_HALF = (0.03, 0.005, 0.008)
"""Half sizes (m) of each finger's collision pad: along the approach (from the fingertip up),
the closing axis (from the inner face out) and across: the finger meshes' lowest 60 mm, whose
width tapers to 10 mm at the tip and widens above, collide as these flat boxes."""
_PAD = (
    '<default class="pad"><geom friction="1.5 0.02 0.002" condim="4" '
    'solref="0.01 1" solimp="0.95 0.99 0.001"/></default>'
)
_SOURCE = "vx300s_left/"


def _rename(name: str, prefix: str) -> str:
    short = name[len(_SOURCE) :] if name.startswith(_SOURCE) else name
    return prefix + {"gripper_link": "gripper"}.get(short, short)


def _arm(assets: str, prefix: str) -> ET.Element:
    """The arm's shoulder link (the base mesh kept), renamed with ``prefix``."""
    root = ET.parse(os.path.join(assets, "vx300s_left.xml")).getroot()
    arm = root.find("body")
    if arm is None:
        raise ValueError("gym-aloha's vx300s_left.xml has no body")
    for parent in arm.iter():
        for child in list(parent):
            if child.tag in ("camera", "site") or child.get("name", "").endswith("camera_focus"):
                parent.remove(child)
    for el in arm.iter():
        for key in ("name", "joint"):
            if el.get(key):
                el.set(key, _rename(el.get(key, ""), prefix))
        if el.tag == "body":
            el.set("gravcomp", "1")
        if el.tag == "joint":
            el.attrib.pop("frictionloss", None)
        if el.tag == "geom" and "finger" not in el.get("name", ""):
            el.set("contype", "0")  # the links do not collide (as the other robots')
            el.set("conaffinity", "0")
    gripper = arm.find(f".//body[@name='{prefix}gripper']")
    if gripper is None:
        raise ValueError("gym-aloha's vx300s_left.xml has no gripper_link body")
    for body in gripper.findall("body"):
        joint, geom = body.find("joint"), body.find("geom")
        if joint is None or geom is None or "finger" not in joint.get("name", ""):
            continue
        left = joint.get("name", "").endswith("left_finger")
        x, y, z = (float(v) for v in body.get("pos", "0 0 0").split())
        y += FINGER_CLOSED if left else -FINGER_CLOSED
        body.set("pos", f"{x} {y} {z}")
        joint.set("axis", "0 1 0" if left else "0 -1 0")
        joint.set("range", f"0 {FINGER_RANGE:.4f}")
        for key in ("solimp", "solref", "friction", "condim"):
            geom.attrib.pop(key, None)
        geom.set("contype", "0")  # the mesh is seen; a flat pad collides (PAD_HALF)
        geom.set("conaffinity", "0")
        inner = (-1.0 if left else 1.0) * (FINGER_CLOSED - PAD_HALF[1])
        ET.SubElement(
            body,
            "geom",
            {
                "name": f"{joint.get('name')}_pad",
                "class": "pad",
                "type": "box",
                "pos": f"{TCP_X + FINGER_BELOW_TCP - PAD_HALF[0] - x:.5f} {inner:.5f} 0",
                "size": " ".join(f"{v:.4f}" for v in PAD_HALF),
                "rgba": "0.1 0.1 0.1 0",
            },
        )
    for geom in gripper.findall("geom"):  # the palm collides
        geom.attrib.pop("contype", None)
        geom.attrib.pop("conaffinity", None)
    ET.SubElement(
        gripper,
        "site",
        {
            "name": f"{prefix}tcp",
            "pos": f"{TCP_X} 0 0",
            "quat": "0.707107 0 0.707107 0",  # x = -gripper z, y = gripper y, z = gripper x
            "size": "0.006",
            "rgba": "1 0 0 1",
        },
    )
    return arm


def _defaults(assets: str) -> str:
    dep = ET.parse(os.path.join(assets, "vx300s_dependencies.xml")).getroot().find("asset")
    if dep is None:
        raise ValueError("gym-aloha's vx300s_dependencies.xml has no <asset>")
    for el in dep:
        if el.get("file"):
            el.set("file", os.path.join(assets, el.get("file", "")))
    return (
        '<default><joint damping="2" armature="0.1"/>'
        f'<geom rgba="0.3 0.3 0.3 1" friction="1 0.005 0.0001"/>{_PAD}</default>'
        f"{ET.tostring(dep, encoding='unicode')}"
    )


def _actuators(prefix: str) -> str:
    arm = "".join(
        f'<position name="{prefix}act_{j}" joint="{prefix}{j}" kp="2000" kv="100" '
        f'ctrlrange="{lo:.4f} {hi:.4f}"/>'
        for j, (lo, hi) in zip(ARM_JOINTS, JOINT_RANGE, strict=True)
    )
    fingers = "".join(
        f'<position name="{prefix}act_{f}" joint="{prefix}{f}" kp="300" kv="20" '
        f'forcerange="-20 20" ctrlrange="0 {FINGER_RANGE:.4f}"/>'
        for f in FINGER_JOINTS
    )
    bodies = [f"{prefix}{b}" for b in ("gripper", "left_finger_link", "right_finger_link")]
    bodies.append(f"{prefix}gripper_prop_link")
    exclude = "".join(
        f'<exclude body1="{a}" body2="{b}"/>' for i, a in enumerate(bodies) for b in bodies[i + 1 :]
    )
    return f"<actuator>{arm}{fingers}</actuator><contact>{exclude}</contact>"


@cache
def viperx(prefix: str = "") -> Robot:
    """One ViperX 300s arm with its gripper, every name prefixed with ``prefix`` (``""`` for
    the arm alone, as the IK uses it; ``"left/"``, ``"right/"`` in the two-arm scene).

    Raises
    ------
    MissingExtraError
        gym-aloha is not installed.
    """
    assets = aloha_assets()
    arm = _arm(assets, prefix)
    ranges = [
        tuple(float(v) for v in j.get("range", "").split())
        for j in arm.iter("joint")
        if j.get("type") != "slide"
    ]
    if tuple(ranges) != JOINT_RANGE:
        raise ValueError(f"gym-aloha's vx300s joint limits changed: {ranges}")
    body = "".join(ET.tostring(el, encoding="unicode") for el in arm)
    return Robot(
        name=f"{prefix}vx300s",
        title="Trossen ViperX 300s with its gripper (gym-aloha's MJCF)",
        body=body,
        defaults=_defaults(assets),
        actuators=_actuators(prefix),
        arm_joints=tuple(prefix + j for j in ARM_JOINTS),
        finger_joints=(prefix + FINGER_JOINTS[0], prefix + FINGER_JOINTS[1]),
        joint_range=JOINT_RANGE,
        home_q=HOME_Q,
        wrist_yaw=WRIST_YAW,
        max_opening=2 * FINGER_RANGE,
        finger_below_tcp=FINGER_BELOW_TCP,
        finger_half_x=PAD_HALF[2],
        hand_radius=FINGER_RANGE,  # the open fingers (the gripper body is above them)
        palm_above_tcp=TCP_X - FINGER_LINK_X,  # where the fingers leave the gripper body
        tcp_offset=WRIST_TO_GRIPPER + TCP_X,
        shoulder_z=SHOULDER_Z,
        reach=REACH,
        limits=Limits(speed=0.4, acceleration=2.0, yaw_rate=2.5, yaw_acceleration=12.0),
        source=f"{GYM_ALOHA} (Apache-2.0): assets/vx300s_left.xml, vx300s_dependencies.xml",
    )


@dataclass(frozen=True)
class TwoArmRobot:
    """Two arms, each a :class:`~lfd.reproduce.robots.Robot` whose names carry its side's
    prefix (``right/``, ``left/``), and the same arm without a prefix (``ik``: the model the
    inverse kinematics runs on). Each hand's lane goes to the arm of its side."""

    name: str
    title: str
    arms: dict[str, Robot]
    ik: Robot
    source: str = ""
    base_levels: tuple[float, ...] = ()
    """How far (m) both bases may lie before or behind the work's centre, tried in turn where
    the arms, their bases placed for the widest reach margin, still meet
    (:func:`~lfd.reproduce.two_arm_apart.bases_apart`); none: the bases stay there."""

    @property
    def sides(self) -> tuple[str, ...]:
        return tuple(self.arms)


SIDES = ("right", "left")


@cache
def aloha() -> TwoArmRobot:
    """The two-arm ALOHA (``--robot aloha``): two ViperX 300s arms.

    Raises
    ------
    MissingExtraError
        gym-aloha is not installed.
    """
    one = viperx()
    return TwoArmRobot(
        name="aloha",
        title="ALOHA: two ViperX 300s arms (gym-aloha's MJCF)",
        arms={side: viperx(f"{side}/") for side in SIDES},
        ik=one,
        source=one.source,
    )
