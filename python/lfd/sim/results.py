"""What a simulation gives: the true state at every camera frame (:class:`Truth`) and the
result (:class:`SimResult`), shared by the one-hand and the two-hand demonstrator."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..demo import Demonstration
from .hand import GRASP_FINGERTIPS, JOINTS_PER_FINGER, N_JOINTS, HandKinematics
from .motion import Plan, rotation, smooth_noise
from .planner import Detach, Planner
from .scene import Scene
from .variability import Variability

SIM_VERSION = "1.5"
"""Version of the simulated demonstrator (bump when motions change; 1.1 added the natural
style, 1.2 the contact boundaries, 1.3 the natural style's idle hovers and table turns, 1.4
the two-hand tasks, 1.5 ``exp7``; the careful motions are those of 1.2, the other one-hand
ones those of 1.3)."""

BASE_TIME_NS = 1_700_000_000_000_000_000
"""Capture time of the first frame of every simulated demonstration."""


@dataclass
class Truth:
    """Noise-free state at every camera frame.

    Attributes
    ----------
    t_ns : array, shape (n,)
    tcp : array, shape (n, 3)
    keypoints : array, shape (n, 21, 3)
    wrist_pos : array, shape (n, 3)
    wrist_quat : array, shape (n, 4)   (w, x, y, z) as MuJoCo
    q : array, shape (n, 20)           finger joint angles
    object_pos : dict of array (n, 3)
    object_yaw : dict of array (n,)
    """

    t_ns: np.ndarray
    tcp: np.ndarray
    keypoints: np.ndarray
    wrist_pos: np.ndarray
    wrist_quat: np.ndarray
    q: np.ndarray
    object_pos: dict[str, np.ndarray]
    object_yaw: dict[str, np.ndarray]
    other: Truth | None = None
    """The left hand of a two-hand demonstration (its own hand arrays, the same objects)."""


@dataclass
class SimResult:
    """A simulated demonstration, its ground truth and what produced it."""

    demo: Demonstration
    truth: Truth
    scene: Scene
    plan: Plan
    variability: Variability


def free_fingers(P: Planner, t: np.ndarray) -> np.ndarray:
    """Weight (n, 20) of each finger joint's drift at times ``t``: 0 for the fingers of a grasp
    from the start of its closing to 0.3 s after the release, ramped over 0.2 s."""
    w = np.ones((t.size, N_JOINTS))
    releases = iter(e.t for e in P.events if isinstance(e, Detach))
    for grasp in P.grasps:
        t0, t1 = float(grasp["t_close_s"]), next(releases, float(t[-1])) + 0.3
        busy = np.interp(t, [t0 - 0.2, t0, t1, t1 + 0.2], [0.0, 1.0, 1.0, 0.0])
        for tip in GRASP_FINGERTIPS[str(grasp["type"])]:
            f = (tip - 1) // 4
            cols = slice(f * JOINTS_PER_FINGER, (f + 1) * JOINTS_PER_FINGER)
            w[:, cols] = np.minimum(w[:, cols], 1.0 - busy[:, None])
    return w


def hand_motion(
    rng: np.random.Generator,
    var: Variability,
    kin: HandKinematics,
    P: Planner,
    plan: Plan,
    t: np.ndarray,
) -> dict[str, np.ndarray]:
    """A hand's true motion on the fine grid ``t``: ``plan`` with finger drift (not of the
    fingers holding an object, in the natural style) and tremor; its TCP, yaw, rotation,
    joint angles, keypoints and wrist."""
    tcp, ang, q = plan.evaluate(t)
    drift_joints = np.arange(2 * JOINTS_PER_FINGER, N_JOINTS)
    drift = smooth_noise(
        rng, t, drift_joints.size, amplitude=np.deg2rad(var.finger_drift_deg), freq_range=(0.1, 0.6)
    )
    if var.style == "natural":  # fingers holding an object do not drift
        drift *= free_fingers(P, t)[:, drift_joints]
    q[:, drift_joints] += drift
    tremor = smooth_noise(
        rng, t, 3, amplitude=float(var.tremor_mm or 0.0) * 1e-3, freq_range=(6, 10)
    )
    tcp = tcp + tremor
    R = rotation(ang[:, 0], ang[:, 1], ang[:, 2])
    kp_local = np.empty((t.size, 21, 3))
    for i in range(t.size):
        kp_local[i] = kin.local_keypoints(q[i])
    tcp_local = 0.5 * (kp_local[:, 4] + kp_local[:, 8])
    keypoints = np.einsum("nij,nkj->nki", R, kp_local - tcp_local[:, None, :]) + tcp[:, None, :]
    wrist = tcp - np.einsum("nij,nj->ni", R, tcp_local)
    return {"tcp": tcp, "yaw": ang[:, 0], "R": R, "q": q, "keypoints": keypoints, "wrist": wrist}


def quat_wxyz(R: np.ndarray) -> np.ndarray:
    import mujoco

    out = np.empty((R.shape[0], 4))
    for i in range(R.shape[0]):
        mujoco.mju_mat2Quat(out[i], R[i].ravel())
    return out
