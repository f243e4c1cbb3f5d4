"""Per-segment Dynamic Movement Primitives (paper Eq. 6) with movement_primitives.

Each skill segment's demonstrated motion ``[x, y, z, yaw]`` is imitated by a discrete DMP
(``movement_primitives.dmp.DMP``, 15 RBF weights per dimension) and rolled out with a new start
(the robot's pose at the end of the previous segment) and a new goal (the object-relative goal
of Eq. 2, see :mod:`lfd.reproduce.goals`). movement_primitives does not scale the forcing term by
``g - y0``, so a displaced goal shifts the attractor without distorting the learned shape; with
``smooth_scaling`` (Pastor et al. 2009) the new start and goal offsets are blended in along the
phase instead of by the spring's step response, which would first pull the path back towards the
demonstrated one (a hook of several cm when the robot starts where the hand did not). Two
small fixes keep chained segments exact: the roll-out starts with the robot's velocity at the end
of the previous part (the demo's start velocity between two demonstrated segments; zero after a
dwell or a stop: a jump in velocity would jerk a carried box out of the fingers), and the residual
between the roll-out's last sample and the goal (the DMP is still converging when the demo's time
is up) is removed by a min-jerk blend.
"""

from __future__ import annotations

import numpy as np


def min_jerk(n: int) -> np.ndarray:
    """Min-jerk phase ``s`` from 0 to 1 over ``n`` samples, shape (n,)."""
    if n <= 1:
        return np.ones(max(n, 0))
    tau = np.linspace(0.0, 1.0, n)
    return 10 * tau**3 - 15 * tau**4 + 6 * tau**5


def resample(t: np.ndarray, y: np.ndarray, dt: float) -> np.ndarray:
    """Linear resampling of ``y`` (m, d) given at times ``t`` (m,) onto a ``dt`` grid."""
    t = np.asarray(t, dtype=np.float64)
    n = max(2, round((t[-1] - t[0]) / dt) + 1)
    grid = np.linspace(t[0], t[-1], n)
    return np.stack([np.interp(grid, t, y[:, j]) for j in range(y.shape[1])], axis=1)


def warp(y: np.ndarray, start: np.ndarray, goal: np.ndarray) -> np.ndarray:
    """Shift a path so it starts at ``start`` and ends at ``goal`` (min-jerk blended offsets).

    Parameters
    ----------
    y : array, shape (n, d)
    start, goal : arrays, shape (d,)
    """
    s = min_jerk(y.shape[0])[:, None]
    return y + (1 - s) * (np.asarray(start) - y[0]) + s * (np.asarray(goal) - y[-1])


def dmp_rollout(
    t: np.ndarray,
    y: np.ndarray,
    start: np.ndarray,
    goal: np.ndarray,
    *,
    dt: float = 0.01,
    n_weights: int = 15,
    start_velocity: np.ndarray | None = None,
) -> np.ndarray:
    """Learn a DMP from one demonstrated segment and roll it out to a new start and goal.

    Parameters
    ----------
    t : array, shape (m,)
        Sample times of the demonstrated segment (s).
    y : array, shape (m, d)
        Demonstrated states (e.g. ``[x, y, z, yaw]``).
    start, goal : arrays, shape (d,)
        New start and goal.
    dt : float
        Output sample period (s).
    start_velocity : array, shape (d,), optional
        Velocity the roll-out starts with: the robot's at the end of what it did before (zero
        after a dwell or a stop); default the demonstrated segment's start velocity.

    Returns
    -------
    array, shape (n, d)
        The generalised path at ``dt`` spacing; first sample = ``start``, last = ``goal``.
    """
    from movement_primitives.dmp import DMP

    t = np.asarray(t, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    if y.ndim != 2 or y.shape[0] != t.shape[0]:
        raise ValueError(f"y must have shape ({t.shape[0]}, d), got {y.shape}")
    duration = float(t[-1] - t[0])
    if y.shape[0] < 4 or duration < 5 * dt:
        lin = resample(t, y, dt) if y.shape[0] >= 2 else np.repeat(y, 2, axis=0)
        return warp(lin, start, goal)
    tt = t - t[0]
    yd = np.gradient(y, tt, axis=0)
    dmp = DMP(
        n_dims=y.shape[1],
        execution_time=duration,
        dt=dt,
        n_weights_per_dim=n_weights,
        smooth_scaling=True,
    )
    dmp.imitate(tt, y, allow_final_velocity=True)
    dmp.configure(
        start_y=np.asarray(start),
        goal_y=np.asarray(goal),
        start_yd=yd[0] if start_velocity is None else np.asarray(start_velocity, dtype=np.float64),
        goal_yd=yd[-1],
    )
    _, out = dmp.open_loop()
    out = np.asarray(out, dtype=np.float64)
    if not np.all(np.isfinite(out)):
        return warp(resample(t, y, dt), start, goal)
    return warp(out, start, goal)
