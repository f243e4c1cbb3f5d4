"""Sensor models: sample the noise-free simulation like a camera, a tag tracker and a hand-pose
estimator would.

- Object poses at every camera frame: position noise ``object_noise_mm`` (doubled along the
  camera's viewing ray), orientation noise ``object_noise_mm / 2`` degrees, missing samples in
  bursts (two-state Markov chain with mean burst 0.2 s, stationary fraction ``dropout``) and an
  extra miss probability ``occlusion`` while the hand is right above the object.
- Hand keypoints on every 5th-7th camera frame (~5 Hz at 30 Hz), a fraction ``hand_miss`` of
  them lost (the estimator found no hand), with gaussian noise ``noise_mm`` (x0.8 at the wrist
  up to x1.35 at the fingertips)
  (1.5x along the viewing ray), and in a fraction ``outlier_rate`` of the frames 1-3 keypoints
  (mostly fingertips) off by 1-3 cm with a low confidence.
"""

from __future__ import annotations

import numpy as np

from ..demo import HandTrack, ObjectTrack
from .scene import Scene
from .variability import Variability

_FINGERTIPS = np.array([4, 8, 12, 16, 20])
_KEYPOINT_NOISE = np.array([0.8] + [0.9, 1.0, 1.15, 1.35] * 5)
"""Relative noise per keypoint: estimators are best at the wrist and worst at the fingertips."""


def _camera_noise(
    rng: np.random.Generator,
    shape: tuple[int, ...],
    sigma: float,
    depth_factor: float,
    R_cv: np.ndarray,
) -> np.ndarray:
    """Gaussian noise with std ``sigma`` across and ``sigma * depth_factor`` along the view ray."""
    n = rng.normal(0.0, 1.0, (*shape, 3)) * np.array([sigma, sigma, sigma * depth_factor])
    return np.asarray(n @ R_cv.T)


def yaw_quat(yaw: np.ndarray) -> np.ndarray:
    """Quaternions (..., 4), (x, y, z, w), of rotations by ``yaw`` (rad) about z."""
    return np.stack(
        [np.zeros_like(yaw), np.zeros_like(yaw), np.sin(yaw / 2), np.cos(yaw / 2)], axis=-1
    )


def _quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product of (x, y, z, w) quaternions, broadcast over leading axes."""
    ax, ay, az, aw = np.moveaxis(a, -1, 0)
    bx, by, bz, bw = np.moveaxis(b, -1, 0)
    return np.stack(
        [
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz,
        ],
        axis=-1,
    )


def _bursts(rng: np.random.Generator, n: int, fraction: float, mean_len: float) -> np.ndarray:
    """Boolean mask of missing samples: Markov bursts with stationary missing ``fraction``."""
    missing = np.zeros(n, dtype=bool)
    u = rng.random(n)
    if fraction <= 0:
        return missing
    p_off = 1.0 / mean_len
    p_on = fraction * p_off / max(1.0 - fraction, 1e-9)
    state = False
    for i in range(n):
        state = (u[i] >= p_off) if state else (u[i] < p_on)
        missing[i] = state
    return missing


def sample_hand(
    rng: np.random.Generator,
    t_ns: np.ndarray,
    keypoints: np.ndarray,
    R_cv: np.ndarray,
    var: Variability,
    hand_rate_hz: float,
    object_rate_hz: float,
    side: str = "right",
) -> HandTrack:
    """A hand-pose estimator's samples of the true ``keypoints`` (n, 21, 3) at the camera
    frames ``t_ns``: its rate, failures, noise and outliers (module docstring)."""
    n = t_ns.size

    # hand-pose estimator: every 5th-7th frame at 30 Hz (scaled to the requested rate);
    # motion capture (natural style): on a fixed clock
    mean_step = object_rate_hz / hand_rate_hz
    if var.style == "natural":
        idx = np.arange(0, n, max(1, round(mean_step)))
    else:
        steps = np.maximum(1, np.round(mean_step + rng.choice([-1, 0, 0, 0, 0, 1], size=n)))
        idx = np.cumsum(np.concatenate([[int(rng.integers(0, max(1, int(mean_step))))], steps]))
        idx = idx[idx < n].astype(int)
    idx = idx[rng.random(idx.size) >= float(var.hand_miss or 0.0)]  # failed estimates leave gaps
    kp = np.asarray(keypoints)[idx].copy()
    noise = _camera_noise(rng, kp.shape[:2], float(var.noise_mm or 0.0) * 1e-3, 1.5, R_cv)
    kp += noise * _KEYPOINT_NOISE[None, :, None]
    conf = rng.uniform(0.8, 0.98, size=kp.shape[:2])
    outlier_frames = rng.random(idx.size) < float(var.outlier_rate or 0.0)
    weights = np.ones(21)
    weights[_FINGERTIPS] = 4.0
    for f in np.flatnonzero(outlier_frames):
        m = int(rng.integers(1, 4))
        which = rng.choice(21, size=m, replace=False, p=weights / weights.sum())
        direction = rng.normal(size=(m, 3))
        direction /= np.linalg.norm(direction, axis=1, keepdims=True)
        kp[f, which] += direction * rng.uniform(0.01, 0.03, size=(m, 1))
        conf[f, which] = rng.uniform(0.2, 0.6, size=m)
    hand = HandTrack(t_ns=t_ns[idx], keypoints=kp, confidence=conf, side=side)

    return hand


def sample_streams(
    rng: np.random.Generator,
    truth: object,
    scene: Scene,
    var: Variability,
    hand_rate_hz: float,
    object_rate_hz: float,
    others: tuple[object, ...] = (),
) -> tuple[HandTrack, dict[str, ObjectTrack]]:
    """Hand track and object tracks from the noise-free :class:`~lfd.sim.demonstrator.Truth`;
    ``others`` are the truths of further hands (they occlude the tags too; their keypoints are
    sampled by :func:`sample_hand`)."""
    t_ns: np.ndarray = truth.t_ns  # type: ignore[attr-defined]
    n = t_ns.size
    R_cv = scene.camera.rotation_cv()
    keypoints: np.ndarray = truth.keypoints  # type: ignore[attr-defined]
    hand = sample_hand(rng, t_ns, keypoints, R_cv, var, hand_rate_hz, object_rate_hz)

    tracks: dict[str, ObjectTrack] = {}
    tcps = [truth.tcp] + [h.tcp for h in others]  # type: ignore[attr-defined]
    for spec in scene.objects:
        pos = truth.object_pos[spec.name].copy()  # type: ignore[attr-defined]
        quat = yaw_quat(truth.object_yaw[spec.name])  # type: ignore[attr-defined]
        obj_noise = float(var.object_noise_mm or 0.0)
        sigma = obj_noise * 1e-3
        pos += _camera_noise(rng, (n,), sigma, 2.0, R_cv)
        rotvec = rng.normal(0.0, np.deg2rad(obj_noise * 0.5), (n, 3))
        angle = np.linalg.norm(rotvec, axis=1, keepdims=True)
        axis = rotvec / np.maximum(angle, 1e-12)
        dq = np.concatenate([axis * np.sin(angle / 2), np.cos(angle / 2)], axis=1)
        quat = _quat_mul(quat, dq)
        missing = _bursts(rng, n, float(var.dropout or 0.0), mean_len=0.2 * object_rate_hz)
        top = pos[:, 2] + 0.5 * spec.size[2]
        over = np.zeros(n, dtype=bool)
        for tcp in tcps:  # a hand right above the object
            over |= (np.linalg.norm(tcp[:, :2] - pos[:, :2], axis=1) < 0.06) & (
                tcp[:, 2] > top - 0.03
            )
        missing |= over & (rng.random(n) < float(var.occlusion or 0.0))
        pos[missing] = np.nan
        quat[missing] = np.nan
        tracks[spec.name] = ObjectTrack(
            name=spec.name,
            tag_id=spec.tag_id,
            size=np.array(spec.size),
            t_ns=t_ns.copy(),
            position=pos,
            quaternion=quat,
            visible=~missing,
        )
    return hand, tracks
