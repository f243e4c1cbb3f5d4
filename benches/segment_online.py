"""The online segmenter (``lfd.segmentation.online``): update cost per sample, its growth with
the demonstration's length, settling latency, and agreement with the batch segmentation.

Run: ``MUJOCO_GL=egl python benches/segment_online.py [--minutes 10] [--seeds 300-305]
[--out /tmp/lfd_heldout_online] [--skip-heldout]``

1. **Cost.** A ``--minutes`` long demonstration with 3 objects (the natural-style ``exp5``
   recordings end to end, as ``benches/segment_memory.py`` builds it; the hand at 30 Hz) is
   preprocessed and its batch features computed, then fed sample by sample. The *engine* cost of
   a sample is the time spent in the compiled ``lfd._hmmseg.OnlineSegmenter`` for it (stage 1,
   the forward states of every start section, the DP step, the agreement check); the *driver*
   cost is the whole ``OnlineSegmenter.push`` (co-motion evidence, object choice, segments and
   their parameters in Python). Median, p99 and max, overall and per minute of the
   demonstration (the cost must not grow with the length).
2. **Latency.** Each segment's settling time minus its end, for the segments equal to a batch
   segment (skill, samples, object), and the sequence agreement on the long demonstration.
3. **Agreement.** On held-out simulated demos (seeds 300-305 of ``benches/segment_heldout.py``'s
   three groups: careful exp1-4, fast/small/noisy exp1-4, natural exp1-5): the final online
   sequence equal to the batch one (skills, samples and objects, and skills only), the frame
   agreement (share of samples with the same skill), and the latency.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parent
sys.path.insert(0, str(ROOT))


class TimedEngine:
    """The compiled online segmenter with the time spent in it accumulated."""

    def __init__(self, inner: Any):
        self.inner = inner
        self.spent = 0.0

    def __getattr__(self, name: str) -> Any:
        attr = getattr(self.inner, name)
        if not callable(attr):
            return attr

        def timed(*a: Any, **kw: Any) -> Any:
            t0 = time.perf_counter()
            try:
                return attr(*a, **kw)
            finally:
                self.spent += time.perf_counter() - t0

        return timed


def feed(traj: Any, templates: Any, **kw: Any) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray]:
    """Feed a trajectory sample by sample (batch features); returns the online segmenter, the
    settle times (s) of its segments, and the engine and driver cost of each sample (s)."""
    from lfd.segmentation.gaps import fill_gaps
    from lfd.segmentation.online import OnlineSegmenter, batch_samples

    filled, _ = fill_gaps(traj)
    seg = OnlineSegmenter(templates, filled.object_names, filled.dt, **kw)
    eng = TimedEngine(seg._engine)
    seg._engine = eng  # type: ignore[assignment]
    n = len(filled)
    engine_s, driver_s = np.zeros(n), np.zeros(n)
    for t, sample in enumerate(batch_samples(filled)):
        before = eng.spent
        t0 = time.perf_counter()
        seg.push(**sample)
        driver_s[t] = time.perf_counter() - t0
        engine_s[t] = eng.spent - before
    seg.finish()
    settle = np.asarray(seg.settle_samples, dtype=np.float64) * filled.dt
    return seg, settle, engine_s, driver_s


def frames(segments: list[Any], n: int) -> np.ndarray:
    out = np.full(n, "", dtype=object)
    for s in segments:
        out[s.start : s.end] = s.skill
    return out


def compare(online: list[Any], offline: list[Any], settle: np.ndarray, n: int) -> dict[str, Any]:
    key = [(s.skill, s.start, s.end, s.object) for s in online]
    ref = [(s.skill, s.start, s.end, s.object) for s in offline]
    ref_set = set(ref)
    lat = [st - s.end_s for s, k, st in zip(online, key, settle, strict=True) if k in ref_set]
    return {
        "equal": key == ref,
        "skills_equal": [s.skill for s in online] == [s.skill for s in offline],
        "frames": float(np.mean(frames(online, n) == frames(offline, n))),
        "latency": lat,
    }


def ms(x: np.ndarray) -> str:
    return f"{np.median(x) * 1e3:7.3f} {np.percentile(x, 99) * 1e3:7.3f} {np.max(x) * 1e3:7.2f}"


OPTIONS: dict[str, Any] = {}
"""Options of the online segmenter (``--lag``, ``--beam``)."""


def cost(minutes: float) -> None:
    from lfd.segmentation import Templates, segment
    from lfd.segmentation.pipeline import as_trajectory
    from segment_memory import long_demo

    templates = Templates.default()
    traj = as_trajectory(long_demo(minutes))
    n = len(traj)
    print(
        f"## {minutes:g}-minute demonstration: {n} samples at {1 / traj.dt:.0f} Hz, "
        f"{len(traj.object_names)} objects\n"
    )
    t0 = time.perf_counter()
    seg, settle, engine_s, driver_s = feed(traj, templates, **OPTIONS)
    online_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    offline = segment(traj, templates)
    offline_s = time.perf_counter() - t0
    print("cost per sample (ms)        median     p99     max")
    print(f"engine (lfd._hmmseg)       {ms(engine_s)}")
    print(f"driver (OnlineSegmenter.push) {ms(driver_s)}")
    print(f"\nwhole stream online {online_s:.1f} s, batch lfd.segment {offline_s:.1f} s\n")
    per_min = round(60 / traj.dt)
    print("minute   engine median  p99     max | driver median  p99     max   (ms)")
    for m in range(int(np.ceil(n / per_min))):
        sl = slice(m * per_min, min(n, (m + 1) * per_min))
        print(f"{m:4d}-{m + 1:<4d}     {ms(engine_s[sl])} |        {ms(driver_s[sl])}")
    c = compare(seg.segments, offline.segments, settle, n)
    lat = np.asarray(c["latency"])
    print(
        f"\nsegments: online {len(seg.segments)}, batch {len(offline.segments)}; sequence equal: "
        f"{c['equal']} (skills only: {c['skills_equal']}); frame agreement {c['frames']:.4f}; "
        f"forced by the lag: {seg.forced}"
    )
    print(
        f"settle latency after the batch segment's end ({len(lat)} equal segments): median "
        f"{np.median(lat):.2f} s, p95 {np.percentile(lat, 95):.2f} s, max {np.max(lat):.2f} s\n"
    )


def heldout(out: Path, seeds: list[int]) -> None:
    from lfd.io import load
    from lfd.segmentation import Templates, segment
    from lfd.segmentation.pipeline import as_trajectory
    from segment_heldout import GROUPS, simulate_group

    templates = Templates.default()
    print(f"## held-out simulated demos (seeds {seeds[0]}-{seeds[-1]})\n")
    print("group              demos  equal  skills equal  frame agr. (min)  latency med / max (s)")
    all_eq, all_frames, all_lat = [], [], []
    for name, (given, tasks) in GROUPS.items():
        paths = simulate_group(out / name.replace(" ", "_"), given, tasks, seeds)
        eq, sk, fr, lat = [], [], [], []
        for p in paths:
            traj = as_trajectory(load(p, images=False))
            offline = segment(traj, templates)
            seg, settle, _, _ = feed(traj, templates, **OPTIONS)
            c = compare(seg.segments, offline.segments, settle, len(traj))
            eq.append(c["equal"])
            sk.append(c["skills_equal"])
            fr.append(c["frames"])
            lat += c["latency"]
            if not c["equal"]:
                print(f"  differs: {p.name}")
        all_eq += eq
        all_frames += fr
        all_lat += lat
        print(
            f"{name:18s} {len(eq):5d} {sum(eq):6d} {sum(sk):13d}  {np.mean(fr):.4f} "
            f"({np.min(fr):.4f})   {np.median(lat):.2f} / {np.max(lat):.2f}"
        )
    print(
        f"{'all':18s} {len(all_eq):5d} {sum(all_eq):6d} ({100 * np.mean(all_eq):.1f}%)"
        f"         {np.mean(all_frames):.4f} ({np.min(all_frames):.4f})   "
        f"{np.median(all_lat):.2f} / {np.max(all_lat):.2f}"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--minutes", type=float, default=10.0)
    ap.add_argument("--seeds", default="300-305")
    ap.add_argument("--out", type=Path, default=Path("/tmp/lfd_heldout_online"))
    ap.add_argument("--lag", type=float, default=None, help="lag_s (default: the library's)")
    ap.add_argument("--beam", type=float, default=None, help="beam (default: the library's)")
    ap.add_argument("--stable", type=float, default=None, help="stable_s (default: the library's)")
    ap.add_argument("--no-stable", action="store_true", help="stable_s=None")
    ap.add_argument("--skip-cost", action="store_true")
    ap.add_argument("--skip-heldout", action="store_true")
    args = ap.parse_args()
    from segment_heldout import seeds_of

    if args.lag is not None:
        OPTIONS["lag_s"] = args.lag
    if args.beam is not None:
        OPTIONS["beam"] = args.beam
    if args.stable is not None:
        OPTIONS["stable_s"] = args.stable
    if args.no_stable:
        OPTIONS["stable_s"] = None

    if not args.skip_cost:
        cost(args.minutes)
    if not args.skip_heldout:
        heldout(args.out, seeds_of(args.seeds))


if __name__ == "__main__":
    main()
