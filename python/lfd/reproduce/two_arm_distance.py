"""How close the two arms come to each other along their plans, before anything is run: the
one measurement both clearance rules use (:mod:`.two_arm_holds`, a hold pressed away from the
other arm; :mod:`.two_arm_clearance`, a hold re-ordered).

Each arm's IK follows its plan on the common clock as
:func:`~lfd.reproduce.two_arms.execute_two` commands it (the look-ahead included, one IK step
a control tick, the last pose held once a plan ends; no dynamics, no objects), and the least
distance between the two arms' colliding geoms (:mod:`.two_arms_contacts`: links, gripper,
pads; ``mujoco.mj_geomDistance``, negative where they overlap) is measured every ``every``-th
tick (:func:`arm_distances`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from .controller import LOOKAHEAD, TICK, Plan

FAR = 0.1
"""Distances beyond this (m) are not measured exactly (reported as this)."""

MakeIK = Callable[[str], Any]
"""A fresh IK of the ``side`` arm at its base (:class:`~lfd.reproduce.two_arms.MountedIK`)."""


def _geoms(model: Any, sides: list[str]) -> dict[str, list[int]]:
    """Each arm's geoms that collide with the other arm (:data:`~.two_arms_contacts.ARM_BITS`)."""
    from .two_arms_contacts import ARM_BITS

    geoms: dict[str, list[int]] = {s: [] for s in sides}
    for g in range(model.ngeom):
        body = model.body(model.geom_bodyid[g]).name
        for s in sides:
            if body.startswith(f"{s}/") and int(model.geom_contype[g]) & ARM_BITS.get(s, 0):
                geoms[s].append(g)
    return geoms


def arm_distances(
    plans: dict[str, Plan], scene: str, make_ik: MakeIK, robot: Any, *, every: int
) -> np.ndarray:
    """The two arms' least distance (m, signed: negative where they overlap; at most
    :data:`FAR`) at every ``every``-th control tick of ``plans`` on one clock (tick ``k *
    every`` is ``k * every * TICK`` s). ``scene``: both arms' MJCF
    (:func:`~lfd.reproduce.two_arms.scene_xml`); ``make_ik(side)``: that arm's IK at its base.
    With one arm, every distance is :data:`FAR`."""
    import mujoco

    from .ik import gripper_rotation

    sides = list(plans)
    model = mujoco.MjModel.from_xml_string(scene)
    data = mujoco.MjData(model)
    geoms = _geoms(model, sides)
    iks = {s: make_ik(s) for s in sides}
    qadr, fadr = {}, {}
    for s in sides:
        plan, arm = plans[s], robot.arms[s]
        R0 = gripper_rotation(float(plan.yaw[0]))
        iks[s].seed_towards(plan.position[0], R0)
        iks[s].solve(plan.position[0], R0)
        qadr[s] = [model.joint(j).qposadr[0] for j in arm.arm_joints]
        fadr[s] = [model.joint(f).qposadr[0] for f in arm.finger_joints]
    ga, gb = np.array(geoms[sides[0]], dtype=int), np.array(geoms[sides[-1]], dtype=int)
    if len(sides) < 2:
        ga = gb = np.zeros(0, dtype=int)
    rab = model.geom_rbound[ga][:, None] + model.geom_rbound[gb][None, :]
    n = max(len(p) for p in plans.values())
    out = np.full(len(range(0, n, every)), FAR)
    fromto = np.zeros(6)
    for i in range(n):
        for s in sides:
            plan = plans[s]
            if i < len(plan):
                ka = min(i + LOOKAHEAD, len(plan) - 1)
                iks[s].step(plan.position[ka], gripper_rotation(float(plan.yaw[ka])))
        if i % every:
            continue
        for s in sides:
            plan = plans[s]
            data.qpos[qadr[s]] = iks[s].q
            w = float(np.clip(plan.opening[min(i, len(plan) - 1)], 0, robot.arms[s].max_opening))
            data.qpos[fadr[s]] = w / 2
        mujoco.mj_kinematics(model, data)
        out[i // every] = _least(model, data, ga, gb, rab, fromto)
    return out


def _least(
    model: Any, data: Any, ga: np.ndarray, gb: np.ndarray, rab: np.ndarray, fromto: np.ndarray
) -> float:
    """The least distance (at most :data:`FAR`) between geoms ``ga`` and ``gb`` (``rab``: the
    sums of their bounding spheres' radii), the pairs taken nearest bounding spheres first and
    none whose bounding spheres are farther apart than the least distance so far."""
    import mujoco

    if not ga.size or not gb.size:
        return FAR
    xpos = data.geom_xpos
    gap = np.linalg.norm(xpos[ga][:, None, :] - xpos[gb][None, :, :], axis=2) - rab
    best = FAR
    for k in np.argsort(gap, axis=None):
        i, j = divmod(int(k), len(gb))
        if gap[i, j] > best:
            break
        best = min(
            best, float(mujoco.mj_geomDistance(model, data, int(ga[i]), int(gb[j]), best, fromto))
        )
    return best


def tick_s(k: int, every: int) -> float:
    """When (s) the ``k``-th distance of :func:`arm_distances` (``every``) was measured."""
    return k * every * TICK
