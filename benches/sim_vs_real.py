"""How the natural simulated demonstrator compares with real human motion (docs/skills.md).

Run: ``MUJOCO_GL=egl python benches/sim_vs_real.py [DIR] [--seeds N] [--json OUT]`` (DIR:
``../shared/realmotion`` beside the repository; without it the bench says it skipped and exits
0).

The same statistics are measured, by the same code, on the 8 real crops of DIR
(``manip_<seq>_<t0>-<t1>s.mcap``: one right hand, optical motion capture, CC-BY-NC 4.0 — read
there, never copied; nothing here is saved into the repository) and on natural simulated
demonstrations of ``exp1``, ``exp4`` and ``exp5`` (seeds 500...; written to a temporary folder
and read back like a recording): every recording goes through ``lfd.load`` and
``lfd.preprocess`` and is measured against its ground-truth labels, distances to objects with
``lfd.contact.box_distance``:

- per-skill label durations;
- grasp -> lift-off: from the end of a Pick up to its object 1 cm above where it rested;
- hover before a reach: the time, in the Move before a Pick up, during which the TCP stayed
  6-15 cm from the object's box up to where it was last 8 cm away (where the Pick up starts; a
  hovering hand dips below 8 cm now and then, so the band reaches down to 6 cm; a re-grasp that
  never leaves the object has no hover);
- turn / slide before lifting: the object's yaw change and horizontal travel during a Pick up
  (and the largest of each per recording: the sims have many quick re-grasps);
- lift height: the highest the object gets in a Move with, above where it rested;
- TCP offset from the box centre while carrying (median per Move with);
- peak TCP speed per skill (and per recording).

Each row prints the median and the 10 / 90 % quantiles over the recordings' instances.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
import tempfile
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_DIR = ROOT.parent / "shared" / "realmotion"
CROP = re.compile(r"_\d+(\.\d+)?-\d+(\.\d+)?s\.mcap$")
SIM_TASKS = ("exp1", "exp4", "exp5")
HOVER_M = 0.15
NEAR_M = 0.06
APPROACH_M = 0.08
LIFT_M = 0.01
SPEED_SKILLS = ("pick_up", "move_with", "place", "move")


def _yaw(q: np.ndarray) -> np.ndarray:
    """Yaw (rad) of quaternions ``(n, 4)`` (x, y, z, w)."""
    x, y, z, w = q.T
    return np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def _index(t_ns: np.ndarray, ns: int) -> int:
    return int(np.clip(np.searchsorted(t_ns, ns), 0, len(t_ns) - 1))


def measure(demo: Any) -> dict[str, list[float]]:
    """Every statistic's instances in one labelled recording."""
    import lfd
    from lfd.contact import box_distance

    traj = lfd.preprocess(demo)
    t = traj.t_s
    tcp = np.asarray(traj.tcp, float)
    speed = np.r_[0.0, np.linalg.norm(np.diff(tcp, axis=0), axis=1) / traj.dt]
    out: dict[str, list[float]] = defaultdict(list)
    labels = sorted(demo.labels, key=lambda lab: lab.start_ns)
    spans = [
        (lab, _index(traj.t_ns, lab.start_ns), max(_index(traj.t_ns, lab.end_ns), 1))
        for lab in labels
    ]
    out["peak TCP speed, recording (m/s)"].append(float(speed.max()))
    turns: list[float] = []
    slides: list[float] = []
    for k, (lab, a, b) in enumerate(spans):
        out[f"duration {lab.skill} (s)"].append((lab.end_ns - lab.start_ns) / 1e9)
        if lab.skill in SPEED_SKILLS and b > a:
            out[f"peak TCP speed {lab.skill} (m/s)"].append(float(speed[a:b].max()))
        if lab.object not in traj.object_names:
            continue
        o = traj.object_names.index(lab.object)
        pos, quat = traj.object_position[o], traj.object_quaternion[o]
        if lab.skill == "pick_up":
            prev = spans[k - 1] if k > 0 else None
            if prev is not None and prev[0].skill == "move":  # a reach from elsewhere
                d = box_distance(tcp, pos, quat, traj.object_size[o])
                far = np.flatnonzero(d[prev[1] : a + 1] >= APPROACH_M)
                i = j = prev[1] + int(far[-1]) if far.size else a
                while i > prev[1] and NEAR_M <= d[i - 1] <= HOVER_M:
                    i -= 1
                out["hover 6-15 cm before the reach (s)"].append(float(t[j] - t[i]))
            turn = np.unwrap(_yaw(quat[a : b + 1]))
            turns.append(float(np.rad2deg(np.ptp(turn))))
            slide = np.linalg.norm(pos[a : b + 1, :2] - pos[a, :2], axis=1)
            slides.append(float(100 * slide.max()))
            nxt = spans[k + 1] if k + 1 < len(spans) else None
            if nxt is not None and nxt[0].skill == "move_with":
                z0 = pos[b, 2]
                up = np.flatnonzero(pos[b : nxt[2] + 1, 2] > z0 + LIFT_M)
                if up.size:
                    out["pick_up end -> object 1 cm up (s)"].append(float(t[b + up[0]] - t[b]))
        elif lab.skill == "move_with" and b > a:
            rest = pos[a, 2]
            out["lift height (cm)"].append(float(100 * (pos[a:b, 2].max() - rest)))
            off = np.linalg.norm(tcp[a:b] - pos[a:b], axis=1)
            out["TCP - box centre while carrying (cm)"].append(float(100 * np.median(off)))
    out["turn during pick_up (deg)"] += turns
    out["slide during pick_up (cm)"] += slides
    if turns:
        out["turn during pick_up, largest per recording (deg)"].append(max(turns))
        out["slide during pick_up, largest per recording (cm)"].append(max(slides))
    return out


def merge(into: dict[str, list[float]], more: dict[str, list[float]]) -> None:
    for key, values in more.items():
        into.setdefault(key, []).extend(values)


def real_stats(folder: Path) -> tuple[dict[str, list[float]], int]:
    import lfd

    stats: dict[str, list[float]] = {}
    files = [p for p in sorted(folder.glob("manip_*.mcap")) if CROP.search(p.name)]
    for path in files:
        merge(stats, measure(lfd.load(path, images=False)))
    return stats, len(files)


def sim_stats(seeds: int) -> tuple[dict[str, list[float]], int]:
    import lfd
    from lfd.sim import Variability, simulate

    stats: dict[str, list[float]] = {}
    n = 0
    with tempfile.TemporaryDirectory() as tmp:
        for task in SIM_TASKS:
            for seed in range(500, 500 + seeds):
                path = Path(tmp) / f"{task}_{seed}.mcap"
                lfd.save(simulate(task, seed, Variability(style="natural")).demo, path)
                merge(stats, measure(lfd.load(path, images=False)))
                n += 1
    return stats, n


def _summary(values: list[float]) -> str:
    if not values:
        return "-"
    q10, q50, q90 = np.percentile(values, [10, 50, 90])
    return f"{q50:6.2f} [{q10:5.2f}, {q90:5.2f}] n={len(values)}"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dir", nargs="?", type=Path, default=DEFAULT_DIR)
    ap.add_argument("--seeds", type=int, default=8, help="seeds per simulated task (500...)")
    ap.add_argument("--json", type=Path, help="write the instances here (outside the repo)")
    args = ap.parse_args()
    if not args.dir.is_dir():
        print(f"sim_vs_real: skipped: no real recordings in {args.dir}")
        return 0
    real, n_real = real_stats(args.dir)
    if not n_real:
        print(f"sim_vs_real: skipped: no crops manip_*_<t0>-<t1>s.mcap in {args.dir}")
        return 0
    sim, n_sim = sim_stats(args.seeds)
    keys = sorted(set(real) | set(sim), key=lambda k: (not k.startswith("duration"), k))
    head = f"{'median [10 %, 90 %]':40s} {'real crops (' + str(n_real) + ')':32s} "
    print(head + f"natural sim ({n_sim}: {', '.join(SIM_TASKS)})")
    for key in keys:
        print(f"{key:40s} {_summary(real.get(key, [])):32s} {_summary(sim.get(key, []))}")
    if args.json:
        args.json.write_text(json.dumps({"real": real, "sim": sim}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
