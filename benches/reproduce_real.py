"""Reproduction of real human motion capture: the 8 single-hand crops of ../shared/realmotion.

Usage::

    MUJOCO_GL=egl python benches/reproduce_real.py [DIR] [--jobs 2] [--json OUT]

For every crop ``manip_*_<t0>-<t1>s.mcap`` in DIR (default ``../shared/realmotion`` beside the
repository; the data are CC-BY-NC and never part of lfd) and both tasks, the ground-truth
labels in the file and ``lfd segment``'s (``--segment``, which follows the trajectory that was
segmented, ``result.run.trajectory``), the recording is reproduced in the
skills and dmp modes (:func:`lfd.reproduce.reproduce`, the same steps as ``lfd reproduce``):
achieved or not, why not (the first failed skill and its reason, or the one-line refusal of a
task the robot cannot do), the final object error and how much slower than the person the
robot was (robot time / demonstrated time, :mod:`lfd.reproduce.timescale`). Prints a table and
the totals; exits 0 whether or not the tasks were achieved (a measurement, not a test).
"""

from __future__ import annotations

import argparse
import json
import sys
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context
from pathlib import Path
from typing import Any

DEFAULT_DIR = Path(__file__).resolve().parent.parent.parent / "shared" / "realmotion"
MODES = ("skills", "dmp")
TASKS = ("labels", "segment")


def run_crop(path: str) -> list[dict[str, Any]]:
    """Every task and mode of one crop (a worker process)."""
    from lfd.errors import LfdError
    from lfd.io import load
    from lfd.preprocessing import preprocess
    from lfd.reproduce import (
        PREPROCESSING,
        check_program,
        from_labels,
        from_segmentation,
        reproduce,
    )
    from lfd.segmentation import segment

    demo = load(path, images=False)
    labelled = preprocess(demo, **PREPROCESSING)
    seg = segment(demo)
    assert seg.run is not None
    segmented = seg.run.trajectory  # --segment: the robot follows what was segmented
    programs = {
        "labels": (labelled, from_labels(demo.labels, int(labelled.t_ns[0]))),
        "segment": (segmented, from_segmentation(seg, int(segmented.t_ns[0]))),
    }
    rows = []
    for task, (traj, program) in programs.items():
        for mode in MODES:
            row: dict[str, Any] = {
                "crop": Path(path).stem.removeprefix("manip_"),
                "task": task,
                "mode": mode,
                "skills": program.skills,
            }
            try:
                check_program(traj, program)
                r = reproduce(traj, program, mode)
            except LfdError as err:  # refused before running: one line
                row |= {"achieved": False, "why": f"refused: {err}", "slowdown": None}
                rows.append(row)
                continue
            why = next((f"{s.label()}: {s.reasons[0]}" for s in r.skills if not s.ok), None)
            row |= {
                "achieved": r.success,
                "why": None if r.success else (why or "no skill reported a failure"),
                "slowdown": r.slowdown,
                "robot_s": r.execution_time_s,
                "demo_s": r.demo_duration_s,
                "error_mm": max(o.position_error for o in r.objects) * 1000,
                "per_skill": [
                    {"skill": s.skill, "slowdown": s.slowdown, "ok": s.ok} for s in r.skills
                ],
            }
            rows.append(row)
    return rows


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("dir", nargs="?", default=str(DEFAULT_DIR), help="the realmotion folder")
    ap.add_argument("--jobs", type=int, default=2, help="worker processes (default 2)")
    ap.add_argument("--json", metavar="OUT", help="write every row as JSON")
    args = ap.parse_args()
    root = Path(args.dir)
    if not root.is_dir():
        print(f"reproduce_real: skipped: no real motion capture at {root} (see the docstring)")
        return 0
    crops = sorted(str(p) for p in root.glob("manip_*_*-*s.mcap"))
    if not crops:
        print(f"reproduce_real: skipped: no crops manip_*_<t0>-<t1>s.mcap in {root}")
        return 0
    with ProcessPoolExecutor(max(1, args.jobs), mp_context=get_context("spawn")) as pool:
        rows = [row for rs in pool.map(run_crop, crops) for row in rs]
    print(f"{'crop':28s} {'task':8s} {'mode':6s} {'ok':3s} {'slower':>7s} {'err mm':>7s}  why")
    for r in rows:
        slow = f"{r['slowdown']:.2f}x" if r.get("slowdown") else "-"
        err = f"{r['error_mm']:.1f}" if "error_mm" in r else "-"
        ok = "yes" if r["achieved"] else "no"
        print(
            f"{r['crop']:28s} {r['task']:8s} {r['mode']:6s} {ok:3s} {slow:>7s} {err:>7s}  ", end=""
        )
        print(r["why"] or "")
    print()
    for task in TASKS:
        for mode in MODES:
            sel = [r for r in rows if r["task"] == task and r["mode"] == mode]
            ok = sum(r["achieved"] for r in sel)
            slow = [r["slowdown"] for r in sel if r.get("slowdown")]
            mean = f", robot {sum(slow) / len(slow):.2f}x slower than the person" if slow else ""
            print(f"{task:8s} {mode:6s}: {ok}/{len(sel)} crops achieved{mean}")
    per: dict[str, list[float]] = {}
    for r in rows:
        for s in r.get("per_skill", []):
            if s["slowdown"]:
                per.setdefault(s["skill"], []).append(s["slowdown"])
    print(
        "slowdown per skill (median robot / demonstrated time): "
        + ", ".join(f"{k} {sorted(v)[len(v) // 2]:.1f}x" for k, v in sorted(per.items()))
    )
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
