"""The simulated human hand: an articulated right hand of capsules with 21 keypoint sites.

The hand is a mocap body (the wrist) carrying a box palm and five fingers. Each finger has four
hinges: abduction (about the local z axis) and flexion at the base (both at the MCP joint, CMC for
the thumb), then two more flexion hinges (PIP and DIP; MCP and IP for the thumb). The sites
``kp_0 ... kp_20`` sit at the joints and fingertips in MediaPipe order, so reading them gives the
ground-truth keypoints.

Wrist frame (right hand): x points from the wrist towards the middle finger, y towards the thumb
side, z out of the back of the hand (palm normal is -z). Positive flexion curls a finger towards
the palm. All lengths scale with the hand size ``scale`` (1.0 = an adult hand, palm length
~9.5 cm, middle finger ~10 cm).

A posture is a vector of :data:`N_JOINTS` joint angles (radians) in :data:`JOINT_NAMES` order.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

FINGERS: tuple[str, ...] = ("thumb", "index", "middle", "ring", "pinky")
"""Finger names; finger ``f`` owns keypoints ``1 + 4 f ... 4 + 4 f``."""

JOINTS_PER_FINGER = 4
N_JOINTS = len(FINGERS) * JOINTS_PER_FINGER
JOINT_NAMES: tuple[str, ...] = tuple(
    f"{f}_{j}" for f in FINGERS for j in ("abd", "flex1", "flex2", "flex3")
)
"""Finger joint names: per finger abduction, then three flexion hinges from base to tip."""

# Base position (wrist frame, m), base x axis (pointing direction) and a hint for the base z axis
# (back of the finger; flexion turns x towards -z), phalanx lengths (m), capsule radius (m).
_BASE: dict[str, tuple[tuple[float, float, float], tuple[float, ...], tuple[float, ...]]] = {
    "thumb": ((0.026, 0.024, -0.016), (0.55, 0.65, -0.50), (0.0, 0.7, 0.7)),
    "index": ((0.092, 0.026, 0.0), (1.0, 0.1, 0.0), (0.0, 0.0, 1.0)),
    "middle": ((0.095, 0.005, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
    "ring": ((0.090, -0.014, 0.0), (1.0, -0.1, 0.0), (0.0, 0.0, 1.0)),
    "pinky": ((0.080, -0.031, 0.0), (1.0, -0.2, 0.0), (0.0, 0.0, 1.0)),
}


def _base_quat(x_axis: tuple[float, ...], z_hint: tuple[float, ...]) -> str:
    x = np.asarray(x_axis, float)
    x /= np.linalg.norm(x)
    z = np.asarray(z_hint, float)
    z = z - x * (z @ x)
    z /= np.linalg.norm(z)
    y = np.cross(z, x)
    R = np.column_stack([x, y, z])
    w = np.sqrt(max(1e-12, 1.0 + np.trace(R))) / 2.0
    q = (
        w,
        (R[2, 1] - R[1, 2]) / (4 * w),
        (R[0, 2] - R[2, 0]) / (4 * w),
        (R[1, 0] - R[0, 1]) / (4 * w),
    )
    return " ".join(f"{c:.6g}" for c in q)


_LENGTHS: dict[str, tuple[float, float, float]] = {
    "thumb": (0.042, 0.033, 0.029),
    "index": (0.044, 0.026, 0.022),
    "middle": (0.049, 0.030, 0.023),
    "ring": (0.045, 0.028, 0.023),
    "pinky": (0.035, 0.021, 0.021),
}
_RADIUS: dict[str, float] = {
    "thumb": 0.0095,
    "index": 0.0085,
    "middle": 0.0088,
    "ring": 0.0083,
    "pinky": 0.0075,
}
FINGERTIP_RADIUS = 0.0068
"""Radius of the distal phalanges at scale 1 (pad thickness between a tip site and an object)."""

_SKIN = "0.87 0.68 0.56 1"


def _deg(*values: float) -> list[float]:
    return [float(np.deg2rad(v)) for v in values]


def _posture(per_finger: dict[str, list[float]]) -> np.ndarray:
    q = np.zeros(N_JOINTS)
    for i, f in enumerate(FINGERS):
        q[i * 4 : i * 4 + 4] = per_finger[f]
    return q


POSTURES: dict[str, np.ndarray] = {
    # relaxed hand during transport: fingers slightly curled, thumb resting beside the index
    "relaxed": _posture(
        {
            "thumb": _deg(-5, 15, 15, 15),
            "index": _deg(0, 20, 25, 15),
            "middle": _deg(0, 25, 30, 15),
            "ring": _deg(0, 30, 35, 15),
            "pinky": _deg(0, 35, 35, 15),
        }
    ),
    # pre-grasp: index and thumb spread (aperture ~11 cm), other fingers half curled
    "open": _posture(
        {
            "thumb": _deg(-7.6, 9.8, 22.1, 12.9),
            "index": _deg(-8.2, 14.4, 12.9, -1.3),
            "middle": _deg(0, 70, 80, 45),
            "ring": _deg(0, 75, 85, 45),
            "pinky": _deg(0, 80, 85, 45),
        }
    ),
    # pinch closed: index and thumb tips touching
    "pinch": _posture(
        {
            "thumb": _deg(-29.9, 19.5, 9.2, -1.3),
            "index": _deg(-9.3, 42.6, 23.6, 49.4),
            "middle": _deg(0, 88, 95, 55),
            "ring": _deg(0, 90, 95, 55),
            "pinky": _deg(0, 90, 95, 55),
        }
    ),
    # pointing: index straight, others curled into the palm
    "point": _posture(
        {
            "thumb": _deg(10, 35, 30, 20),
            "index": _deg(0, 5, 5, 0),
            "middle": _deg(0, 85, 90, 45),
            "ring": _deg(0, 85, 90, 45),
            "pinky": _deg(0, 85, 90, 45),
        }
    ),
    # pushing: fingers together and slightly bent, the hand acts as a paddle
    "push": _posture(
        {
            "thumb": _deg(0, 20, 15, 10),
            "index": _deg(-3, 25, 20, 10),
            "middle": _deg(0, 25, 20, 10),
            "ring": _deg(2, 25, 20, 10),
            "pinky": _deg(4, 25, 20, 10),
        }
    ),
    # thumb-middle grasp: thumb and middle tips spread (~12.5 cm) / touching, the index lifted
    # and extended (thumb-index tip distance 13-15 cm while holding a 5-9 cm cube)
    "thumb_middle_open": _posture(
        {
            "thumb": _deg(-9.6, 9.5, 21.9, 12.8),
            "index": _deg(-10, -20, 0, 0),
            "middle": _deg(0, 11.5, 10.9, 0),
            "ring": _deg(0, 85, 90, 50),
            "pinky": _deg(0, 85, 90, 50),
        }
    ),
    "thumb_middle": _posture(
        {
            "thumb": _deg(-33.2, 25.4, 12.5, 0.2),
            "index": _deg(-10, -20, 0, 0),
            "middle": _deg(0, 46.8, 42.0, 41.1),
            "ring": _deg(0, 85, 90, 50),
            "pinky": _deg(0, 85, 90, 50),
        }
    ),
    # whole-hand grasp: the four fingertips side by side on one face, the thumb opposite
    # (thumb to fingertip centroid ~12.5 cm open / 3 cm closed)
    "whole_hand_open": _posture(
        {
            "thumb": _deg(-2.5, 14.9, 22.7, 11.2),
            "index": _deg(-4, 13.4, 11.3, 8.1),
            "middle": _deg(0, 13.4, 11.3, 8.1),
            "ring": _deg(3, 13.4, 11.3, 8.1),
            "pinky": _deg(6, 13.4, 11.3, 8.1),
        }
    ),
    "whole_hand": _posture(
        {
            "thumb": _deg(-47.9, 27.2, 18.0, 9.0),
            "index": _deg(-4, 65.3, 50.9, 29.7),
            "middle": _deg(0, 65.3, 50.9, 29.7),
            "ring": _deg(3, 65.3, 50.9, 29.7),
            "pinky": _deg(6, 65.3, 50.9, 29.7),
        }
    ),
}
"""Named finger postures (joint angle vectors, shape (20,))."""

GRASP_TYPES: tuple[str, ...] = ("pinch", "thumb_middle", "whole_hand")
"""Grasp types: thumb-index pinch, thumb-middle (tripod-like, index lifted), whole hand."""

GRASP_FINGERTIPS: dict[str, tuple[int, ...]] = {
    "pinch": (8,),
    "thumb_middle": (12,),
    "whole_hand": (8, 12, 16, 20),
}
"""Keypoints of the fingertips that oppose the thumb tip (keypoint 4) in each grasp type."""


def pinch_posture(g: float) -> np.ndarray:
    """Posture between ``open`` (``g = 0``) and ``pinch`` (``g = 1``, tips touching)."""
    return (1.0 - g) * POSTURES["open"] + g * POSTURES["pinch"]


def grasp_posture(kind: str, g: float) -> np.ndarray:
    """Posture of grasp type ``kind`` between open (``g = 0``) and closed (``g = 1``)."""
    if kind == "pinch":
        return pinch_posture(g)
    return (1.0 - g) * POSTURES[f"{kind}_open"] + g * POSTURES[kind]


def grasp_contacts(kp: np.ndarray, kind: str) -> tuple[np.ndarray, np.ndarray]:
    """The thumb tip and the opposing contact point of grasp type ``kind`` in keypoints ``kp``
    of shape (21, 3): the opposing fingertip, or for several the centroid of their tips moved
    along the grasp axis to the tip nearest to the thumb (so no tip goes into the object)."""
    thumb, tips = kp[4], kp[list(GRASP_FINGERTIPS[kind])]
    other = tips.mean(axis=0)
    if len(tips) > 1:
        u = (other - thumb) / np.linalg.norm(other - thumb)
        other = other + u * float(np.min((tips - other) @ u))
    return thumb, other


LEFT_PREFIX = "left_"
"""Prefix of the names of the left hand's bodies, joints, sites and geoms in a two-hand scene
(``left_hand``, ``left_kp_0``, ``left_index_abd``...); the right hand's are unprefixed."""


def hand_mjcf(scale: float = 1.0, side: str = "right") -> str:
    """MJCF ``<body>`` of the hand (a mocap body named ``hand``), to be placed in ``worldbody``.

    Parameters
    ----------
    scale : float
        Hand size factor; every length and radius is multiplied by it.
    side : {"right", "left"}
        The left hand is the right one mirrored in its wrist frame (y -> -y): its names carry
        :data:`LEFT_PREFIX`, its keypoints for a posture ``q`` are the right hand's with y
        negated (:class:`MirroredKinematics`), the same joint angles curling it the same way.
    """
    s = float(scale)
    left = side == "left"
    m = -1.0 if left else 1.0
    pre = LEFT_PREFIX if left else ""

    def v(*xs: float) -> str:
        return " ".join(f"{x * s:.6g}" for x in xs)

    parts = [
        f'<body name="{pre}hand" mocap="true">',
        f'<site name="{pre}kp_0" pos="0 0 0" size="0.004"/>',
        f'<geom name="{pre}palm" type="box" pos="{v(0.05, -0.002 * m, 0.0)}"'
        f' size="{v(0.045, 0.038, 0.011)}" rgba="{_SKIN}" contype="0" conaffinity="0"/>',
        f'<geom name="{pre}wrist" type="capsule" fromto="{v(-0.03, 0, 0, 0.0, 0, 0)}"'
        f' size="{v(0.024)}" rgba="{_SKIN}" contype="0" conaffinity="0"/>',
    ]
    for fi, f in enumerate(FINGERS):
        pos, x_axis, z_hint = _BASE[f]
        if left:  # mirrored base: x and z mirrored, y = z x x (a right-handed frame)
            pos = (pos[0], -pos[1], pos[2])
            x_axis = (x_axis[0], -x_axis[1], x_axis[2])
            z_hint = (z_hint[0], -z_hint[1], z_hint[2])
        lengths = _LENGTHS[f]
        r = _RADIUS[f]
        kp = 1 + 4 * fi
        # in the mirrored frame a flexion about y keeps its sense, an abduction about z flips
        abd_axis = "0 0 -1" if left else "0 0 1"
        parts.append(
            f'<body name="{pre}{f}_1" pos="{v(*pos)}" quat="{_base_quat(x_axis, z_hint)}">'
        )
        parts.append(f'<joint name="{pre}{f}_abd" type="hinge" axis="{abd_axis}"/>')
        parts.append(f'<joint name="{pre}{f}_flex1" type="hinge" axis="0 1 0"/>')
        parts.append(f'<site name="{pre}kp_{kp}" pos="0 0 0" size="0.004"/>')
        for k, length in enumerate(lengths):
            rad = r if k < 2 else FINGERTIP_RADIUS
            parts.append(
                f'<geom type="capsule" fromto="0 0 0 {v(length)} 0 0" size="{v(rad)}"'
                f' rgba="{_SKIN}" contype="0" conaffinity="0"/>'
            )
            if k < 2:
                parts.append(f'<body name="{pre}{f}_{k + 2}" pos="{v(length)} 0 0">')
                parts.append(f'<joint name="{pre}{f}_flex{k + 2}" type="hinge" axis="0 1 0"/>')
                parts.append(f'<site name="{pre}kp_{kp + k + 1}" pos="0 0 0" size="0.004"/>')
            else:
                parts.append(f'<site name="{pre}kp_{kp + 3}" pos="{v(length)} 0 0" size="0.004"/>')
        parts.append("</body></body></body>")
    parts.append("</body>")
    return "\n".join(parts)


@dataclass
class HandKinematics:
    """Forward kinematics of the compiled hand: keypoints in the wrist frame for a posture.

    Parameters
    ----------
    model : mujoco.MjModel
        A compiled scene containing :func:`hand_mjcf`.
    """

    model: Any

    def __post_init__(self) -> None:
        import mujoco

        m = self.model
        self._mujoco = mujoco
        self.data = mujoco.MjData(m)
        self.qadr = np.array(
            [m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, n)] for n in JOINT_NAMES]
        )
        self.site_ids = np.array(
            [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, f"kp_{i}") for i in range(21)]
        )
        self.mocap_id = int(m.body_mocapid[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "hand")])
        self.data.mocap_pos[self.mocap_id] = 0.0
        self.data.mocap_quat[self.mocap_id] = (1.0, 0.0, 0.0, 0.0)

    def local_keypoints(self, q: np.ndarray) -> np.ndarray:
        """Keypoints in the wrist frame, shape (21, 3), for a posture ``q`` of shape (20,)."""
        self.data.qpos[self.qadr] = q
        self._mujoco.mj_kinematics(self.model, self.data)
        return np.array(self.data.site_xpos[self.site_ids])

    def tcp_local(self, q: np.ndarray) -> np.ndarray:
        """The TCP (midpoint of index and thumb tips) in the wrist frame, shape (3,)."""
        kp = self.local_keypoints(q)
        return 0.5 * (kp[4] + kp[8])

    def aperture(self, q: np.ndarray) -> float:
        """Distance between the index and thumb tip keypoints (m)."""
        kp = self.local_keypoints(q)
        return float(np.linalg.norm(kp[8] - kp[4]))

    def grasp_for_aperture(self, kind: str, width: float) -> float:
        """The closure ``g`` of grasp type ``kind`` whose thumb-to-opposing-fingertips distance
        is ``width`` (clipped to [0, 1]); :meth:`pinch_for_aperture` for ``pinch``."""
        if kind == "pinch":
            return self.pinch_for_aperture(width)
        gs = np.linspace(0.0, 1.0, 41)
        ap = []
        for g in gs:
            thumb, other = grasp_contacts(self.local_keypoints(grasp_posture(kind, g)), kind)
            ap.append(float(np.linalg.norm(other - thumb)))
        order = np.argsort(ap)
        return float(np.clip(np.interp(width, np.array(ap)[order], gs[order]), 0.0, 1.0))

    def pinch_for_aperture(self, width: float) -> float:
        """The pinch parameter ``g`` whose tip distance is ``width`` (clipped to [0, 1])."""
        gs = np.linspace(0.0, 1.0, 41)
        ap = np.array([self.aperture(pinch_posture(g)) for g in gs])
        order = np.argsort(ap)
        return float(np.clip(np.interp(width, ap[order], gs[order]), 0.0, 1.0))


class MirroredKinematics(HandKinematics):
    """The left hand's forward kinematics: the right hand's keypoints mirrored in the wrist
    frame (y -> -y), exactly what :func:`hand_mjcf` with ``side="left"`` renders."""

    def local_keypoints(self, q: np.ndarray) -> np.ndarray:
        kp = super().local_keypoints(q)
        kp[:, 1] *= -1.0
        return kp
