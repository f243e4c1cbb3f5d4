"""Differential inverse kinematics of the arm with mink (QP-based, joint limits respected).

The gripper orientation used throughout the reproduction is "top-down with a yaw":
:func:`gripper_rotation` maps a yaw angle (direction of the closing axis in the table plane) to
the rotation matrix of the gripper frame (x, y = closing axis, z = approach = world -Z).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .arm import Robot
from .robot import KUKA_LWR4


def gripper_rotation(yaw: float) -> np.ndarray:
    """Top-down gripper orientation whose closing axis points along ``(cos yaw, sin yaw, 0)``.

    Returns
    -------
    array, shape (3, 3)
        Columns are the gripper x, y (closing) and z (approach) axes in world coordinates.
    """
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[-s, c, 0.0], [c, s, 0.0], [0.0, 0.0, -1.0]])


def rotation_angle(Ra: np.ndarray, Rb: np.ndarray) -> float:
    """Angle (rad) of the relative rotation between two rotation matrices."""
    c = (np.trace(np.asarray(Ra).T @ np.asarray(Rb)) - 1.0) / 2.0
    return float(np.arccos(np.clip(c, -1.0, 1.0)))


class ArmIK:
    """Differential IK on a robot-only model (no object free joints), one step per control tick.

    Parameters
    ----------
    base : array, shape (3,)
        Robot base position in the world.
    posture_cost : float
        Weight of the posture task that keeps the redundant elbow near the robot's
        :attr:`~lfd.reproduce.arm.Robot.home_q`.
    robot : Robot
        The arm (its MJCF alone, without the scene's objects).
    """

    def __init__(
        self, base: np.ndarray, *, posture_cost: float = 1e-2, robot: Robot = KUKA_LWR4
    ) -> None:
        import mink
        import mujoco

        self._mink = mink
        self.robot = robot
        self.dof = robot.dof
        self.model = mujoco.MjModel.from_xml_string(robot.model_xml(base))
        self.data = mujoco.MjData(self.model)
        self.cfg = mink.Configuration(self.model)
        self.task = mink.FrameTask(
            "tcp", "site", position_cost=1.0, orientation_cost=0.5, lm_damping=1e-3
        )
        self.posture = mink.PostureTask(self.model, cost=posture_cost)
        home = np.zeros(self.model.nq)
        home[: self.dof] = robot.home_q
        home[self.dof : self.dof + 2] = min(0.03, robot.max_opening / 2)
        self.home = home
        self.posture.set_target(home)
        self.limits: list[Any] = [mink.ConfigurationLimit(self.model)]
        self.cfg.update(home)

    @property
    def q(self) -> np.ndarray:
        """Current IK joint angles of the arm, shape (dof,)."""
        return np.array(self.cfg.q[: self.dof])

    def reset(self, q: np.ndarray | None = None) -> None:
        """Set the IK configuration (arm joints; fingers keep their posture value)."""
        full = self.home.copy()
        if q is not None:
            full[: self.dof] = np.asarray(q, dtype=np.float64).reshape(self.dof)
        self.cfg.update(full)

    def step(self, position: np.ndarray, rotation: np.ndarray, *, iters: int = 3) -> np.ndarray:
        """Move the IK configuration towards a TCP pose (``iters`` QP steps); return arm q."""
        mink = self._mink
        target = mink.SE3.from_rotation_and_translation(
            mink.SO3.from_matrix(np.asarray(rotation, dtype=np.float64)),
            np.asarray(position, dtype=np.float64),
        )
        self.task.set_target(target)
        dt = 0.01
        for _ in range(iters):
            v = mink.solve_ik(
                self.cfg, [self.task, self.posture], dt, "daqp", 1e-3, limits=self.limits
            )
            self.cfg.integrate_inplace(v, dt)
        return self.q

    def seed_towards(self, position: np.ndarray, rotation: np.ndarray) -> None:
        """Reset to the home pose turned towards a target (joint 1) with a matching wrist yaw
        (:attr:`~lfd.reproduce.arm.Robot.wrist_yaw`)."""
        base = self.model.body("robot_base").pos
        phi = float(np.arctan2(position[1] - base[1], position[0] - base[0]))
        yaw = float(np.arctan2(rotation[1, 1], rotation[0, 1]))  # closing axis heading
        q = np.array(self.robot.home_q, dtype=np.float64)
        q[0] = phi
        offset, sign = self.robot.wrist_yaw
        q[-1] = (offset + sign * phi - sign * yaw + np.pi) % (2 * np.pi) - np.pi
        self.reset(q)

    def solve(
        self, position: np.ndarray, rotation: np.ndarray, *, max_iters: int = 400, tol: float = 1e-4
    ) -> np.ndarray:
        """Iterate :meth:`step` until the pose error is below ``tol`` (position metres)."""
        for _ in range(max_iters // 4):
            self.step(position, rotation, iters=4)
            p, R = self.tcp_pose()
            if np.linalg.norm(p - position) < tol and rotation_angle(R, rotation) < 1e-3:
                break
        return self.q

    def tcp_pose(self, q: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Forward kinematics of the TCP site: position (3,) and rotation (3, 3)."""
        import mujoco

        qq = np.array(self.cfg.q) if q is None else np.concatenate([q, self.home[self.dof :]])
        self.data.qpos[:] = qq
        mujoco.mj_kinematics(self.model, self.data)
        sid = self.model.site("tcp").id
        return self.data.site_xpos[sid].copy(), self.data.site_xmat[sid].reshape(3, 3).copy()
