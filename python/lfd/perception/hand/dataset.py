"""Hand crops from depth images, and a training set rendered by the simulated demonstrator.

A depth frame is back-projected into the world (reference marker) frame; points more than
:data:`TABLE_CLEARANCE` above the table that are not inside a known box are hand or forearm.
Every point carries a fourth value, 1 when its pixel lies within :data:`BORDER_PX` of the image
border: a hand cut off by the edge of the view is then seen as cut off, not as a small hand.
The demonstrator reaches from the -y edge of the table, so the hand is the +y end of that blob:
the crop centre starts at the farthest points along +y and moves by a few mean-shift steps
(radius :data:`CROP_RADIUS`). The network sees the points within :data:`CROP_RADIUS` of the
centre, resampled to :data:`N_POINTS`, relative to the centre and divided by
:data:`CROP_RADIUS`.

Training samples take hand poses from simulated demonstrations (all tasks, many seeds) and
randomise them: wrist position and yaw, finger angles, hand size (several scenes), and the
depth sensor's noise (Gaussian, quantised to mm, missing pixels).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np

CROP_RADIUS = 0.14
"""Radius of the hand crop around its centre (m); also the coordinate scale of the network."""
N_POINTS = 256
"""Points per crop fed to the network."""
STORED_POINTS = 512
"""Points per crop in a training set (training draws N_POINTS of them per batch)."""
TABLE_CLEARANCE = 0.012
"""Points lower than this above the table (m) are table, tags or noise."""
MIN_POINTS = 60
"""Fewer hand points than this means no hand in view."""
PIXEL_STRIDE = 2
BORDER_PX = 6
"""Pixels this close to the image border are flagged (a hand leaving the view is cut there)."""
POINT_DIM = 4
"""Values per point: world x, y, z and the image-border flag."""


_RAYS: dict[tuple[Any, ...], tuple[np.ndarray, np.ndarray, np.ndarray]] = {}


def _ray_grid(K: np.ndarray, shape: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pixel rays (z = 1) on the ``PIXEL_STRIDE`` grid: x (h, w), y (h, w), border flag (h, w)."""
    key = (*np.asarray(K, float).ravel().tolist(), *shape)
    if key not in _RAYS:
        v, u = np.mgrid[0 : shape[0] : PIXEL_STRIDE, 0 : shape[1] : PIXEL_STRIDE]
        x = ((u - K[0, 2]) / K[0, 0]).astype(np.float32)
        y = ((v - K[1, 2]) / K[1, 1]).astype(np.float32)
        edge = (u < BORDER_PX) | (v < BORDER_PX)
        edge |= (u >= shape[1] - BORDER_PX) | (v >= shape[0] - BORDER_PX)
        _RAYS.clear()
        _RAYS[key] = (x, y, edge.astype(np.float32))
    return _RAYS[key]


def backproject(
    depth_mm: np.ndarray,
    K: np.ndarray,
    world_T_camera: np.ndarray,
    *,
    min_height: float = TABLE_CLEARANCE,
) -> np.ndarray:
    """World points (n, 4) of every ``PIXEL_STRIDE``-th depth pixel higher than ``min_height``.

    Columns: x, y, z (m) and 1.0 where the pixel lies within :data:`BORDER_PX` of the image
    border (else 0.0). ``depth_mm`` has shape (H, W) (uint16 mm, 0 = no data); the world z of
    every pixel is computed first, so only the few points above the table are fully
    back-projected.
    """
    full = np.asarray(depth_mm)
    d = full[::PIXEL_STRIDE, ::PIXEL_STRIDE].astype(np.float32) * 1e-3
    x, y, edge = _ray_grid(K, full.shape)
    R = np.asarray(world_T_camera[:3, :3], np.float32)
    t = np.asarray(world_T_camera[:3, 3], np.float32)
    zw = d * (R[2, 0] * x + R[2, 1] * y + R[2, 2]) + t[2]
    keep = (d > 0) & (zw > min_height)
    z = d[keep]
    P = np.column_stack([x[keep] * z, y[keep] * z, z])
    return np.column_stack([P @ R.T + t, edge[keep]]).astype(np.float64)


def hand_points(
    points: np.ndarray, boxes: Sequence[tuple[np.ndarray, np.ndarray, np.ndarray]] = ()
) -> np.ndarray:
    """Keep the points above the table and outside the boxes ``(centre, R (3, 3), size (3,))``."""
    keep = points[:, 2] > TABLE_CLEARANCE
    for centre, R, size in boxes:
        local = (points[:, :3] - centre) @ R
        inside = np.all(np.abs(local) < np.asarray(size) / 2.0 + 0.008, axis=1)
        keep &= ~inside
    return np.asarray(points[keep])


def crop_centre(points: np.ndarray) -> np.ndarray | None:
    """Centre (3,) of the hand in the above-table points, or None without a hand."""
    if len(points) < MIN_POINTS:
        return None
    xyz = points[:, :3]
    y_top = np.quantile(xyz[:, 1], 0.98)
    c = xyz[xyz[:, 1] >= y_top].mean(axis=0)
    for _ in range(4):
        near = xyz[np.linalg.norm(xyz - c, axis=1) < CROP_RADIUS * 0.75]
        if len(near) < MIN_POINTS:
            return None
        c = near.mean(axis=0)
    return np.asarray(c)


def normalised_crop(
    points: np.ndarray, centre: np.ndarray, rng: np.random.Generator, n: int = N_POINTS
) -> np.ndarray:
    """``n`` points (n, 4) within the crop radius: xyz relative to ``centre`` / CROP_RADIUS,
    and the border flag."""
    rel = (points[:, :3] - centre) / CROP_RADIUS
    inside = np.einsum("ij,ij->i", rel, rel) < 1.0
    rel = np.column_stack([rel[inside], points[inside, 3]])
    if len(rel) == 0:
        return np.zeros((n, POINT_DIM), np.float32)
    idx = rng.choice(len(rel), n, replace=len(rel) < n)
    return rel[idx].astype(np.float32)


def _noisy(depth_mm: np.ndarray, rng: np.random.Generator, sigma_mm: float) -> np.ndarray:
    d = depth_mm.astype(np.float64)
    valid = d > 0
    d = d + rng.normal(0.0, sigma_mm, d.shape) * (d / 800.0) ** 2
    d[~valid] = 0
    d[rng.random(d.shape) < rng.uniform(0.0, 0.05)] = 0
    return np.clip(np.round(d), 0, 65535).astype(np.uint16)


def _demo_poses(truth: Any, sizes: dict[str, Any]) -> list[tuple[Any, ...]]:
    """Per frame: wrist position, wrist quaternion (w, x, y, z), finger angles and the box the
    hand carries as ``(name, centre, yaw)`` (lifted off the table, within 8 cm of the TCP) or
    None."""
    out = []
    for i in range(truth.t_ns.size):
        held = None
        for name, size in sizes.items():
            c = truth.object_pos[name][i]
            lifted = c[2] > size[2] / 2 + 0.005
            if lifted and np.linalg.norm(truth.tcp[i] - c) < 0.08:
                held = (name, c, float(truth.object_yaw[name][i]))
        out.append((truth.wrist_pos[i], truth.wrist_quat[i], truth.q[i], held))
    return out


def randomised_views(
    n_samples: int,
    *,
    seed: int = 0,
    scales: Sequence[float] = (0.85, 0.93, 1.0, 1.07, 1.15),
) -> Iterator[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Render ``n_samples`` randomised depth frames with a hand in view.

    Yields the hand points as the recorder extracts them (world frame, (m, POINT_DIM): after
    back-projection and excluding the known boxes), the true keypoints (21, 3), m, and the
    crop centre (3,) of :func:`crop_centre`.

    Hand poses come from simulated demonstrations of exp1-exp4 (demonstration seeds
    ``10 seed .. 10 seed + 3``) and are randomised: wrist yaw and position, finger angles, hand
    size (``scales``), box positions and depth noise. A demonstration frame in which the hand
    carries a box keeps that box in the hand (moved with the randomised wrist); half of the time
    it is not excluded, as when its tag is hidden by the hand and the recorder only knows where
    it was last seen.
    """
    from ... import _gl  # noqa: F401  (headless GL before mujoco loads)

    # isort: split
    import mujoco
    from scipy.spatial.transform import Rotation

    from ...sim import simulate
    from ...sim.hand import JOINT_NAMES
    from ...sim.scene import build_scene, forearm_quat

    rng = np.random.default_rng(seed)
    poses = []  # (wrist_pos, wrist_quat wxyz, q, carried box) from simulated demonstrations
    for k, task in enumerate(("exp1", "exp2", "exp3", "exp4")):
        r = simulate(task, seed=seed * 10 + k)
        poses += _demo_poses(r.truth, {o.name: o.size for o in r.scene.objects})
    per_scale = -(-n_samples // len(scales))
    done = 0
    for scale in scales:
        scene = build_scene(hand_scale=float(scale))
        model = scene.compile()
        data = mujoco.MjData(model)
        cam = scene.camera
        K, W = cam.intrinsics(), cam.world_T_camera()
        qadr = np.array([model.jnt_qposadr[model.joint(n).id] for n in JOINT_NAMES])
        sites = np.array([model.site(f"kp_{i}").id for i in range(21)])
        hand_mocap = int(model.body_mocapid[model.body("hand").id])
        arm_mocap = int(model.body_mocapid[model.body("forearm").id])
        obj_adr = [int(model.jnt_qposadr[model.joint(o.name).id]) for o in scene.objects]
        renderer = mujoco.Renderer(model, cam.height, cam.width)
        renderer.enable_depth_rendering()
        try:
            target = min(n_samples, done + per_scale)
            while done < target:
                wp, wq, q, held = poses[int(rng.integers(len(poses)))]
                yaw = rng.uniform(-0.5, 0.5)
                rot = Rotation.from_euler("z", yaw)
                wrist = rot.apply(wp) + rng.normal(0.0, [0.05, 0.05, 0.03])
                wrist[2] = max(wrist[2], 0.03)
                shift = wrist - rot.apply(wp)
                quat = (rot * Rotation.from_quat(np.roll(wq, -1))).as_quat()
                data.mocap_pos[hand_mocap] = wrist
                data.mocap_quat[hand_mocap] = np.roll(quat, 1)
                data.mocap_pos[arm_mocap] = wrist
                data.mocap_quat[arm_mocap] = forearm_quat(wrist)
                data.qpos[qadr] = q + rng.normal(0.0, np.deg2rad(8.0), q.shape)
                boxes = []
                for spec, adr in zip(scene.objects, obj_adr, strict=True):
                    pos = np.array(
                        [rng.uniform(-0.2, 0.2), rng.uniform(0.1, 0.4), spec.size[2] / 2]
                    )
                    oyaw = rng.uniform(-np.pi, np.pi)
                    excluded = True
                    if held is not None and held[0] == spec.name:  # in the hand, moved with it
                        pos, oyaw = rot.apply(held[1]) + shift, held[2] + yaw
                        excluded = bool(rng.random() < 0.5)
                    data.qpos[adr : adr + 3] = pos
                    data.qpos[adr + 3 : adr + 7] = (np.cos(oyaw / 2), 0, 0, np.sin(oyaw / 2))
                    if excluded:
                        R_box = Rotation.from_euler("z", oyaw).as_matrix()
                        boxes.append((pos, R_box, np.array(spec.size)))
                mujoco.mj_kinematics(model, data)
                mujoco.mj_camlight(model, data)
                renderer.update_scene(data, "cam")
                z = renderer.render()
                depth = np.where((z > 0) & (z < 10.0), np.round(z * 1000.0), 0).astype(np.uint16)
                depth = _noisy(depth, rng, rng.uniform(0.5, 3.0))
                pts = hand_points(backproject(depth, K, W), boxes)
                centre = crop_centre(pts)
                if centre is None:
                    continue
                yield pts, data.site_xpos[sites].copy(), centre
                done += 1
        finally:
            renderer.close()


def render_training_set(
    n_samples: int,
    *,
    seed: int = 0,
    scales: Sequence[float] = (0.85, 0.93, 1.0, 1.07, 1.15),
    progress: Any = None,
) -> dict[str, np.ndarray]:
    """Render ``n_samples`` randomised hand crops (:func:`randomised_views`) with their
    ground-truth keypoints, cropped as at run time.

    Returns
    -------
    dict with ``points`` (n, STORED_POINTS, POINT_DIM) float32 (xyz and the border flag) and
    ``keypoints`` (n, 21, 3) float32, both relative to the crop centre / :data:`CROP_RADIUS`,
    and ``centre`` (n, 3) (m).
    """
    rng = np.random.default_rng(seed + 10_000)
    out_p = np.empty((n_samples, STORED_POINTS, POINT_DIM), np.float32)
    out_k = np.empty((n_samples, 21, 3), np.float32)
    out_c = np.empty((n_samples, 3))
    for i, (pts, kp, c) in enumerate(randomised_views(n_samples, seed=seed, scales=scales)):
        out_p[i] = normalised_crop(pts, c, rng, STORED_POINTS)
        out_k[i] = (kp - c) / CROP_RADIUS
        out_c[i] = c
        if progress is not None:
            progress(1)
    return {"points": out_p, "keypoints": out_k, "centre": out_c}
