"""Segmentation methods on held-out simulated demos (the README's segmentation table).

Run: ``MUJOCO_GL=egl python benches/segment_heldout.py [--out /tmp/lfd_heldout] [--seeds 300-302]``

Two groups of demos that no template and no tuning used: the four experiments performed by the
simulator's default demonstrator, and by a fast, small-handed, noisy one (speed 1.4x, hand scale
0.85, keypoint noise 5 mm), each with seeds 300-302 (3 x 4 = 12 demos per group). Every method
is scored against the simulator's ground truth; the table is printed as Markdown, the first row
being lfd's default (``lfd segment`` without options).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from segment_robustness import EXPERIMENTS, simulate_condition  # same folder: benches/

GROUPS: dict[str, dict[str, float]] = {
    "default demonstrator": {},
    "fast, small, noisy hand": {"speed": 1.4, "hand_scale": 0.85, "noise_mm": 5.0},
}
ROWS: list[tuple[str, str, dict[str, Any]]] = [
    # (label, method of lfd.segmentation.evaluate, grammar)
    ("dp, grammar enforced (default)", "dp", {"grammar": "enforce"}),
    ("greedy, grammar warns (the paper, `--paper`)", "paper", {}),
    ("greedy, grammar enforced", "greedy", {"grammar": "enforce"}),
    ("dp, grammar warns", "dp", {"grammar": "warn"}),
    ("change points + contact rules (OKAMI / ORION-style baseline)", "changepoint", {}),
    ("proximity baseline", "proximity", {}),
    ("gripper-distance baseline", "gripper", {}),
]


def seeds_of(spec: str) -> list[int]:
    a, _, b = spec.partition("-")
    return list(range(int(a), int(b or a) + 1))


def main() -> int:
    from lfd.segmentation.evaluate import evaluate

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="/tmp/lfd_heldout", help="where to write the recordings")
    ap.add_argument("--seeds", default="300-302", help="seed range A-B (default 300-302)")
    args = ap.parse_args()
    seeds = seeds_of(args.seeds)
    results: dict[str, dict[str, dict[str, float]]] = {}
    for group, given in GROUPS.items():
        slug = group.split(",")[0].replace(" ", "_")
        paths = simulate_condition(Path(args.out) / slug, given, seeds)
        results[group] = {}
        for label, method, kw in ROWS:
            report = evaluate(paths, methods=(method,), **kw)
            results[group][label] = report.summary()[method]
            print(f"{group} / {label}: {results[group][label]['sequence_match']:.0f}", flush=True)
    n = len(EXPERIMENTS) * len(seeds)
    print()
    print(f"Held-out simulated demos: exp1-4 x seeds {args.seeds} ({n} per group).")
    print()
    head = " | ".join(f"{g}: exact, frame acc." for g in GROUPS)
    print(f"| method | {head} |")
    print("|---|" + "---|" * len(GROUPS))
    for label, _, _ in ROWS:
        cells = []
        for group in GROUPS:
            m = results[group][label]
            cells.append(f"{m['sequence_match']:.0f}/{n}, {100 * m['frame_accuracy']:.1f} %")
        print(f"| {label} | " + " | ".join(cells) + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
