"""Retraining on the user's own labelled recordings (docs/own-recordings.md, docs/results.md).

Run: ``MUJOCO_GL=egl python benches/segment_adapt.py [--out /tmp/lfd_adapt] [--seeds 310-311]``

Eleven natural-style recordings (``--style natural``: exp1-5 x two seeds, plus one more exp5;
seeds 310-312, used by no template, tuning or other benchmark) stand in for a user's own
labelled recordings that move unlike the careful demonstrator. Leave-one-out, default method
(DP, grammar enforced): each recording is segmented by templates built without it.

- templates trained on careful demos only (``recordings/templates``), not retrained;
- the same careful-only templates adapted to the other 10 (``--base``: what a user whose
  templates came from another demonstrator does);
- templates trained from scratch on the other 10;
- the shipped templates (careful and natural template demos), not retrained.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def main() -> int:
    from lfd.segmentation import Method, train_templates
    from lfd.segmentation.evaluate import evaluate, leave_one_out
    from segment_heldout import seeds_of, simulate_group  # same folder: benches/

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="/tmp/lfd_adapt", help="where to write the recordings")
    ap.add_argument("--seeds", default="310-311", help="seed range A-B of exp1-5 (default 310-311)")
    args = ap.parse_args()
    seeds = seeds_of(args.seeds)
    natural = {"style": "natural"}
    paths = simulate_group(Path(args.out), natural, ("exp1", "exp2", "exp3", "exp4", "exp5"), seeds)
    paths += simulate_group(Path(args.out), natural, ("exp5",), [seeds[-1] + 1])
    careful = train_templates(sorted((ROOT / "recordings" / "templates").glob("*.mcap")))
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        careful_file = Path(tmp) / "careful.json"
        careful.save(careful_file)
        rows.append(
            (
                "careful-only templates, not retrained",
                evaluate(paths, method=Method.of_templates(careful), methods=("dp",)),
            )
        )
        rows.append(
            (
                f"careful-only templates adapted to the other {len(paths) - 1} (`--base`)",
                leave_one_out(paths, base=careful, base_name=str(careful_file)),
            )
        )
    rows.append(
        (f"trained from scratch on the other {len(paths) - 1}", leave_one_out(paths, base=None))
    )
    rows.append(
        (
            "shipped templates, not retrained",
            evaluate(paths, method=Method.default(), methods=("dp",)),
        )
    )
    print(f"{len(paths)} natural-style recordings (seeds {args.seeds} and {seeds[-1] + 1}), dp:")
    print()
    print("| templates for each recording | frame accuracy | exact sequences | boundary error |")
    print("|---|---|---|---|")
    for label, report in rows:
        m = report.summary()["dp"]
        print(
            f"| {label} | {100 * m['frame_accuracy']:.1f} % | {m['sequence_match']:.0f}/"
            f"{len(paths)} | {m['boundary_error_s']:.2f} s |"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
