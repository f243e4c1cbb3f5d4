"""Live segmentation end to end: raw messages -> causal preprocessing -> online segmenter
(``lfd.segmentation.live``), against the batch ``lfd.segment`` of the whole recording.

Run: ``MUJOCO_GL=egl python benches/segment_live.py [--seeds 300-305]
[--out /tmp/lfd_heldout_online] [--groups careful,natural]``

On the held-out simulated demos of ``benches/segment_heldout.py`` (seeds 300-305, which no
template, tuning or design choice used; three groups: careful exp1-4, fast/small/noisy exp1-4,
natural exp1-5), each recording's messages are replayed in time order (hand frames at the
estimator's rate, object poses at 30 Hz) through :class:`~lfd.segmentation.live.LiveSegmentation`,
which sees each message once, as it would arrive during the recording. Reported per group:

* **sequence**: the final live sequence of (skill, object) equals the batch one;
* **frames**: share of the batch trajectory's samples whose live skill (by time) is the batch
  one (mean, and the worst demo);
* **latency**: for the segments of demos with equal sequences, the message time at which each
  settled minus the batch segment's end (the recording's last segment, settled by its end,
  is left out); median, 95th percentile and max;
* **cost**: wall time per message of ``LiveSegmentation.push`` (preprocessing, features,
  online segmenter), median, p99 and max.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parent
sys.path.insert(0, str(ROOT))


def skill_at(segments: list[Any], t_ns: np.ndarray) -> np.ndarray:
    """The skill of each time (empty outside every segment)."""
    out = np.full(len(t_ns), "", dtype=object)
    for s in segments:
        out[(t_ns >= s.start_ns) & (t_ns < s.end_ns)] = s.skill
    if segments:  # the last segment includes the last sample
        out[t_ns == segments[-1].end_ns] = segments[-1].skill
    return out


OPTIONS: dict[str, Any] = {}
"""Settling options of the online segmenter (``--lag``, ``--beam``, ``--stable``)."""


def run_one(path: Path, templates: Any) -> dict[str, Any]:
    from lfd.io import load
    from lfd.preprocessing.online import demo_messages
    from lfd.segmentation import segment
    from lfd.segmentation.live import LiveSegmentation
    from lfd.segmentation.pipeline import as_trajectory

    demo = load(path, images=False)
    traj = as_trajectory(demo, templates.preprocessing)
    offline = segment(traj, templates)
    live = LiveSegmentation.for_demonstration(demo, templates, **OPTIONS)
    cost = []
    for msg in demo_messages(demo):
        t0 = time.perf_counter()
        live.push(msg)
        cost.append(time.perf_counter() - t0)
    live.finish()
    result = live.result()
    seq = [(s.skill, s.object) for s in result.segments]
    ref = [(s.skill, s.object) for s in offline.segments]
    frames = float(
        np.mean(skill_at(result.segments, traj.t_ns) == skill_at(offline.segments, traj.t_ns))
    )
    latency: list[float] = []
    if seq == ref:
        for s, t in list(zip(offline.segments, live.settled_ns, strict=True))[:-1]:
            latency.append((t - s.end_ns) * 1e-9)
    return {"equal": seq == ref, "frames": frames, "latency": latency, "cost": cost}


def main() -> None:
    from lfd.segmentation import Templates
    from segment_heldout import GROUPS, simulate_group

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="300-305")
    ap.add_argument("--out", type=Path, default=Path("/tmp/lfd_heldout_online"))
    ap.add_argument("--groups", default=",".join(GROUPS), help="comma-separated group names")
    ap.add_argument("--lag", type=float, help="lag_s (default: the library's)")
    ap.add_argument("--beam", type=float, help="beam (default: the library's)")
    ap.add_argument("--stable", type=float, help="stable_s (default: the library's)")
    ap.add_argument("--no-stable", action="store_true", help="stable_s=None (no leader rule)")
    ap.add_argument("--lookahead", type=float, help="lookahead_s of the fixed-lag smoother")
    ap.add_argument("--smoother", choices=("fixed-lag", "causal"), help="the preprocessor's")
    args = ap.parse_args()
    for key, value in (
        ("lag_s", args.lag),
        ("beam", args.beam),
        ("stable_s", args.stable),
        ("lookahead_s", args.lookahead),
        ("smoother", args.smoother),
    ):
        if value is not None:
            OPTIONS[key] = value
    if args.no_stable:
        OPTIONS["stable_s"] = None
    lo, _, hi = args.seeds.partition("-")
    seeds = list(range(int(lo), int(hi or lo) + 1))
    wanted = [g.strip() for g in args.groups.split(",")]
    templates = Templates.default()
    warnings.simplefilter("ignore")
    print(f"## live segmentation of held-out simulated demos (seeds {seeds[0]}-{seeds[-1]})\n")
    print(
        "group              demos  sequence  frames mean (worst)  "
        "latency med / p95 / max (s)  cost/message med / p99 / max (ms)"
    )
    totals: dict[str, list[Any]] = {"equal": [], "frames": [], "latency": [], "cost": []}
    for name, (given, tasks) in GROUPS.items():
        if name not in wanted:
            continue
        paths = simulate_group(args.out / name.replace(" ", "_"), given, tasks, seeds)
        rows = [run_one(p, templates) for p in paths]
        for p, r in zip(paths, rows, strict=True):
            if not r["equal"]:
                print(f"  differs: {p.parent.name}/{p.name} (frames {r['frames']:.3f})")
        eq = [r["equal"] for r in rows]
        fr = [r["frames"] for r in rows]
        lat = np.array([x for r in rows for x in r["latency"]])
        cost = np.array([x for r in rows for x in r["cost"]]) * 1e3
        for key, val in (("equal", eq), ("frames", fr), ("latency", lat), ("cost", cost)):
            totals[key] += list(val)
        print(
            f"{name:18s} {len(eq):5d} {sum(eq):5d}/{len(eq):<3d} {np.mean(fr):.3f} ({np.min(fr):.3f})"
            f"        {np.median(lat):.2f} / {np.percentile(lat, 95):.2f} / {np.max(lat):.2f}"
            f"           {np.median(cost):.3f} / {np.percentile(cost, 99):.2f} / {np.max(cost):.1f}"
        )
    eq, fr = totals["equal"], totals["frames"]
    lat, cost = np.array(totals["latency"]), np.array(totals["cost"])
    print(
        f"{'all':18s} {len(eq):5d} {sum(eq):5d}/{len(eq):<3d} {np.mean(fr):.3f} ({np.min(fr):.3f})"
        f"        {np.median(lat):.2f} / {np.percentile(lat, 95):.2f} / {np.max(lat):.2f}"
        f"           {np.median(cost):.3f} / {np.percentile(cost, 99):.2f} / {np.max(cost):.1f}"
    )
    print(
        f"\nsequence agreement {100 * np.mean(eq):.1f}% (target >= 95%), frame agreement "
        f"{100 * np.mean(fr):.1f}% (target >= 95%), latency median {np.median(lat):.2f} s "
        f"(target <= 1.5 s), max {np.max(lat):.2f} s (target <= 3 s)"
    )


if __name__ == "__main__":
    main()
