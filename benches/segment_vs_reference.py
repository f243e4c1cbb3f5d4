"""Benchmark: stage 2 of the segmentation in the engine vs a numpy + hmmlearn reference.

Run: ``OMP_NUM_THREADS=1 python benches/segment_vs_reference.py [--repeat 5]``

* A ~60 s demonstration is built by concatenating the features of ``recordings/exp1..4.mcap``
  (stage 1 runs on each part; the section boundaries are concatenated).
* **engine**: the score tables for every target object (``TemplateSet.score_table``), their
  maximum, the TCP rise table and the greedy loop (``segment_greedy``).
* **reference**: the same stage 2 written plainly: hmmlearn ``GMMHMM`` models built from the
  template parameters give the per-frame emission log-likelihoods of each run
  (``_compute_log_likelihood``), a numpy log-space forward pass per (start section, skill,
  feature, object) gives the final-state prefix scores, then the greedy loop in Python. Both must
  produce the same segmentation (checked).
* **end to end**: wall time of ``lfd segment recordings/exp1.mcap`` (process start included).

Targets: engine stage 2 < 20 ms on 60 s, reference / engine >= 30x, ``lfd segment`` < 1.5 s.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def build_demo() -> dict:
    from lfd.features import compute_features
    from lfd.io import load
    from lfd.preprocessing import preprocess
    from lfd.segmentation.gaps import fill_gaps
    from lfd.segmentation.stage1 import section_boundaries

    values, per_object, bounds, z = [], [], [0], []
    offset = 0
    for k in range(1, 5):
        traj, _ = fill_gaps(
            preprocess(load(ROOT / "recordings" / f"exp{k}.mcap"), feature_cutoff_hz=2.0)
        )
        f = compute_features(traj)
        b = section_boundaries(f.values, f.thresholds, traj.dt)
        values.append(f.values)
        per_object.append(
            [compute_features(traj, target=o).values for o in range(len(traj.object_names))]
        )
        bounds.extend(int(x) + offset for x in b[1:])
        z.append(traj.tcp[:, 2])
        offset += len(traj)
        dt = traj.dt
    objs = [np.ascontiguousarray(np.concatenate([p[o] for p in per_object])) for o in range(3)]
    return {
        "objects": objs,
        "bounds": np.asarray(bounds, dtype=np.int64),
        "z": np.ascontiguousarray(np.concatenate(z)),
        "dt": dt,
        "n": offset,
    }


def engine_stage2(templates, demo: dict) -> list[tuple[int, int, int]]:
    from lfd import _hmmseg
    from lfd.segmentation.band import Band
    from lfd.segmentation.grammar import compiled_grammar
    from lfd.segmentation.stage2 import scores_over_objects

    band = Band.of(demo["bounds"], round(10.0 / demo["dt"]))
    st = scores_over_objects(demo["objects"], templates, band, "final")
    rising = _hmmseg.rising_band(demo["z"], demo["bounds"], band.max_len, 0.02, 0.0)
    rules = compiled_grammar(tuple(templates.skills), False)
    cuts, _ = _hmmseg.segment_greedy(
        st.scores, demo["bounds"], rules, rising, "warn", True, band.max_len
    )
    return [(c.skill, c.start_section, c.end_section) for c in cuts]


# --- the reference ---------------------------------------------------------------------------
def hmmlearn_models(templates) -> list[list]:
    from hmmlearn.hmm import GMMHMM

    doc = json.loads(templates.engine.to_json())
    out = []
    for row in doc["models"]:
        models = []
        for p in row:
            n, m = len(p["weights"]), len(p["weights"][0])
            d = len(p["means"][0][0])
            g = GMMHMM(n_components=n, n_mix=m, covariance_type="diag", init_params="", params="")
            g.startprob_ = np.asarray(p["startprob"])
            g.transmat_ = np.asarray(p["transmat"])
            g.weights_ = np.asarray(p["weights"])
            g.means_ = np.asarray(p["means"])
            g.covars_ = np.array([[np.diag(np.asarray(c)) for c in s] for s in p["covars"]])
            g.n_features = d
            models.append(g)
        out.append(models)
    return out


def _logsumexp(a: np.ndarray, axis: int = 0) -> np.ndarray:
    hi = np.max(a, axis=axis, keepdims=True)
    hi = np.where(np.isfinite(hi), hi, 0.0)
    with np.errstate(divide="ignore"):
        return np.squeeze(hi, axis) + np.log(np.sum(np.exp(a - hi), axis=axis))


def reference_stage2(templates, models, demo: dict) -> list[tuple[int, int, int]]:
    ranges = templates.ranges
    lo, hi = ranges[:, 0], ranges[:, 1]
    span = np.where(hi > lo, hi - lo, 1.0)
    b = demo["bounds"]
    k = len(b) - 1
    n_sk = len(templates.skills)
    max_len = round(10.0 / demo["dt"])
    best = np.full((k, k + 1, n_sk), -np.inf)
    for raw in demo["objects"]:
        x = np.where(hi > lo, np.clip((raw - lo) / span, 0.0, 1.0), 0.5)
        table = np.full((k, k + 1, n_sk), -np.inf)
        for i in range(k):
            last = i + 1
            while last < k and b[last + 1] - b[i] <= max_len:
                last += 1
            run = slice(b[i], b[last])
            for s, row in enumerate(models):
                total = np.zeros(last - i)
                for (_, c0, c1), g in zip(templates.features, row, strict=True):
                    logb = g._compute_log_likelihood(x[run, c0:c1])
                    with np.errstate(divide="ignore"):
                        log_a = np.log(g.transmat_)
                        alpha = np.log(g.startprob_) + logb[0]
                    fin = np.empty(len(logb))
                    fin[0] = alpha[-1]
                    for t in range(1, len(logb)):
                        alpha = _logsumexp(alpha[:, None] + log_a, axis=0) + logb[t]
                        fin[t] = alpha[-1]
                    total += fin[b[i + 1 : last + 1] - b[i] - 1]
                table[i, i + 1 : last + 1, s] = total
        best = np.maximum(best, table)
    # the rise decision and the greedy loop (Eq. 4-5, per-sample scores of a cut together with
    # its best successor: the engine's lookahead)
    rising_skill = np.array([s in ("move", "move_with") for s in templates.skills])
    z = demo["z"]
    rise = np.zeros((k, k + 1), dtype=bool)
    for i in range(k):
        for j in range(i + 1, k + 1):
            seg = z[b[i] : b[j]]
            rise[i, j] = float(np.max(seg - np.minimum.accumulate(seg))) >= 0.02
    ok = rise[:, :, None] == rising_skill[None, None, :]  # (K, K + 1, S)

    def value(i: int, j: int, s: int) -> float:
        if j == k:
            return float(best[i, j, s] / (b[j] - b[i]))
        for use_rise in (True, False):
            nxt = np.where(ok[j] | (not use_rise), best[j], -np.inf)
            nxt[:, s] = -np.inf
            nxt[: j + 1] = -np.inf
            n = np.maximum(b - b[i], 1)[:, None]
            v = np.where(np.isfinite(nxt), (best[i, j, s] + nxt) / n, -np.inf)
            if np.isfinite(v).any():
                return float(v.max())
        return -np.inf

    out, i = [], 0
    while i < k:
        pick = None
        for j in range(i + 1, k + 1):
            for s in np.flatnonzero(ok[i, j] & np.isfinite(best[i, j])):
                v = value(i, j, int(s))
                if np.isfinite(v) and (pick is None or v > pick[0]):
                    pick = (v, j, int(s))
        if pick is None:
            out.append((0, i, i + 1))
            i += 1
            continue
        out.append((pick[2], i, pick[1]))
        i = pick[1]
    return out


def timed(fn, repeat: int) -> tuple[float, object]:
    times, result = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times)), result


def main() -> int:
    from lfd.segmentation import Templates
    from rich.console import Console
    from rich.table import Table

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--skip-reference", action="store_true", help="time the engine only")
    args = ap.parse_args()
    templates = Templates.default()
    demo = build_demo()
    models = hmmlearn_models(templates)
    t_engine, seg_engine = timed(lambda: engine_stage2(templates, demo), args.repeat)
    if args.skip_reference:
        t_ref, same = float("nan"), True
    else:
        t_ref, seg_ref = timed(lambda: reference_stage2(templates, models, demo), 1)
        same = seg_engine == seg_ref
    cmd = [sys.executable, "-m", "lfd.cli", "segment", str(ROOT / "recordings" / "exp1.mcap")]
    t_cli, _ = timed(lambda: subprocess.run(cmd, capture_output=True, check=True), 3)

    table = Table(
        title=f"stage 2 on a {demo['n'] * demo['dt']:.0f} s demo, {len(demo['bounds']) - 1} sections"
    )
    for col in ("what", "time", "target", "ratio"):
        table.add_column(col, justify="right" if col != "what" else "left")
    table.add_row("engine stage 2 (3 objects)", f"{1e3 * t_engine:.1f} ms", "< 20 ms", "1x")
    table.add_row(
        "numpy + hmmlearn reference",
        f"{1e3 * t_ref:.0f} ms",
        "",
        f"{t_ref / t_engine:.0f}x (>= 30x)",
    )
    table.add_row("lfd segment exp1.mcap (end to end)", f"{t_cli:.2f} s", "< 1.5 s", "")
    Console().print(table)
    print(f"same segmentation: {same}")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
