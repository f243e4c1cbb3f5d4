"""Skill parameters computed for many segments at once equal those of one segment at a time."""

from __future__ import annotations

import numpy as np
from lfd.segmentation.params import poses_in_object, skill_params, skill_params_batch
from lfd.trajectory import Trajectory
from scipy.spatial.transform import Rotation


def _trajectory(n: int = 200, n_obj: int = 3, seed: int = 0) -> Trajectory:
    rng = np.random.default_rng(seed)
    rotation = Rotation.random(n, random_state=seed).as_matrix()
    rotation[::17, 0, 0] = np.nan  # hand orientation lost
    quat = rng.normal(size=(n_obj, n, 4))
    quat[:, ::13] = np.nan  # object orientation lost
    pos = rng.normal(size=(n_obj, n, 3))
    pos[1, ::29] = np.nan
    return Trajectory(
        t_ns=np.arange(n, dtype=np.int64) * 33_333_333 + 10**18,
        tcp=rng.normal(size=(n, 3)),
        rotation=rotation,
        euler=np.zeros((n, 3)),
        opening=np.zeros(n),
        keypoints=np.zeros((n, 21, 3)),
        object_names=[f"box_{k}" for k in range(n_obj)],
        object_position=pos,
        object_quaternion=quat,
        object_size=np.full((n_obj, 3), 0.05),
        hand_valid=np.ones(n, dtype=bool),
        object_valid=np.ones((n_obj, n), dtype=bool),
    )


def _pose_one(traj: Trajectory, k: int, t: int) -> tuple[np.ndarray, np.ndarray]:
    """One sample's TCP pose in an object frame, with scipy's single-rotation calls."""
    q = traj.object_quaternion[k, t]
    r_obj = Rotation.from_quat(q) if np.all(np.isfinite(q)) else Rotation.identity()
    p = r_obj.inv().apply(traj.tcp[t] - traj.object_position[k, t])
    if not np.all(np.isfinite(traj.rotation[t])):
        return p, np.full(4, np.nan)
    return p, (r_obj.inv() * Rotation.from_matrix(traj.rotation[t])).as_quat()


def test_poses_in_object_equal_scipy() -> None:
    """The engine's rotations (lfd.rotations) against scipy one rotation at a time: the same
    to a few units in the last place (the sums are ordered differently)."""
    traj = _trajectory()
    k = np.arange(len(traj)) % 3
    t = np.arange(len(traj))
    p, q = poses_in_object(traj, k, t)
    for i in range(len(traj)):
        p1, q1 = _pose_one(traj, int(k[i]), int(t[i]))
        np.testing.assert_allclose(p[i], p1, rtol=0, atol=1e-14)
        np.testing.assert_allclose(q[i], q1, rtol=0, atol=1e-14)
        assert np.isnan(q[i]).all() == np.isnan(q1).all()


def test_skill_params_batch_equal_one_at_a_time() -> None:
    traj = _trajectory()
    rng = np.random.default_rng(1)
    skills = ["pick_up", "locate", "place", "stack", "push", "move", "move_with"]
    specs = []
    for i in range(300):
        a = int(rng.integers(0, len(traj) - 1))
        b = int(rng.integers(a + 1, len(traj) + 3))  # an end past the last sample too
        obj = [None, -1, 0, 1, 2, 3][i % 6]  # none, out of range, every object
        specs.append((skills[i % len(skills)], a, b, obj))
    batch = skill_params_batch(traj, *map(list, zip(*specs, strict=True)))
    for spec, params in zip(specs, batch, strict=True):
        one = skill_params(traj, *spec)
        assert list(one) == list(params)  # same keys in the same order (the JSON's)
        assert repr(one) == repr(params)
    assert skill_params_batch(traj, [], [], [], []) == []
