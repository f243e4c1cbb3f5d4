"""Offscreen rendering of a simulated demonstration: colour and metric depth like an RGB-D camera.

Needs an OpenGL backend without a display: set ``MUJOCO_GL=egl`` (or ``osmesa``) before MuJoCo
is imported (done here if unset). Shadows and reflections are off and there is no
multi-sampling, so pixels are deterministic for a given machine.
"""

from __future__ import annotations

import os

import numpy as np

from ..demo import ImageStream
from ..errors import UsageError
from .hand import JOINT_NAMES, LEFT_PREFIX
from .scene import LEFT_SHOULDER, Scene, forearm_quat


def render_frames(
    scene: Scene, truth: object, frames: np.ndarray, *, depth: bool = True
) -> tuple[ImageStream, ImageStream | None]:
    """Render camera frames ``frames`` (indices into ``truth.t_ns``).

    Returns
    -------
    color : ImageStream
        RGB frames, uint8, shape (n, H, W, 3).
    depth : ImageStream or None
        Depth along the optical axis in millimetres, uint16, shape (n, H, W) (0 = no return).
    """
    os.environ.setdefault("MUJOCO_GL", "egl")
    import mujoco

    model = scene.compile()
    data = mujoco.MjData(model)
    cam = scene.camera
    qadr = np.array([model.jnt_qposadr[model.joint(n).id] for n in JOINT_NAMES])
    obj_adr = {o.name: int(model.jnt_qposadr[model.joint(o.name).id]) for o in scene.objects}
    hand_mocap = int(model.body_mocapid[model.body("hand").id])
    arm_mocap = int(model.body_mocapid[model.body("forearm").id])
    left = getattr(truth, "other", None)  # the left hand of a two-hand demonstration
    if left is not None:
        l_qadr = np.array([model.jnt_qposadr[model.joint(LEFT_PREFIX + n).id] for n in JOINT_NAMES])
        l_hand = int(model.body_mocapid[model.body(LEFT_PREFIX + "hand").id])
        l_arm = int(model.body_mocapid[model.body(LEFT_PREFIX + "forearm").id])
    frames = np.asarray(frames, dtype=int)
    color = np.empty((frames.size, cam.height, cam.width, 3), np.uint8)
    depth_mm = np.empty((frames.size, cam.height, cam.width), np.uint16) if depth else None
    renderer = mujoco.Renderer(model, cam.height, cam.width)
    try:
        for k, i in enumerate(frames):
            wrist = truth.wrist_pos[i]  # type: ignore[attr-defined]
            data.mocap_pos[hand_mocap] = wrist
            data.mocap_quat[hand_mocap] = truth.wrist_quat[i]  # type: ignore[attr-defined]
            data.mocap_pos[arm_mocap] = wrist
            data.mocap_quat[arm_mocap] = forearm_quat(wrist)
            data.qpos[qadr] = truth.q[i]  # type: ignore[attr-defined]
            if left is not None:
                data.mocap_pos[l_hand] = data.mocap_pos[l_arm] = left.wrist_pos[i]
                data.mocap_quat[l_hand] = left.wrist_quat[i]
                data.mocap_quat[l_arm] = forearm_quat(left.wrist_pos[i], LEFT_SHOULDER)
                data.qpos[l_qadr] = left.q[i]
            for name, adr in obj_adr.items():
                yaw = truth.object_yaw[name][i]  # type: ignore[attr-defined]
                data.qpos[adr : adr + 3] = truth.object_pos[name][i]  # type: ignore[attr-defined]
                data.qpos[adr + 3 : adr + 7] = (np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2))
            mujoco.mj_kinematics(model, data)
            mujoco.mj_camlight(model, data)
            renderer.disable_depth_rendering()
            renderer.update_scene(data, "cam")
            renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = 0
            renderer.scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = 0
            color[k] = renderer.render()
            if depth_mm is not None:
                renderer.enable_depth_rendering()
                renderer.update_scene(data, "cam")
                z = renderer.render()
                z = np.where((z > 0) & (z < 10.0), np.round(z * 1000.0), 0.0)
                depth_mm[k] = z.astype(np.uint16)
    finally:
        renderer.close()
    t_ns = truth.t_ns[frames]  # type: ignore[attr-defined]
    return (
        ImageStream(t_ns=t_ns, frames=color),
        ImageStream(t_ns=t_ns.copy(), frames=depth_mm) if depth_mm is not None else None,
    )


def add_rendering(
    result: object, *, rate_hz: float = 10.0, until_s: float | None = None, depth: bool = True
) -> None:
    """Render ``result`` (a :class:`~lfd.sim.demonstrator.SimResult`) at ``rate_hz`` in place.

    Frames are taken on camera frames (a multiple of the object rate's period); ``until_s``
    limits rendering to the first seconds.
    """
    demo = result.demo  # type: ignore[attr-defined]
    truth = result.truth  # type: ignore[attr-defined]
    rate = float(demo.metadata.get("object_rate_hz", 30.0))
    if not 0 < rate_hz <= rate:
        raise UsageError(f"render rate must be in (0, {rate:g}] Hz, got {rate_hz}")
    step = max(1, round(rate / rate_hz))
    frames = np.arange(0, truth.t_ns.size, step)
    if until_s is not None:
        frames = frames[(truth.t_ns[frames] - truth.t_ns[0]) <= until_s * 1e9]
    demo.color, demo.depth = render_frames(result.scene, truth, frames, depth=depth)  # type: ignore[attr-defined]
    demo.metadata["render_rate_hz"] = rate / step
