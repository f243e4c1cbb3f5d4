"""Synthetic demonstrations for the I/O and preprocessing tests (not a test module)."""

from __future__ import annotations

import numpy as np
from lfd.demo import (
    CameraInfo,
    Demonstration,
    HandTrack,
    ImageStream,
    ObjectTrack,
    SkillLabel,
)
from scipy.spatial.transform import Rotation

T0 = 1_700_000_000_000_000_000  # an absolute epoch time, as a real recording has

# A right hand in its own frame (metres): x across the palm, y along the fingers, z out of palm.
HAND_TEMPLATE = np.array(
    [
        [0.0, 0.0, 0.0],  # wrist
        [-0.02, 0.02, 0.0], [-0.04, 0.04, 0.0], [-0.05, 0.06, 0.0], [-0.05, 0.08, 0.0],  # thumb
        [-0.01, 0.09, 0.0], [-0.01, 0.12, 0.0], [-0.01, 0.14, 0.0], [-0.015, 0.15, 0.01],  # index
        [0.01, 0.09, 0.0], [0.01, 0.12, 0.0], [0.01, 0.14, 0.0], [0.01, 0.16, 0.0],  # middle
        [0.03, 0.09, 0.0], [0.03, 0.11, 0.0], [0.03, 0.13, 0.0], [0.03, 0.15, 0.0],  # ring
        [0.05, 0.08, 0.0], [0.05, 0.10, 0.0], [0.05, 0.11, 0.0], [0.05, 0.12, 0.0],  # pinky
    ]
)  # fmt: skip


def hand_keypoints(t_s: np.ndarray) -> np.ndarray:
    """Keypoints, shape (n, 21, 3): the template rotating slowly and moving on a circle."""
    n = t_s.size
    rot = Rotation.from_euler(
        "xyz", np.stack([0.3 * np.sin(0.2 * t_s), 0.1 * t_s, 0.2 + 0 * t_s], 1)
    )
    centre = np.stack([0.4 + 0.1 * np.cos(0.3 * t_s), 0.1 * np.sin(0.3 * t_s), 0.2 + 0 * t_s], 1)
    kp = np.empty((n, 21, 3))
    for i in range(n):
        kp[i] = rot[i].apply(HAND_TEMPLATE) + centre[i]
    return kp


def make_demo(
    duration_s: float = 6.0,
    hand_hz: float = 5.0,
    object_hz: float = 30.0,
    n_objects: int = 2,
    images: int = 0,
    seed: int = 0,
) -> Demonstration:
    """A small consistent demonstration; objects drift slowly, some samples invisible."""
    rng = np.random.default_rng(seed)
    th = np.arange(0.0, duration_s, 1.0 / hand_hz)
    th_ns = T0 + np.round(th * 1e9).astype(np.int64)
    kp = hand_keypoints(th)
    conf = rng.uniform(0.5, 1.0, size=(th.size, 21))
    kp[2, 7] = np.nan  # one unobserved keypoint
    conf[2, 7] = 0.0
    objects = {}
    for k in range(n_objects):
        to = np.arange(0.0, duration_s, 1.0 / object_hz) + 0.003 * k
        pos = np.stack([0.3 + 0.05 * k + 0.01 * np.sin(to), 0.1 * k + 0 * to, 0.025 + 0 * to], 1)
        quat = Rotation.from_euler("z", (0.1 * to + k)[:, None]).as_quat()
        visible = np.ones(to.size, dtype=bool)
        visible[10:14] = False
        name = f"cube{k}"
        objects[name] = ObjectTrack(
            name=name,
            tag_id=k + 1,
            size=np.array([0.05, 0.05, 0.05 + 0.01 * k]),
            t_ns=T0 + np.round(to * 1e9).astype(np.int64),
            position=np.where(visible[:, None], pos, np.nan),
            quaternion=np.where(visible[:, None], quat, np.nan),
            visible=visible,
        )
    labels = [
        SkillLabel("pick_up", T0, T0 + 2_000_000_000, "cube0"),
        SkillLabel("place", T0 + 2_000_000_000, T0 + 4_000_000_000, "cube0"),
        SkillLabel("move", T0 + 4_000_000_000, T0 + 5_000_000_000, None),
    ]
    camera = CameraInfo(
        width=8,
        height=6,
        K=np.array([[10.0, 0, 4], [0, 10.0, 3], [0, 0, 1]]),
        world_T_camera=np.array(
            [[1.0, 0, 0, 0.5], [0, -1.0, 0, 0.0], [0, 0, -1.0, 1.0], [0, 0, 0, 1]]
        ),
    )
    color = depth = None
    if images:
        ti = T0 + np.arange(images, dtype=np.int64) * 100_000_000
        color = ImageStream(ti, rng.integers(0, 256, size=(images, 6, 8, 3), dtype=np.uint8))
        depth = ImageStream(ti, rng.integers(0, 5000, size=(images, 6, 8), dtype=np.uint16))
    return Demonstration(
        hand=HandTrack(th_ns, kp, conf, side="right"),
        objects=objects,
        labels=labels,
        camera=camera,
        color=color,
        depth=depth,
        metadata={
            "task": "stack",
            "seed": seed,
            "demonstrator": "synthetic",
            "nested": {"a": [1, 2]},
        },
    )
