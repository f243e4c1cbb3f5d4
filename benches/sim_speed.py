"""How fast the simulated demonstrator generates and renders demonstrations.

Run: ``MUJOCO_GL=egl python benches/sim_speed.py``.
"""

from __future__ import annotations

import os
import time

import numpy as np

os.environ.setdefault("MUJOCO_GL", "egl")


def main() -> None:
    from lfd.sim import simulate
    from lfd.sim.render import render_frames

    for task in ("exp1", "exp4", "pick_up"):
        times, sim_s = [], []
        for seed in range(5):
            t0 = time.perf_counter()
            res = simulate(task, seed=seed)
            times.append(time.perf_counter() - t0)
            sim_s.append(res.demo.duration_s)
        print(
            f"{task:8s} {np.median(times) * 1e3:6.0f} ms per demo "
            f"({np.mean(sim_s):.1f} s demo, {np.mean(sim_s) / np.median(times):.0f}x real time)"
        )
    res = simulate("exp1", seed=0)
    frames = np.arange(0, 120, 2)
    for depth in (False, True):
        t0 = time.perf_counter()
        render_frames(res.scene, res.truth, frames, depth=depth)
        dt = time.perf_counter() - t0
        print(f"render 640x480 {'colour+depth' if depth else 'colour'}: {frames.size / dt:.1f} fps")


if __name__ == "__main__":
    main()
