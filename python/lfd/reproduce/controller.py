"""Execute a planned TCP trajectory + gripper command in MuJoCo physics.

Every 10 ms control tick the IK (:class:`~lfd.reproduce.ik.ArmIK`, 3 QP iterations) moves its
configuration towards the planned TCP pose; the result is the set point of the joint position
servos. The fingers get half the commanded opening each (position servos with a 20 N force
limit, so a closed command squeezes the object). Physics runs at 2 ms (5 steps per tick).
Grasping is purely physical: nothing is welded or teleported.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from .arm import Robot
from .ik import ArmIK, gripper_rotation
from .robot import KUKA_LWR4
from .scene import ObjectSpec, scene_xml

TICK = 0.01
"""Control period (s)."""
LOOKAHEAD = 5
"""Ticks the joint set point leads the plan (compensates the servo's kv/kp = 0.05 s lag)."""


@dataclass
class Plan:
    """A TCP trajectory sampled at control ticks.

    Attributes
    ----------
    position : array, shape (n, 3)
        TCP positions (m, world).
    yaw : array, shape (n,)
        Gripper yaw (rad): direction of the closing axis; the approach is top-down.
    opening : array, shape (n,)
        Commanded distance between the pads (m); 0 = close (squeeze).
    segment : array, shape (n,)
        Index of the task-program segment each tick belongs to (-1 for dwell/settle ticks).
    """

    position: np.ndarray
    yaw: np.ndarray
    opening: np.ndarray
    segment: np.ndarray

    def __len__(self) -> int:
        return int(self.position.shape[0])

    @property
    def duration_s(self) -> float:
        """Execution time in seconds."""
        return len(self) * TICK

    @staticmethod
    def of_path(path: np.ndarray, segment: int, opening: float = 0.0) -> Plan:
        """A plan along ``path`` (n, 4: x, y, z, yaw) with one opening, in one segment."""
        n = len(path)
        return Plan(path[:, :3].copy(), path[:, 3].copy(), np.full(n, opening), np.full(n, segment))

    @staticmethod
    def concat(parts: list[Plan]) -> Plan:
        """Join plans in order."""
        return Plan(
            np.concatenate([p.position for p in parts]),
            np.concatenate([p.yaw for p in parts]),
            np.concatenate([p.opening for p in parts]),
            np.concatenate([p.segment for p in parts]),
        )


@dataclass
class Execution:
    """What happened in physics.

    Attributes
    ----------
    tcp : array, shape (n, 3)
        Executed TCP positions at each tick.
    planned_ik : array, shape (n, 3)
        TCP of the IK solution at each tick (what the servos were asked to reach).
    object_names : list[str]
    object_position : array, shape (k, n, 3)
    object_quaternion : array, shape (k, n, 4)
        (x, y, z, w) per tick.
    final_position, final_quaternion : arrays, shapes (k, 3), (k, 4)
        Object poses after the final settling time.
    frames : list of arrays
        Rendered RGB frames when requested.
    """

    tcp: np.ndarray
    planned_ik: np.ndarray
    object_names: list[str]
    object_position: np.ndarray
    object_quaternion: np.ndarray
    final_position: np.ndarray
    final_quaternion: np.ndarray
    frames: list[np.ndarray] = field(default_factory=list)
    wall_time_s: float = 0.0
    warnings: list[str] = field(default_factory=list)
    """MuJoCo warnings raised during the run (e.g. an unstable simulation)."""
    qpos: np.ndarray | None = None
    """(n, nq) ``data.qpos`` at the start of each tick, before its command acts (robot
    data: ``lfd.export.robot_data``)."""
    ctrl: np.ndarray | None = None
    """(n, nu) the actuators' set points commanded at each tick."""
    scene: str = ""
    """The MJCF of the scene that ran (``qpos`` indexes its model)."""


def execute(
    plan: Plan,
    base: np.ndarray,
    objects: list[ObjectSpec],
    *,
    settle_s: float = 0.5,
    video_fps: float = 0.0,
    video_size: tuple[int, int] = (480, 640),
    progress: Callable[[int, int], None] | None = None,
    robot: Robot = KUKA_LWR4,
) -> Execution:
    """Run ``plan`` on the robot in the scene and record the TCP and the objects.

    Parameters
    ----------
    plan : Plan
        The TCP trajectory at :data:`TICK` spacing.
    base : array, shape (3,)
        Robot base position.
    objects : list of ObjectSpec
        Cuboids at their initial poses.
    settle_s : float
        Time the robot holds its last pose before the objects are measured.
    video_fps : float
        Render frames at this rate (0 = no rendering).
    progress : callable, optional
        Called as ``progress(tick, n_ticks)`` every 100 ticks.
    robot : Robot
        The arm that runs the plan.
    """
    import mujoco

    # MuJoCo's default warning handler appends to MUJOCO_LOG.TXT in the working directory;
    # collect the warnings instead (restored afterwards)
    warnings: list[str] = []
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(warnings.append)
    try:
        return _run(plan, base, objects, settle_s, video_fps, video_size, progress, warnings, robot)
    finally:
        mujoco.set_mju_user_warning(previous)


def _run(
    plan: Plan,
    base: np.ndarray,
    objects: list[ObjectSpec],
    settle_s: float,
    video_fps: float,
    video_size: tuple[int, int],
    progress: Callable[[int, int], None] | None,
    warnings: list[str],
    robot: Robot,
) -> Execution:
    import time

    import mujoco

    t_start = time.perf_counter()
    xml = scene_xml(base, objects, robot=robot)
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    ik = ArmIK(base, robot=robot)
    dof, max_opening = robot.dof, robot.max_opening
    n = len(plan)
    if n == 0:
        raise ValueError("empty plan")
    R0 = gripper_rotation(float(plan.yaw[0]))
    ik.seed_towards(plan.position[0], R0)
    q0 = ik.solve(plan.position[0], R0)
    arm_qadr = [model.joint(j).qposadr[0] for j in robot.arm_joints]
    fingers = [model.joint(f).qposadr[0] for f in robot.finger_joints]
    data.qpos[arm_qadr] = q0
    w0 = float(np.clip(plan.opening[0], 0.0, max_opening)) / 2
    data.qpos[fingers] = w0
    data.ctrl[:dof] = q0
    data.ctrl[dof : dof + 2] = w0
    mujoco.mj_forward(model, data)
    tcp_id = model.site("tcp").id
    names = [o.name for o in objects]
    body_ids = [model.body(nm).id for nm in names]
    steps = max(1, round(TICK / model.opt.timestep))
    n_settle = round(settle_s / TICK)
    tcp = np.zeros((n, 3))
    ik_tcp = np.zeros((n, 3))
    opos = np.zeros((len(names), n, 3))
    oquat = np.zeros((len(names), n, 4))
    qpos, ctrl = np.zeros((n, model.nq)), np.zeros((n, model.nu))
    renderer = None
    cam = None
    frames: list[np.ndarray] = []
    every = max(1, round(1.0 / (video_fps * TICK))) if video_fps > 0 else 0
    if every:
        renderer = mujoco.Renderer(model, *video_size)
        cam = mujoco.MjvCamera()
        cam.lookat[:] = np.mean([o.position for o in objects], axis=0) if objects else base
        cam.distance, cam.azimuth, cam.elevation = 1.6, 150.0, -30.0
    try:
        for i in range(n + n_settle):
            k = min(i, n - 1)
            # feed-forward: the servo (kp, kv) lags by kv/kp = 50 ms at constant velocity, so the
            # IK tracks the plan LOOKAHEAD ticks ahead
            ka = min(i + LOOKAHEAD, n - 1)
            R = gripper_rotation(float(plan.yaw[ka]))
            q = ik.step(plan.position[ka], R) if i < n else ik.q
            data.ctrl[:dof] = q
            data.ctrl[dof : dof + 2] = float(np.clip(plan.opening[k], 0.0, max_opening)) / 2
            if i < n:
                qpos[i], ctrl[i] = data.qpos, data.ctrl
            for _ in range(steps):
                mujoco.mj_step(model, data)
            if i < n:
                tcp[i] = data.site_xpos[tcp_id]
                ik_tcp[i] = ik.tcp_pose()[0]  # (of the look-ahead target)
                for j, b in enumerate(body_ids):
                    opos[j, i] = data.xpos[b]
                    w, x, y, z = data.xquat[b]
                    oquat[j, i] = (x, y, z, w)
            if renderer is not None and cam is not None and i % every == 0:
                renderer.update_scene(data, cam)
                renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = 0
                renderer.scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = 0
                frames.append(renderer.render().copy())
            if progress is not None and i % 100 == 0:
                progress(i, n + n_settle)
    finally:
        if renderer is not None:
            renderer.close()
    fpos = np.array([data.xpos[b].copy() for b in body_ids]).reshape(len(names), 3)
    fq = np.array([[*data.xquat[b][1:], data.xquat[b][0]] for b in body_ids]).reshape(-1, 4)
    return Execution(
        tcp=tcp,
        planned_ik=ik_tcp,
        object_names=names,
        object_position=opos,
        object_quaternion=oquat,
        final_position=fpos,
        final_quaternion=fq,
        frames=frames,
        wall_time_s=time.perf_counter() - t_start,
        warnings=warnings,
        qpos=qpos,
        ctrl=ctrl,
        scene=xml,
    )
