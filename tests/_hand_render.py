"""Rendered hand views with ground truth for the keypoint-lifting tests (not a test module).

Frames of simulated demonstrations (hand poses and the boxes where they are, held ones
included) are re-rendered with MuJoCo at 640x480, with the wrist moved and turned a little,
the fingers perturbed, several hand sizes and camera positions, and a depth sensor's noise.
The "detector" output is the true keypoints' projection; the landmark model's relative depth is
the true camera depth relative to the wrist in pixel units, with a scale error and noise.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import lfd._gl  # noqa: F401  (headless GL before mujoco loads)
import numpy as np

PALM = [0, 5, 9, 13, 17]
CAMERAS = (
    ((0.0, 0.62, 0.64), (0.0, 0.15, 0.0)),  # the default: in front of the demonstrator, above
    ((0.45, 0.55, 0.55), (0.0, 0.15, 0.0)),  # from the right
    ((-0.35, -0.05, 0.75), (0.0, 0.2, 0.0)),  # from behind the demonstrator's left shoulder
)


@dataclass
class View:
    depth_mm: np.ndarray  # (H, W) uint16
    K: np.ndarray  # (3, 3)
    world_T_camera: np.ndarray  # (4, 4)
    keypoints: np.ndarray  # (21, 3) camera frame, m (truth)
    uv: np.ndarray  # (21, 2) true projection
    relative_z: np.ndarray  # (21,) pixel units, noisy
    box_mask: np.ndarray  # (H, W) bool: pixels of the boxes (what tag tracking would exclude)
    hand_mask: np.ndarray  # (H, W) bool: pixels of the hand and forearm
    camera: int  # index into CAMERAS
    hand_scale: float


def noisy_depth(depth_mm: np.ndarray, rng: np.random.Generator, sigma_mm: float) -> np.ndarray:
    """A depth sensor's imperfections: noise growing with depth^2, mm quantisation, dropped
    pixels, and mixed ("flying") pixels between foreground and background at depth edges."""
    d = depth_mm.astype(np.float64)
    valid = d > 0
    pad = np.pad(d, 1, mode="edge")
    h, w = d.shape
    neigh = np.stack([pad[1 + dy : 1 + dy + h, 1 + dx : 1 + dx + w] for dy, dx in
                      ((-1, 0), (1, 0), (0, -1), (0, 1))])  # fmt: skip
    far = neigh.max(axis=0)
    edge = valid & (far - d > 30.0) & (rng.random(d.shape) < 0.5)
    d[edge] += rng.uniform(0.0, 1.0, edge.sum()) * (far[edge] - d[edge])
    d = d + rng.normal(0.0, sigma_mm, d.shape) * (d / 800.0) ** 2
    d[~valid] = 0
    d[rng.random(d.shape) < rng.uniform(0.0, 0.05)] = 0
    return np.clip(np.round(d), 0, 65535).astype(np.uint16)


def relative_z_from_truth(
    keypoints_cam: np.ndarray,
    fx: float,
    rng: np.random.Generator,
    *,
    noise_m: float = 0.005,
    scale_range: tuple[float, float] = (0.8, 1.2),
) -> np.ndarray:
    """A landmark model's relative depth: (z - z_wrist) * fx / z_hand, in pixels, times a scale
    error, plus Gaussian noise of ``noise_m`` metres (converted to pixels)."""
    z = keypoints_cam[:, 2]
    z_hand = float(np.mean(z[PALM]))
    scale = rng.uniform(*scale_range)
    noise = rng.normal(0.0, noise_m, 21)
    noise[0] = 0.0
    return (scale * (z - z[0]) + noise) * fx / z_hand


def render_views(  # noqa: PLR0915  the render loop: scenes, then views rendered in each
    n_views: int,
    *,
    seed: int = 0,
    scales: Sequence[float] = (0.9, 1.0, 1.1),
    cameras: Sequence[int] = (0, 1, 2),
    tasks: Sequence[str] = ("exp1", "exp2", "exp3", "exp4"),
    per_scene: int = 4,
) -> Iterator[View]:
    """``n_views`` views of the hand (all 21 keypoints inside the image), spread over the hand
    sizes ``scales`` and the camera positions ``cameras`` (indices into :data:`CAMERAS`)."""
    import mujoco
    from lfd.sim import simulate
    from lfd.sim.hand import JOINT_NAMES
    from lfd.sim.scene import CameraSpec, build_scene, forearm_quat
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(seed)
    frames = []  # (truth, index) near the boxes half of the time
    for k, task in enumerate(tasks):
        r = simulate(task, seed=seed * 10 + k)
        objects = r.scene.objects
        truth = r.truth
        near = np.zeros(truth.t_ns.size, bool)
        for o in objects:
            near |= np.linalg.norm(truth.tcp - truth.object_pos[o.name], axis=1) < 0.1
        frames += [(truth, int(i), bool(near[i])) for i in range(truth.t_ns.size)]
    near_idx = [f for f in frames if f[2]]
    combos = [(s, c) for s in scales for c in cameras]
    done = 0
    for n_scene in range(10 * n_views):
        if done >= n_views:
            return
        scale, cam_i = combos[n_scene % len(combos)]
        cam = CameraSpec(position=CAMERAS[cam_i][0], target=CAMERAS[cam_i][1])
        scene = build_scene(objects, hand_scale=float(scale), camera=cam)
        model = scene.compile()
        data = mujoco.MjData(model)
        K, T = cam.intrinsics(), cam.world_T_camera()
        qadr = np.array([model.jnt_qposadr[model.joint(n).id] for n in JOINT_NAMES])
        sites = np.array([model.site(f"kp_{i}").id for i in range(21)])
        hand_mocap = int(model.body_mocapid[model.body("hand").id])
        arm_mocap = int(model.body_mocapid[model.body("forearm").id])
        obj_adr = {o.name: int(model.jnt_qposadr[model.joint(o.name).id]) for o in objects}
        box_geoms = {model.geom(o.name).id for o in objects}
        box_geoms |= {model.geom(f"{o.name}_tag").id for o in objects}
        hand_body = {model.body("hand").id, model.body("forearm").id}
        renderer = mujoco.Renderer(model, cam.height, cam.width)
        try:
            for _ in range(per_scene):  # a few views per scene, then the next size / camera
                pool = near_idx if rng.random() < 0.5 else frames
                truth, i, _near = pool[int(rng.integers(len(pool)))]
                yaw = rng.uniform(-0.3, 0.3)
                rot = Rotation.from_euler("z", yaw)
                centre = np.array([0.0, 0.2, 0.0])
                wrist = rot.apply(truth.wrist_pos[i] - centre) + centre
                shift = wrist - truth.wrist_pos[i] + rng.normal(0.0, [0.03, 0.03, 0.0])
                wrist = truth.wrist_pos[i] + shift
                quat = (rot * Rotation.from_quat(np.roll(truth.wrist_quat[i], -1))).as_quat()
                data.mocap_pos[hand_mocap] = wrist
                data.mocap_quat[hand_mocap] = np.roll(quat, 1)
                data.mocap_pos[arm_mocap] = wrist
                data.mocap_quat[arm_mocap] = forearm_quat(wrist)
                data.qpos[qadr] = truth.q[i] + rng.normal(0.0, np.deg2rad(5.0), 20)
                for o in objects:
                    adr = obj_adr[o.name]
                    pos = truth.object_pos[o.name][i]
                    oyaw = truth.object_yaw[o.name][i]
                    if np.linalg.norm(pos - truth.tcp[i]) < 0.1:  # near / in the hand: moved
                        pos = rot.apply(pos - centre) + centre + shift
                        oyaw = oyaw + yaw
                    data.qpos[adr : adr + 3] = pos
                    data.qpos[adr + 3 : adr + 7] = (np.cos(oyaw / 2), 0, 0, np.sin(oyaw / 2))
                mujoco.mj_kinematics(model, data)
                mujoco.mj_camlight(model, data)
                kp_w = data.site_xpos[sites].copy()
                kp_c = (kp_w - T[:3, 3]) @ T[:3, :3]
                uv = kp_c[:, :2] / kp_c[:, 2:3] * [K[0, 0], K[1, 1]] + K[:2, 2]
                if (
                    np.any(uv < 2)
                    or np.any(uv[:, 0] > cam.width - 3)
                    or np.any(uv[:, 1] > cam.height - 3)
                ):
                    continue
                renderer.enable_depth_rendering()
                renderer.update_scene(data, "cam")
                z = renderer.render()
                renderer.disable_depth_rendering()
                renderer.enable_segmentation_rendering()
                renderer.update_scene(data, "cam")
                seg = renderer.render()
                renderer.disable_segmentation_rendering()
                geom = np.where(seg[..., 1] == int(mujoco.mjtObj.mjOBJ_GEOM), seg[..., 0], -1)
                box_mask = np.isin(geom, list(box_geoms))
                root = model.body_rootid[model.geom_bodyid[np.maximum(geom, 0)]]
                hand_mask = (geom >= 0) & np.isin(root, list(hand_body))
                depth = np.where((z > 0) & (z < 10.0), np.round(z * 1000.0), 0).astype(np.uint16)
                yield View(
                    depth_mm=noisy_depth(depth, rng, rng.uniform(0.5, 3.0)),
                    K=K,
                    world_T_camera=T,
                    keypoints=kp_c,
                    uv=uv,
                    relative_z=relative_z_from_truth(kp_c, K[0, 0], rng),
                    box_mask=box_mask,
                    hand_mask=hand_mask,
                    camera=cam_i,
                    hand_scale=float(scale),
                )
                done += 1
                if done >= n_views:
                    return
        finally:
            renderer.close()
