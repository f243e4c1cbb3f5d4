"""What each choice for real human motion is worth: the measurements behind the default
segmentation (docs/segmentation.md, "Real human motion").

Run: ``MUJOCO_GL=egl python benches/segment_ablation.py [--out /tmp/lfd_ablation]``

Each row changes one thing from the default and, where the change is in the preprocessing or
the template training, trains its own templates from ``recordings/templates`` and
``recordings/templates/natural``. Scored with the default search (DP, grammar enforced) on
tuning demos, seeds 500-503 (not the held-out benchmark seeds 300-305): careful exp1-4 (16) and
natural exp1-5 (20). A second table says how far the filtered object height strays from the
unfiltered one on the natural demos: the largest error during each lift (median over lifts)
and the largest error while the object rests.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_PRE: dict[str, Any] = {"feature_cutoff_hz": "auto", "object_cutoff_hz": 10.0}
ROWS: list[tuple[str, dict[str, Any], dict[str, Any], dict[str, Any], bool]] = [
    # (label, preprocessing, template params, segment params, natural template demos)
    ("default", {}, {}, {}, True),
    ("hand and objects filtered at 2 Hz (previous default)", {"feature_cutoff_hz": 2.0,
     "object_cutoff_hz": 2.0}, {}, {}, True),
    ("hand 2 Hz, objects 10 Hz", {"feature_cutoff_hz": 2.0}, {}, {}, True),
    ("Table I opening (thumb-index) instead of the grasp aperture", {"aperture": "thumb_index"},
     {}, {}, True),
    ("covariance floor 1e-3 (previous default)", {}, {"fit": {"covariance_floor": 1e-3}}, {},
     True),
    ("no object lift-off / set-down / motion cuts in stage 1", {}, {},
     {"object_criteria": False}, True),
    ("no co-motion evidence", {}, {}, {"co_motion": 0.0}, True),
    ("no implicit re-grasp moves", {}, {}, {"implicit_moves": False}, True),
    ("stage-1 sections >= 0.2 s (previous default)", {}, {}, {"min_section_s": 0.2}, True),
    ("templates from careful demos only", {}, {}, {}, False),
]  # fmt: skip
GROUPS: dict[str, tuple[dict[str, Any], tuple[str, ...]]] = {
    "careful": ({}, ("exp1", "exp2", "exp3", "exp4")),
    "natural": ({"style": "natural"}, ("exp1", "exp2", "exp3", "exp4", "exp5")),
}
SEEDS = range(500, 504)


def height_errors(paths: list[Path], opts: dict[str, Any]) -> tuple[float, float]:
    """Median over lifts of the largest |filtered - raw| object height, and the largest error
    at rest (metres)."""
    from lfd.io import load
    from lfd.preprocessing import preprocess

    lifts, rest = [], []
    for p in paths:
        demo = load(p)
        raw = preprocess(demo, filter=False)
        filt = preprocess(demo, **opts)
        for k in range(len(raw.object_names)):
            z, f = raw.object_position[k, :, 2], filt.object_position[k, :, 2]
            base = np.nanmin(z)
            up = np.r_[False, z > base + 0.02, False]
            edges = np.flatnonzero(np.diff(up.astype(int)))
            for a, b in zip(edges[::2], edges[1::2], strict=True):
                lifts.append(float(np.nanmax(np.abs(f[a:b] - z[a:b]))))
            still = z < base + 0.002
            if still.any():
                rest.append(float(np.nanmax(np.abs(f[still] - z[still]))))
    return float(np.median(lifts)) if lifts else float("nan"), float(np.max(rest))


def main() -> int:
    from lfd.io import load
    from lfd.segmentation import SegmentParams, segment, train_templates
    from lfd.segmentation.metrics import all_metrics
    from lfd.segmentation.stage1 import Stage1Params
    from segment_heldout import simulate_group  # same folder: benches/

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="/tmp/lfd_ablation", help="where to write the recordings")
    args = ap.parse_args()

    demos = {
        g: [load(p) for p in simulate_group(Path(args.out) / g, given, tasks, list(SEEDS))]
        for g, (given, tasks) in GROUPS.items()
    }
    careful_tpl = sorted((ROOT / "recordings" / "templates").glob("*.mcap"))
    natural_tpl = sorted((ROOT / "recordings" / "templates" / "natural").glob("*.mcap"))
    cache: dict[str, Any] = {}
    lines = []
    for label, pre, tparams, sparams, with_natural in ROWS:
        key = repr((pre, tparams, with_natural))
        if key not in cache:
            cache[key] = train_templates(
                careful_tpl + (natural_tpl if with_natural else []),
                params=tparams or None,
                **{**DEFAULT_PRE, **pre},
            )
        templates = cache[key]
        stage1 = {k: v for k, v in sparams.items() if k in ("object_criteria", "min_section_s")}
        rest = {k: v for k, v in sparams.items() if k not in stage1}
        params = SegmentParams(stage1=Stage1Params(**stage1), **rest)
        cells = []
        for group_demos in demos.values():
            exact, frame, bound = 0, [], []
            for demo in group_demos:
                seg = segment(demo, templates, params=params)
                m = all_metrics(seg.segments, demo.labels)
                exact += int(seg.skill_sequence == demo.skill_sequence)
                frame.append(m["frame_accuracy"])
                bound.append(m["boundary_error_s"])
            cells.append(
                f"{exact}/{len(group_demos)}, {100 * np.mean(frame):.1f} %, "
                f"{np.nanmean(bound):.2f} s"
            )
        line = f"| {label} | " + " | ".join(cells) + " |"
        print(line, flush=True)
        lines.append(line)
    print()
    print("Tuning demos, seeds 500-503; exact sequences, frame accuracy, mean boundary error.")
    print()
    print("| change from the default | " + " | ".join(GROUPS) + " |")
    print("|---|" + "---|" * len(GROUPS))
    print("\n".join(lines))
    print()
    natural_paths = simulate_group(Path(args.out) / "natural", *GROUPS["natural"], list(SEEDS))
    print("| object filter | lift height error (median of per-lift max) | error at rest |")
    print("|---|---|---|")
    for label, opts in (
        ("2 Hz (previous default)", {"feature_cutoff_hz": 2.0, "object_cutoff_hz": 2.0}),
        ("10 Hz (default)", DEFAULT_PRE),
    ):
        lift, still = height_errors(natural_paths, opts)
        print(f"| {label} | {100 * lift:.1f} cm | {100 * still:.2f} cm |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
