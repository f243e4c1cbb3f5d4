"""Cost and accuracy of the online (causal) preprocessing and features.

Every recording is replayed message by message in timestamp order through
``lfd.preprocessing.online.OnlinePreprocessor`` and ``OnlineFeatures`` (with the preprocessing
options of the shipped templates, as ``lfd segment`` uses them). Printed per recording:

- cost: wall time of each message (preprocessor and features of the samples it released),
  median and p99, and the time per output sample (total / samples; ``cpu``: process time, less
  sensitive to other load on the machine);
- latency: the newest message's timestamp when a feature row came out minus the row's clock
  time (the wait for the next 5 Hz hand frame plus one sample for central differences), median
  and p99, and the causal filters' group delay (hand, objects);
- accuracy: per feature column, the RMS difference between the online and the offline features
  (``compute_features`` of ``lfd.preprocess``) once the filter lag is taken out, relative to the
  column's offline range — the largest over the per-object rows (``compute_features(traj,
  target=o)``), and for the hand's own columns the hand row; and the stage-1 boundaries: the
  share of offline cuts with an online cut (lag taken out) within 3 samples, and the median
  distance.

Run: ``python benches/preprocess_online.py [FILES] [--order 4] [--derivative central]
[--max-wait S] [--no-match-lag]``
(default: recordings/exp1-4.mcap and recordings/perceived/exp1.mcap).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import lfd
import numpy as np
from lfd.features import FEATURE_NAMES, compute_features
from lfd.preprocessing.online import OnlineFeatures, OnlinePreprocessor, demo_messages
from lfd.segmentation.gaps import fill_gaps
from lfd.segmentation.stage1 import section_boundaries
from lfd.segmentation.templates import preprocessing_options

ROOT = Path(__file__).resolve().parent.parent
DEFAULT = [*(ROOT / "recordings" / f"exp{i}.mcap" for i in range(1, 5))]
DEFAULT.append(ROOT / "recordings" / "perceived" / "exp1.mcap")
SHORT = ["fing", "rise", "prox", "dist", "height", "in_x", "in_y", "in_z", "o_vel", "h_vel"]


def run(
    path: Path,
    order: int,
    derivative: str,
    max_wait: float | None,
    match_lag: bool,
    smoother: str = "fixed-lag",
) -> dict[str, object]:
    demo = lfd.load(path)
    opts = preprocessing_options()
    pre = OnlinePreprocessor.for_demonstration(
        demo,
        filter_order=order,
        max_wait_s=max_wait,
        match_lag=match_lag,
        smoother=smoother,  # type: ignore[arg-type]
        **opts,
    )
    feats = OnlineFeatures(
        pre.object_names,
        pre.object_sizes,
        pre.rate_hz,
        derivative=derivative,  # type: ignore[arg-type]
    )
    costs, latency = [], []
    c0 = time.process_time()
    for msg in demo_messages(demo):
        t0 = time.perf_counter()
        rows = [r for s in pre.push(msg) for r in feats.push(s)]
        costs.append(time.perf_counter() - t0)
        latency += [(msg.t_ns - r.t_ns) * 1e-6 for r in rows]
    t0 = time.perf_counter()
    _ = [r for s in pre.flush() for r in feats.push(s)] + feats.flush()
    costs.append(time.perf_counter() - t0)
    cpu = time.process_time() - c0
    a = feats.arrays()
    n_out = len(a["t_ns"])

    off = lfd.preprocess(demo, **opts)
    filled, _ = fill_gaps(off)
    offline = compute_features(filled)
    per_object = [compute_features(filled, target=o) for o in range(len(off.object_names))]
    lag = pre.lag_s()
    hl = pre.shift_samples  # 0 for the fixed-lag smoother: its rows carry their own time
    ol = (hl and round(lag["objects"] * pre.rate_hz)) + pre.object_delay_samples
    n = min(len(off), n_out)
    err = np.zeros(10)
    for o, ref in enumerate(per_object):
        for c in range(10):
            k = ol if c in (3, 4, 8) else hl
            d = ref.values[: n - k, c] - a["object_values"][o][k:n, c]
            rng = max(float(np.ptp(ref.values[:, c])), 1e-9)
            err[c] = max(err[c], float(np.sqrt(np.nanmean(d**2))) / rng)
    hand_err = {}
    for c in (0, 1, 9):
        d = offline.values[: n - hl, c] - a["values"][hl:n, c]
        hand_err[FEATURE_NAMES[c]] = float(np.sqrt(np.nanmean(d**2))) / float(
            np.ptp(offline.values[:, c])
        )
    b_off = section_boundaries(
        offline.values,
        offline.thresholds,
        off.dt,
        objects=[(f.values, f.thresholds) for f in per_object],
    )[1:-1]
    b_on = section_boundaries(
        a["values"],
        a["thresholds"],
        off.dt,
        objects=[
            (a["object_values"][o], a["object_thresholds"][o]) for o in range(len(per_object))
        ],
    )[1:-1]
    dist = np.array([np.min(np.abs(b_on - hl - b)) for b in b_off]) if b_on.size else np.inf
    return {
        "name": path.stem
        if path.parent.name == "recordings"
        else f"{path.parent.name}/{path.stem}",
        "samples": n_out,
        "msg_ms": np.percentile(np.array(costs) * 1e3, [50, 99]),
        "per_sample_ms": sum(costs) / n_out * 1e3,
        "cpu_ms": cpu / n_out * 1e3,
        "latency_ms": np.percentile(latency, [50, 99]),
        "lag_ms": (lag["hand"] * 1e3, lag["objects"] * 1e3),
        "err": err,
        "hand_err": hand_err,
        "bounds": (len(b_off), len(b_on), float(np.mean(dist <= 3)), float(np.median(dist))),
        "target_agree": float(np.mean(offline.target[: n - hl] == a["target"][hl:n])),
        "dropped": pre.dropped,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("files", nargs="*", type=Path, default=DEFAULT)
    ap.add_argument("--order", type=int, default=4, help="causal Butterworth order")
    ap.add_argument("--derivative", default="central", choices=["central", "backward"])
    ap.add_argument("--max-wait", type=float, default=None, help="seconds (default max_gap_s)")
    ap.add_argument("--no-match-lag", action="store_true", help="objects not delayed")
    ap.add_argument("--smoother", default="fixed-lag", choices=["fixed-lag", "causal"])
    args = ap.parse_args()
    match = not args.no_match_lag
    res = [
        run(p, args.order, args.derivative, args.max_wait, match, args.smoother) for p in args.files
    ]
    print(
        f"smoother {args.smoother}, order {args.order}, derivative {args.derivative}, "
        f"max_wait_s {args.max_wait}, match_lag {match}"
    )
    print(
        f"{'recording':16s} {'n':>5s} {'msg p50':>8s} {'msg p99':>8s} {'ms/smp':>7s} "
        f"{'cpu/smp':>7s} {'lat p50':>8s} {'lat p99':>8s} {'lag h/o ms':>11s}"
    )
    for r in res:
        m, lat, lag = r["msg_ms"], r["latency_ms"], r["lag_ms"]
        print(
            f"{r['name']:16s} {r['samples']:5d} {m[0]:8.3f} {m[1]:8.3f} "  # type: ignore[index]
            f"{r['per_sample_ms']:7.3f} {r['cpu_ms']:7.3f} {lat[0]:8.0f} {lat[1]:8.0f} "  # type: ignore[index]
            f"{lag[0]:5.0f}/{lag[1]:<5.0f}"  # type: ignore[index]
        )
    print("\nRMS(online - offline) / offline range, lag removed (max over the per-object rows):")
    print(f"{'recording':16s} " + " ".join(f"{s:>6s}" for s in SHORT))
    for r in res:
        print(f"{r['name']:16s} " + " ".join(f"{e:6.3f}" for e in r["err"]))  # type: ignore[attr-defined]
    print("\nhand row (fingertip, rise/fall, hand velocity), target agreement, stage-1 cuts:")
    for r in res:
        h, (nb_off, nb_on, within, med) = r["hand_err"], r["bounds"]  # type: ignore[misc]
        print(
            f"{r['name']:16s} "
            + " ".join(f"{v:6.3f}" for v in h.values())  # type: ignore[attr-defined]
            + f"  target {r['target_agree']:.2f}  cuts offline {nb_off} online {nb_on}, "
            f"within 3 samples {within:.0%}, median {med:.1f}"
        )


if __name__ == "__main__":
    main()
