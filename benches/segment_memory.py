"""Memory and time of ``lfd segment`` against the demonstration's length.

Long demonstrations are built from the shipped natural-style ``exp5`` recordings
(``recordings/templates/natural/exp5_*.mcap``, 18-25 s of repeated lifts each, the hand at 30 Hz)
played end to end with shifted timestamps and labels, until the wanted length; each is written
to an MCAP file and segmented by ``lfd segment FILE --json OUT`` in a subprocess, whose wall time
and peak resident memory (``ru_maxrss`` from ``os.wait4``, in a small launcher process) are
measured.

The stage-2 score tables are banded (runs of at most ``max_segment_s``, ``hmmseg::segment::Band``):
memory and time grow linearly with the length. For comparison the table prints what the dense
``(K, K + 1, S)`` tables of the previous implementation need: one table of ``K (K + 1) S``
float64 (``dense table``), of which the pipeline held about ``3 O + 3`` at once for ``O``
target objects (``dense est.``: the co-motion penalty, the per-object scores and their sum with
it, the shared-feature table, the maximum and the arg-maximum). ``--reference PYTHONPATH`` also measures an older
checkout's ``lfd segment`` (e.g. ``git worktree add /tmp/old <commit>`` with its compiled
engine) on the lengths up to ``--reference-max-min``.

Run: ``python benches/segment_memory.py`` (defaults: 5, 15, 30 and 60 minutes). Measured on
the 2-core development machine under load about 1 (docs/segmentation.md, "Memory"):

    minutes  samples  sections    runs  seconds  peak MB  dense table MB  dense est. MB
          5     9086      1412   64356      4.7      191             107           1279
         15    27246      4237  195396     11.1      325             959          11508
         30    54479      8473  391918     22.4      499            3835          46015
         60   108415     16855  780233     38.2      833          15173         182076

The dense implementation measured on the same files: 19.9 s / 1468 MB (5 min), 122 s /
11870 MB (15 min), with byte-identical JSON.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SOURCES = sorted((ROOT / "recordings" / "templates" / "natural").glob("exp5_*.mcap"))


def long_demo(minutes: float):  # -> Demonstration
    """The exp5 natural recordings end to end (cycled) until ``minutes`` of demonstration."""
    from lfd.demo import Demonstration, HandTrack, ObjectTrack, SkillLabel
    from lfd.io import load

    parts = [load(p, images=False) for p in SOURCES]
    names = list(parts[0].objects)
    if any(list(p.objects) != names for p in parts):
        raise SystemExit("the exp5 recordings do not share their objects")
    want_ns = int(minutes * 60e9)
    hand_t, kp, conf, vis = [], [], [], []
    obj: dict[str, dict[str, list[np.ndarray]]] = {
        n: {"t": [], "p": [], "q": [], "v": []} for n in names
    }
    labels: list[SkillLabel] = []
    offset, start, k = 0, parts[0].start_ns, 0
    while True:
        d = parts[k % len(parts)]
        shift = offset - (d.start_ns - start)
        hand_t.append(d.hand.t_ns + shift)
        kp.append(d.hand.keypoints)
        conf.append(d.hand.confidence)
        vis.append(d.hand.visible)
        for n in names:
            o = d.objects[n]
            obj[n]["t"].append(o.t_ns + shift)
            obj[n]["p"].append(o.position)
            obj[n]["q"].append(o.quaternion)
            obj[n]["v"].append(o.visible)
        labels += [
            SkillLabel(lab.skill, lab.start_ns + shift, lab.end_ns + shift, lab.object)
            for lab in d.labels
        ]
        # the next copy starts one hand frame after this one ends
        offset += d.end_ns - d.start_ns + int(np.median(np.diff(d.hand.t_ns)))
        k += 1
        if offset >= want_ns:
            break
    first = parts[0]
    objects = {
        n: ObjectTrack(
            n,
            first.objects[n].tag_id,
            first.objects[n].size,
            np.concatenate(obj[n]["t"]),
            np.concatenate(obj[n]["p"]),
            np.concatenate(obj[n]["q"]),
            np.concatenate(obj[n]["v"]),
        )
        for n in names
    }
    hand = HandTrack(
        np.concatenate(hand_t),
        np.concatenate(kp),
        np.concatenate(conf),
        first.hand.side,
        np.concatenate(vis),
    )
    meta = {key: v for key, v in first.metadata.items() if key != "load_report"}
    meta["note"] = f"{k} exp5 natural recordings end to end (benches/segment_memory.py)"
    return Demonstration(hand, objects, labels, first.camera, metadata=meta)


LAUNCH = """
import os, subprocess, sys, time
t0 = time.perf_counter()
p = subprocess.Popen(sys.argv[1:], stdout=subprocess.DEVNULL, stderr=sys.stderr)
_, status, usage = os.wait4(p.pid, 0)
print(time.perf_counter() - t0, usage.ru_maxrss, os.waitstatus_to_exitcode(status))
"""
"""Runs a command, printing its wall seconds, peak RSS (KiB) and exit status. The command is
started from this small process, not from the benchmark: a child forked from a process that
holds an hour's arrays counts the parent's resident pages in its own peak until it execs."""


def measure(cmd: list[str], env: dict[str, str] | None = None) -> tuple[float, float, int, str]:
    """Run ``cmd`` (stdout discarded): wall seconds, peak RSS in MB, exit status, and the last
    line of its stderr."""
    proc = subprocess.run(
        [sys.executable, "-c", LAUNCH, *cmd], env=env, capture_output=True, text=True
    )
    wall, kib, status = proc.stdout.split()
    tail = proc.stderr.strip().splitlines()[-1:] or ["?"]
    return float(wall), int(kib) / 1024.0, int(status), tail[0]


def run_segment(path: Path, out: Path, pythonpath: str | None = None) -> tuple[float, float]:
    """``lfd segment path --json out`` in a subprocess: (wall seconds, peak RSS in MB)."""
    env = dict(os.environ)
    if pythonpath is not None:
        env["PYTHONPATH"] = pythonpath
    cmd = [sys.executable, "-m", "lfd.cli", "segment", str(path), "--json", str(out)]
    seconds, peak, status, tail = measure(cmd, env)
    if status != 0:
        raise RuntimeError(f"lfd segment failed ({status}): {tail}")
    return seconds, peak


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--minutes", type=float, nargs="+", default=[5, 15, 30, 60])
    ap.add_argument("--reference", metavar="PYTHONPATH", help="also measure this lfd checkout")
    ap.add_argument("--reference-max-min", type=float, default=15.0)
    ap.add_argument("--keep", metavar="DIR", help="keep the generated recordings here")
    args = ap.parse_args()

    from lfd.segmentation import SegmentParams, Templates
    from lfd.segmentation.band import Band

    n_skills = len(Templates.default().skills)
    max_segment_s = SegmentParams().max_segment_s
    tmp = Path(args.keep or tempfile.mkdtemp(prefix="lfd-segmem-"))
    tmp.mkdir(parents=True, exist_ok=True)
    head = (
        f"{'minutes':>7} {'samples':>8} {'sections':>8} {'runs':>8} {'seconds':>8} "
        f"{'peak MB':>8} {'dense table MB':>14} {'dense est. MB':>13}"
    )
    if args.reference:
        head += f" {'ref seconds':>11} {'ref peak MB':>11}"
    print(head, flush=True)
    from lfd.io import save

    for minutes in args.minutes:
        rec = tmp / f"exp5_{minutes:g}min.mcap"
        if not rec.exists():
            save(long_demo(minutes), rec)
        out = tmp / f"exp5_{minutes:g}min.json"
        seconds, peak = run_segment(rec, out)
        bounds, n, n_obj, dt = _prepared(rec)
        k = len(bounds) - 1
        band = Band.of(bounds, max(1, round(max_segment_s / dt)))
        dense = k * (k + 1) * n_skills * 8 / 2**20
        line = (
            f"{minutes:>7g} {n:>8d} {k:>8d} {band.n_runs:>8d} {seconds:>8.1f} {peak:>8.0f} "
            f"{dense:>14.0f} {(3 * n_obj + 3) * dense:>13.0f}"
        )
        if args.reference:
            if minutes <= args.reference_max_min:
                rs, rp = run_segment(rec, tmp / "reference.json", args.reference)
                line += f" {rs:>11.1f} {rp:>11.0f}"
            else:
                line += f" {'-':>11} {'-':>11}"
        print(line, flush=True)


def _prepared(rec: Path) -> tuple[np.ndarray, int, int, float]:
    """Stage-1 boundaries, samples, objects and sample period of a recording, as segmented."""
    from lfd.features import compute_features
    from lfd.io import load
    from lfd.segmentation import SegmentParams, Templates
    from lfd.segmentation.pipeline import as_trajectory, fill_gaps
    from lfd.segmentation.stage1 import section_boundaries

    tpl = Templates.default()
    traj, _ = fill_gaps(as_trajectory(load(rec, images=False), tpl.preprocessing))
    feats = compute_features(traj)
    per_object = [compute_features(traj, target=o) for o in range(len(traj.object_names))]
    b = section_boundaries(
        np.ascontiguousarray(feats.values, dtype=np.float64),
        feats.thresholds,
        traj.dt,
        SegmentParams().stage1,
        objects=[(f.values, f.thresholds) for f in per_object],
    )
    return np.asarray(b), len(traj), len(traj.object_names), traj.dt


if __name__ == "__main__":
    main()
