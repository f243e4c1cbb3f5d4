"""Segmentation on real optical motion capture of people handling objects (docs/results.md).

Run: ``python benches/segment_real.py [DIR] [--json OUT]`` (DIR: ``../shared/realmotion``
beside the repository; without it the bench says it skipped and exits 0).

DIR holds MCAP recordings converted from ManipNet's motion capture (CC-BY-NC 4.0: read them
there, never copy them or anything derived from them into this repository; DIR/README.md): 8
crops ``manip_<seq>_<t0>-<t1>s.mcap`` where only the recorded (right) hand handles the object,
the fair test cases, and whole bimanual sequences ``manip_<seq>.mcap`` whose metadata names the
spans where the other hand handles the object (``other_hand_spans``, ``shared_spans``).

Each recording is loaded and segmented as a user's ``lfd segment`` does (``lfd.load``, then
``lfd.segment``), by lfd's default, by ``--paper`` (``lfd.segmentation.PAPER``) and by the
change-point + contact-rule baseline (``lfd.segmentation.changepoint``), and scored against its
ground truth with the library's metrics (``lfd.segmentation.metrics``) with the spans of its
metadata left out (none on the crops): frame accuracy, exact skill sequence, mean boundary
error, predicted / true segment count, the sequences and counts as seen from outside the spans
(``metrics.restrict``). Totals per group: mean frame accuracy and boundary error over the
recordings, exact sequences counted, the ratio of the segments summed over the recordings.
"""

from __future__ import annotations

import argparse
import json
import math
import re
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_DIR = ROOT.parent / "shared" / "realmotion"
CROP = re.compile(r"_\d+(\.\d+)?-\d+(\.\d+)?s\.mcap$")
GROUPS = ("crops", "whole")
GROUP_TITLES = {
    "crops": "crops, one hand",
    "whole": "whole files, outside the other hand's spans",
}


def methods() -> dict[str, Callable[[Any], Any]]:
    """Name -> segmentation of a Demonstration, as the user's commands run it."""
    import lfd
    from lfd.segmentation import PAPER, changepoint_segmentation

    return {
        "lfd default": lambda demo: lfd.segment(demo),
        "--paper": lambda demo: lfd.segment(demo, **PAPER),
        "change points": changepoint_segmentation,
    }


def score(segments: Any, demo: Any) -> dict[str, float]:
    """The metrics of one segmentation of ``demo``, its metadata's excluded spans left out."""
    from lfd.segmentation.metrics import all_metrics, excluded_spans, restrict, segment_ratio

    exclude = excluded_spans(demo.metadata, demo.start_ns)
    out = all_metrics(segments, demo.labels, exclude=exclude)
    pred, truth = restrict(segments, exclude), restrict(demo.labels, exclude)
    out["segments"] = float(len(pred))
    out["true_segments"] = float(len(truth))
    out["segment_ratio"] = segment_ratio(pred, truth)
    return out


def run(folder: Path) -> dict[str, Any]:
    """Every recording of ``folder`` by every method: per recording and per group."""
    import lfd
    from lfd.segmentation.metrics import excluded_spans

    files = sorted(folder.glob("manip_*.mcap"))
    rows: list[dict[str, Any]] = []
    for path in files:
        demo = lfd.load(path, images=False)
        if not demo.labels:
            print(f"segment_real: {path.name} has no ground truth; left out", file=sys.stderr)
            continue
        t0 = demo.start_ns
        exclude = excluded_spans(demo.metadata, t0)
        row: dict[str, Any] = {
            "file": path.name,
            "group": "crops" if CROP.search(path.name) else "whole",
            "duration_s": demo.duration_s,
            "excluded_s": [[(a - t0) * 1e-9, (b - t0) * 1e-9] for a, b in exclude],
            "methods": {},
        }
        for name, method in methods().items():
            started = time.perf_counter()
            seg = method(demo)
            m = score(seg.segments, demo)
            m["seconds"] = time.perf_counter() - started
            row["methods"][name] = m
        rows.append(row)
    return {"folder": str(folder), "recordings": rows, "groups": totals(rows)}


def totals(rows: list[dict[str, Any]]) -> dict[str, dict[str, dict[str, float]]]:
    """Per group and method: n, exact, mean frame accuracy and boundary error, segment ratio."""
    out: dict[str, dict[str, dict[str, float]]] = {}
    for group in GROUPS:
        sel = [r for r in rows if r["group"] == group]
        if not sel:
            continue
        out[group] = {}
        for name in sel[0]["methods"]:
            ms = [r["methods"][name] for r in sel]
            bounds = [m["boundary_error_s"] for m in ms if math.isfinite(m["boundary_error_s"])]
            out[group][name] = {
                "n": float(len(ms)),
                "exact": float(sum(m["sequence_match"] for m in ms)),
                "frame_accuracy": sum(m["frame_accuracy"] for m in ms) / len(ms),
                "boundary_error_s": sum(bounds) / len(bounds) if bounds else math.nan,
                "segments": sum(m["segments"] for m in ms),
                "true_segments": sum(m["true_segments"] for m in ms),
                "segment_ratio": sum(m["segments"] for m in ms)
                / max(sum(m["true_segments"] for m in ms), 1.0),
            }
    return out


def _cell(m: dict[str, float], n: int | None = None) -> str:
    exact = f"{m['sequence_match']:.0f}" if n is None else f"{m['exact']:.0f}/{n}"
    be = m["boundary_error_s"]
    return (
        f"{exact}, {100 * m['frame_accuracy']:.1f} %, {be:.2f} s, x{m['segment_ratio']:.2f}"
        if math.isfinite(be)
        else f"{exact}, {100 * m['frame_accuracy']:.1f} %, -, x{m['segment_ratio']:.2f}"
    )


def print_tables(doc: dict[str, Any]) -> None:
    rows = doc["recordings"]
    names = list(rows[0]["methods"]) if rows else []
    print("Per recording: exact sequence (1/0), frame accuracy, mean boundary error, ")
    print("predicted / true segments (ratio); whole files scored outside their excluded spans.\n")
    print("| group | recording | excluded s | " + " | ".join(names) + " |")
    print("|---|---|---|" + "---|" * len(names))
    for r in rows:
        excl = sum(b - a for a, b in r["excluded_s"])
        cells = []
        for name in names:
            m = r["methods"][name]
            cells.append(f"{_cell(m)} ({m['segments']:.0f}/{m['true_segments']:.0f})")
        print(
            f"| {r['group']} | {r['file']} | {excl:.1f} of {r['duration_s']:.1f} | "
            + " | ".join(cells)
            + " |"
        )
    groups = doc["groups"]
    print(
        "\nTotals: exact sequences, mean frame accuracy, mean boundary error, "
        "predicted / true segments summed (ratio).\n"
    )
    heads = [f"{GROUP_TITLES[g]} ({int(next(iter(groups[g].values()))['n'])})" for g in groups]
    print("| method | " + " | ".join(heads) + " |")
    print("|---|" + "---|" * len(heads))
    for name in names:
        cells = [
            f"{_cell(groups[g][name], int(groups[g][name]['n']))} "
            f"({groups[g][name]['segments']:.0f}/{groups[g][name]['true_segments']:.0f})"
            for g in groups
        ]
        print(f"| {name} | " + " | ".join(cells) + " |")


def _clean(x: Any) -> Any:
    if isinstance(x, float) and not math.isfinite(x):
        return None
    if isinstance(x, dict):
        return {k: _clean(v) for k, v in x.items()}
    if isinstance(x, list):
        return [_clean(v) for v in x]
    return x


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "folder",
        nargs="?",
        type=Path,
        default=DEFAULT_DIR,
        help=f"the converted recordings (default {DEFAULT_DIR})",
    )
    ap.add_argument("--json", metavar="OUT", help="also write every number here as JSON")
    args = ap.parse_args(argv)
    if not args.folder.is_dir():
        print(f"segment_real: skipped: {args.folder} not found (the real motion-capture set)")
        return 0
    if not any(args.folder.glob("manip_*.mcap")):
        print(f"segment_real: skipped: no manip_*.mcap recordings in {args.folder}")
        return 0
    if args.json:
        from lfd.outputs import check_output

        check_output(args.json, what="--json", suffixes=(".json",))
    started = time.perf_counter()
    doc = run(args.folder)
    doc["seconds"] = time.perf_counter() - started
    print_tables(doc)
    print(f"\n{len(doc['recordings'])} recordings in {doc['seconds']:.1f} s")
    if args.json:
        from lfd.outputs import atomic_write_text

        atomic_write_text(args.json, json.dumps(_clean(doc), indent=1) + "\n")
        print(f"wrote {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
