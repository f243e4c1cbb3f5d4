"""How the natural simulated demonstrator compares with real human motion (docs/skills.md).

Run: ``MUJOCO_GL=egl python benches/sim_vs_real.py [DIR] [--labels LABELS] [--seeds N]
[--tasks exp1,exp4,exp5] [--per-task] [--json OUT]`` (DIR: ``../shared/realmotion`` beside the
repository; without it the bench says it skipped and exits 0).

The same statistics are measured, by the same code, on real motion capture of DIR (ManipNet,
optical motion capture, CC-BY-NC 4.0 — read there, never copied; nothing here is saved into the
repository) and on natural simulated demonstrations of ``--tasks`` (seeds 500...; written to a
temporary folder and read back like a recording). Two real sets:

- **crops**: the 8 crops ``manip_<seq>_<t0>-<t1>s.mcap`` (one right hand handles the object);
- **whole files, per hand**: every whole sequence of ``DIR/bimanual`` once per hand
  (``manip_<seq>.{right,left}.mcap``, 33-53 s, many repeated cycles), labelled by ``LABELS``
  (``manip_<seq>.<side>.labels.json``, seconds from the first sample: corrected labels kept
  outside the repository) where it has them, else by the file's own labels; without
  ``DIR/bimanual``, the whole right-hand files ``manip_<seq>.mcap`` of DIR.

Every recording goes through ``lfd.load`` and ``lfd.preprocess`` (object positions low-passed at
the segmentation's ``OBJECT_CUTOFF_HZ``, 10 Hz, not at the hand's 0.625 Hz, which lowers a quick
lift by half) and is measured against its labels, distances to objects with ``lfd.contact.box_distance``:

- per-skill label durations (``duration move_with`` is the carry duration);
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

Repeated cycles (a cycle is a Move with; "between two cycles" is from the end of a Place or
Stack to the end of the next Pick up of the same object, its grasp):

- cycles per object per minute (objects carried at least once; whole recording);
- short low carries: the share of Move withs that last <= 0.8 s and rise <= 10 cm (the issue's
  missed carries last a median 0.37 s and rise 6.6 cm);
- re-grasps: the share of reaches (Pick ups) before which the TCP never went 8 cm from the
  object's box since it was put down; re-lifts: the share where it never went 3 cm away (put
  down and lifted again without the hand leaving it);
- release -> next grasp: the time between two cycles of one object;
- turn in the hand: the object's yaw range during a Move with, and the yaw it gained from the
  start of one cycle's Pick up to the end of its Place (at rest to at rest).

Rows named ``share`` print the mean (%) and the count; the others the median and the 10 / 90 %
quantiles over the recordings' instances.
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
RELIFT_M = 0.03
LIFT_M = 0.01
SHORT_S = 0.8
LOW_CM = 10.0
SPEED_SKILLS = ("pick_up", "move_with", "place", "move")


def _yaw(q: np.ndarray) -> np.ndarray:
    """Yaw (rad) of quaternions ``(n, 4)`` (x, y, z, w)."""
    x, y, z, w = q.T
    return np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def _index(t_ns: np.ndarray, ns: int) -> int:
    return int(np.clip(np.searchsorted(t_ns, ns), 0, len(t_ns) - 1))


def _carry(
    out: dict[str, list[float]], dur: float, pos: np.ndarray, yaw: np.ndarray, tcp: np.ndarray
) -> None:
    """The statistics of one Move with (its object's positions, unwrapped yaw and the TCP)."""
    rise = float(100 * (pos[:, 2].max() - pos[0, 2]))
    out["lift height (cm)"].append(rise)
    out["share short low carries <= 0.8 s, <= 10 cm (%)"].append(
        float(dur <= SHORT_S and rise <= LOW_CM)
    )
    out["turn in the hand during a carry (deg)"].append(float(np.rad2deg(np.ptp(yaw))))
    off = np.linalg.norm(tcp - pos, axis=1)
    out["TCP - box centre while carrying (cm)"].append(float(100 * np.median(off)))


def measure(demo: Any) -> dict[str, list[float]]:
    """Every statistic's instances in one labelled recording."""
    import lfd
    from lfd.contact import box_distance
    from lfd.segmentation.templates import OBJECT_CUTOFF_HZ

    traj = lfd.preprocess(demo, object_cutoff_hz=OBJECT_CUTOFF_HZ)
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
    carries: dict[str, int] = defaultdict(int)
    put_down: dict[str, int] = {}  # object -> frame its last Place / Stack ended
    cycle_start: dict[str, int] = {}  # object -> frame its current cycle's Pick up started
    for k, (lab, a, b) in enumerate(spans):
        out[f"duration {lab.skill} (s)"].append((lab.end_ns - lab.start_ns) / 1e9)
        if lab.skill in SPEED_SKILLS and b > a:
            out[f"peak TCP speed {lab.skill} (m/s)"].append(float(speed[a:b].max()))
        if lab.object not in traj.object_names:
            continue
        o = traj.object_names.index(lab.object)
        pos, quat = traj.object_position[o], traj.object_quaternion[o]
        yaw = np.unwrap(_yaw(quat))
        if lab.skill == "pick_up":
            d = box_distance(tcp, pos, quat, traj.object_size[o])
            prev = spans[k - 1] if k > 0 else None
            if prev is not None and prev[0].skill == "move":  # a reach from elsewhere
                far = np.flatnonzero(d[prev[1] : a + 1] >= APPROACH_M)
                i = j = prev[1] + int(far[-1]) if far.size else a
                while i > prev[1] and NEAR_M <= d[i - 1] <= HOVER_M:
                    i -= 1
                out["hover 6-15 cm before the reach (s)"].append(float(t[j] - t[i]))
            since = put_down.pop(lab.object, None)
            gap = d[since : a + 1] if since is not None else np.array([np.inf])
            out["share re-grasps: TCP < 8 cm between cycles (% of reaches)"].append(
                float(gap.max() < APPROACH_M)
            )
            out["share re-lifts: TCP < 3 cm between cycles (% of reaches)"].append(
                float(gap.max() < RELIFT_M)
            )
            if since is not None:
                out["release -> next grasp (s)"].append(float(t[b] - t[since]))
            cycle_start[lab.object] = a
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
            carries[lab.object] += 1
            _carry(out, (lab.end_ns - lab.start_ns) / 1e9, pos[a:b], yaw[a : b + 1], tcp[a:b])
        elif lab.skill in ("place", "stack"):
            put_down[lab.object] = b
            c0 = cycle_start.pop(lab.object, None)
            if c0 is not None:
                out["yaw gained per cycle, rest to rest (deg)"].append(
                    float(np.rad2deg(abs(yaw[b] - yaw[c0])))
                )
    minutes = max(float(t[-1] - t[0]), 1e-9) / 60.0
    for n in carries.values():
        out["cycles per object per minute"].append(n / minutes)
    out["turn during pick_up (deg)"] += turns
    out["slide during pick_up (cm)"] += slides
    if turns:
        out["turn during pick_up, largest per recording (deg)"].append(max(turns))
        out["slide during pick_up, largest per recording (cm)"].append(max(slides))
    return out


def merge(into: dict[str, list[float]], more: dict[str, list[float]]) -> None:
    for key, values in more.items():
        into.setdefault(key, []).extend(values)


def relabelled(demo: Any, labels: Path) -> Any:
    """``demo`` with the labels of the file ``labels`` (seconds from its first sample)."""
    from lfd.demo import SkillLabel

    t0 = demo.start_ns
    demo.labels = [
        SkillLabel(x["skill"], t0 + round(x["start_s"] * 1e9), t0 + round(x["end_s"] * 1e9),
                   x.get("object"))
        for x in json.loads(labels.read_text())
    ]  # fmt: skip
    return demo


def real_stats(folder: Path) -> tuple[dict[str, list[float]], int]:
    """The crops of ``folder``."""
    import lfd

    stats: dict[str, list[float]] = {}
    files = [p for p in sorted(folder.glob("manip_*.mcap")) if CROP.search(p.name)]
    for path in files:
        merge(stats, measure(lfd.load(path, images=False)))
    return stats, len(files)


def whole_stats(folder: Path, labels: Path | None) -> tuple[dict[str, list[float]], int, str]:
    """The whole files of ``folder``: per hand from ``folder/bimanual`` (with the labels of
    ``labels`` where it has them), else the right-hand whole files of ``folder``."""
    import lfd

    stats: dict[str, list[float]] = {}
    files = sorted((folder / "bimanual").glob("manip_*.*.mcap"))
    what = "whole files per hand"
    if not files:
        files = [p for p in sorted(folder.glob("manip_*.mcap")) if not CROP.search(p.name)]
        what = "whole files, right hand"
    relabelled_n = 0
    for path in files:
        demo = lfd.load(path, images=False)
        got = labels / path.name.replace(".mcap", ".labels.json") if labels else None
        if got is not None and got.is_file():
            demo = relabelled(demo, got)
            relabelled_n += 1
        merge(stats, measure(demo))
    if relabelled_n:
        what += f", {relabelled_n} relabelled"
    return stats, len(files), what


def sim_stats(tasks: tuple[str, ...], seeds: int) -> dict[str, dict[str, list[float]]]:
    """Per task, the statistics of natural demonstrations at seeds 500..."""
    import lfd
    from lfd.sim import Variability, simulate

    stats: dict[str, dict[str, list[float]]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for task in tasks:
            stats[task] = {}
            for seed in range(500, 500 + seeds):
                path = Path(tmp) / f"{task}_{seed}.mcap"
                lfd.save(simulate(task, seed, Variability(style="natural")).demo, path)
                merge(stats[task], measure(lfd.load(path, images=False)))
    return stats


def _summary(key: str, values: list[float]) -> str:
    if not values:
        return "-"
    if key.startswith("share"):
        return f"{100 * np.mean(values):6.1f} % n={len(values)}"
    q10, q50, q90 = np.percentile(values, [10, 50, 90])
    return f"{q50:6.2f} [{q10:5.2f}, {q90:5.2f}] n={len(values)}"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dir", nargs="?", type=Path, default=DEFAULT_DIR)
    ap.add_argument("--labels", type=Path, help="corrected per-hand labels (outside the repo)")
    ap.add_argument("--seeds", type=int, default=8, help="seeds per simulated task (500...)")
    ap.add_argument("--tasks", default=",".join(SIM_TASKS), help="simulated tasks (natural)")
    ap.add_argument("--per-task", action="store_true", help="one column per simulated task")
    ap.add_argument("--json", type=Path, help="write the instances here (outside the repo)")
    args = ap.parse_args()
    if not args.dir.is_dir():
        print(f"sim_vs_real: skipped: no real recordings in {args.dir}")
        return 0
    real, n_real = real_stats(args.dir)
    whole, n_whole, what = whole_stats(args.dir, args.labels)
    if not n_real and not n_whole:
        print(f"sim_vs_real: skipped: no ManipNet recordings manip_*.mcap in {args.dir}")
        return 0
    tasks = tuple(x for x in args.tasks.split(",") if x)
    per_task = sim_stats(tasks, args.seeds)
    columns = {f"real crops ({n_real})": real, f"real {what} ({n_whole})": whole}
    if args.per_task:
        columns.update({f"sim {task} ({args.seeds})": st for task, st in per_task.items()})
    else:
        sim: dict[str, list[float]] = {}
        for st in per_task.values():
            merge(sim, st)
        columns[f"natural sim ({len(tasks) * args.seeds}: {', '.join(tasks)})"] = sim
    keys = sorted(
        {k for st in columns.values() for k in st},
        key=lambda k: (not k.startswith("duration"), k),
    )
    print(f"{'median [10 %, 90 %]':58s} " + " ".join(f"{c:32s}" for c in columns))
    for key in keys:
        print(
            f"{key:58s} "
            + " ".join(f"{_summary(key, st.get(key, [])):32s}" for st in columns.values())
        )
    if args.json:
        args.json.write_text(json.dumps(columns, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
