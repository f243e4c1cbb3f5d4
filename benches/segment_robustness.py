"""Robustness of the segmentation: the eval set (4 experiments x seeds 100-105) re-simulated
under one perturbation at a time, scored with the shipped templates.

Run: ``MUJOCO_GL=egl python benches/segment_robustness.py [--out /tmp/lfd_robust]``

Conditions: nominal (the simulator's default variability), speed 0.7x / 1.4x, hand scale
0.85 / 1.15, keypoint noise 5 mm, 5 % object-marker dropouts. Prints one table of the greedy and
DP metrics (grammar enforced and warn) per condition.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Iterable
from pathlib import Path

CONDITIONS: dict[str, dict[str, float]] = {
    "nominal": {},
    "speed 0.7x": {"speed": 0.7},
    "speed 1.4x": {"speed": 1.4},
    "hand scale 0.85": {"hand_scale": 0.85},
    "hand scale 1.15": {"hand_scale": 1.15},
    "noise 5 mm": {"noise_mm": 5.0},
    "dropout 5 %": {"dropout": 0.05},
}
EXPERIMENTS = ("exp1", "exp2", "exp3", "exp4")
SEEDS = range(100, 106)


def simulate_condition(
    out: Path, given: dict[str, float], seeds: Iterable[int] = SEEDS
) -> list[Path]:
    """Simulate (once; cached in ``out``) every experiment x seed with the given variability."""
    from segment_heldout import simulate_group  # same folder: benches/

    return simulate_group(out, dict(given), EXPERIMENTS, list(seeds))


def main() -> int:
    from lfd.segmentation import Method
    from lfd.segmentation.evaluate import evaluate
    from rich.console import Console
    from rich.table import Table

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="/tmp/lfd_robust", help="where to write the recordings")
    ap.add_argument("--conditions", default=",".join(CONDITIONS), help="comma-separated names")
    args = ap.parse_args()
    table = Table(title="segmentation robustness (24 demos per condition)")
    for col in ("condition", "method", "seq match", "frame acc %", "boundary err s", "F1@50 %"):
        table.add_column(col, justify="left" if col in ("condition", "method") else "right")
    for name in args.conditions.split(","):
        given = CONDITIONS[name]
        slug = name.replace(" ", "_").replace("%", "pct")
        paths = simulate_condition(Path(args.out) / slug, given)
        for grammar in ("enforce", "warn"):
            method = Method.default().with_options(grammar=grammar)
            rep = evaluate(paths, methods=("greedy", "dp"), method=method)
            for method, m in rep.summary().items():
                table.add_row(
                    name,
                    f"{method} ({grammar})",
                    f"{m['sequence_match']:.0f}/{m['n']:.0f}",
                    f"{100 * m['frame_accuracy']:.1f}",
                    f"{m['boundary_error_s']:.3f}",
                    f"{100 * m['f1@50']:.1f}",
                )
        Console().print(f"done: {name}")
    Console().print(table)
    return 0


if __name__ == "__main__":
    sys.exit(main())
