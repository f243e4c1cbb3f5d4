"""Two hands segmented together on real motion capture, and what two hands cost
(docs/results.md, "Two hands").

Run: ``python benches/bimanual.py [DIR] [--labels LABELS] [--minutes M] [--json OUT]`` (DIR:
``../shared/realmotion/bimanual`` beside the repository; without it the bench says it skipped
and exits 0).

DIR holds ManipNet's whole sequences converted once per hand (CC-BY-NC 4.0: read them there,
never copy them or anything derived from them into this repository; ../README.md):
``manip_<seq>.right.mcap`` and ``manip_<seq>.left.mcap``, on one clock with one object track.
Each pair is merged in memory into one two-hand demonstration (the right file's objects, each
file's labels in its hand's lane) and segmented as a user's two-hand ``lfd segment`` does
(``lfd.segment_hands``); the change-point + contact-rule baseline runs on each hand alone.
Scored on the whole files, nothing excluded, per hand: frame accuracy, exact sequence,
boundary error, predicted / true segments; and the handovers (found within 0.3 s, false).

``--labels`` is a folder of corrected labels (``manip_<seq>.<side>.labels.json``, seconds
from the first sample) and ground-truth handovers (``manip_<seq>.handovers.json``: giver, taker,
start_ns, end_ns, object) kept outside the repository; without it each file's own one-hand
labels are the truth and no handover is scored.

Cost: a two-hand demonstration of ``--minutes`` minutes (the takes played end to end) is
segmented in a child process by ``lfd.segment_hands`` and its right hand alone by
``lfd.segment``: CPU seconds (the less of two runs; wall seconds beside), peak memory of each
process, and their ratios (target <= 2x).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import resource
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_DIR = ROOT.parent / "shared" / "realmotion" / "bimanual"


def load_pair(right: Path, labels: Path | None) -> Any:
    """The two-hand demonstration of ``manip_<seq>.right.mcap`` and its ``.left`` file (with
    the corrected labels and handovers of ``labels`` when given)."""
    import lfd
    from lfd.demo import Demonstration, Handover, SkillLabel

    seq = right.name.removesuffix(".right.mcap")
    r, l_ = lfd.load(right), lfd.load(right.with_name(f"{seq}.left.mcap"))
    t0 = r.start_ns
    lanes: list[SkillLabel] = []
    handovers: list[Handover] = []
    for side, demo in (("right", r), ("left", l_)):
        got = labels / f"{seq}.{side}.labels.json" if labels else None
        if got is not None and got.is_file():
            lanes += [
                SkillLabel(
                    x["skill"],
                    t0 + round(x["start_s"] * 1e9),
                    t0 + round(x["end_s"] * 1e9),
                    x.get("object"),
                    hand=side,
                )
                for x in json.loads(got.read_text())
            ]
        else:
            lanes += [dataclasses.replace(lab, hand=side) for lab in demo.labels]
    ho = labels / f"{seq}.handovers.json" if labels else None
    if ho is not None and ho.is_file():
        handovers = [
            Handover(h["start_ns"], h["end_ns"], h["giver"], h["taker"], h.get("object"))
            for h in json.loads(ho.read_text())
        ]
    return Demonstration(
        hand=r.hand,
        other_hand=l_.hand,
        objects=r.objects,
        labels=lanes,
        metadata={k: v for k, v in r.metadata.items() if k != "hand"},
        handovers=handovers,
    )


def score(demo: Any) -> dict[str, Any]:
    """lfd (both hands together) and the change-point baseline (each hand alone) on ``demo``."""
    import lfd
    from lfd.segmentation import changepoint_segmentation
    from lfd.segmentation.metrics import all_metrics, handover_scores, segment_ratio

    t = time.perf_counter()
    hands = lfd.segment_hands(demo)
    seconds = time.perf_counter() - t
    out: dict[str, Any] = {"seconds": seconds, "lfd": {}, "changepoint": {}}
    for side in demo.sides:
        truth = demo.labels_of(side)
        for name, segs in (
            ("lfd", hands.lanes[side].segments),
            ("changepoint", changepoint_segmentation(demo.one_hand(side)).segments),
        ):
            m = all_metrics(segs, truth)
            out[name][side] = {
                "frame_accuracy": m["frame_accuracy"],
                "exact": bool(m["sequence_match"]),
                "boundary_error_s": m["boundary_error_s"],
                "predicted": len(segs),
                "true": len(truth),
                "ratio": segment_ratio(segs, truth),
            }
    out["handovers"] = handover_scores(hands.handovers, demo.handovers)
    out["handovers_found"] = [
        {"giver": h.giver, "taker": h.taker, "end_s": (h.end_ns - demo.start_ns) * 1e-9}
        for h in hands.handovers
    ]
    return out


def _tile(demo: Any, minutes: float) -> Any:
    """``demo`` played end to end until it lasts ``minutes`` (labels dropped)."""
    from lfd.demo import Demonstration, HandTrack, ObjectTrack

    period = demo.end_ns - demo.start_ns + 33_333_333
    reps = max(1, math.ceil(minutes * 60e9 / period))

    def hand(h: HandTrack) -> HandTrack:
        return HandTrack(
            np.concatenate([h.t_ns + k * period for k in range(reps)]),
            np.concatenate([h.keypoints] * reps),
            np.concatenate([h.confidence] * reps),
            side=h.side,
        )

    def obj(o: ObjectTrack) -> ObjectTrack:
        return dataclasses.replace(
            o,
            t_ns=np.concatenate([o.t_ns + k * period for k in range(reps)]),
            position=np.concatenate([o.position] * reps),
            quaternion=np.concatenate([o.quaternion] * reps),
            visible=np.concatenate([o.visible] * reps),
        )

    return Demonstration(
        hand=hand(demo.hand),
        other_hand=hand(demo.other_hand),
        objects={k: obj(o) for k, o in demo.objects.items()},
    )


def cost_child(data: Path, minutes: float, hands: int) -> None:
    """In this process: segment ``minutes`` of two-hand motion (``hands`` = 2: both hands
    together; 1: the right hand alone); print seconds and peak memory as JSON."""
    import lfd

    first = sorted(data.glob("manip_*.right.mcap"))[0]
    demo = _tile(load_pair(first, None), minutes)
    one = demo.one_hand("right") if hands == 1 else None
    base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    t, cpu = time.perf_counter(), time.process_time()
    if hands == 1:
        lfd.segment(one)
    else:
        lfd.segment_hands(demo)
    seconds, cpu = time.perf_counter() - t, time.process_time() - cpu
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(json.dumps({"seconds": seconds, "cpu_s": cpu, "peak_mb": peak, "before_mb": base}))


def cost(data: Path, minutes: float) -> dict[str, Any]:
    """Seconds and peak memory of one hand and of two, each in its own child process."""
    out: dict[str, Any] = {"minutes": minutes}
    for _ in range(2):  # the faster of two runs each (the machine is shared)
        for hands in (1, 2):
            cmd = [sys.executable, __file__, str(data), "--cost-child", str(hands)]
            cmd += ["--minutes", str(minutes)]
            got = subprocess.run(cmd, capture_output=True, text=True, check=True)
            run = json.loads(got.stdout.strip().splitlines()[-1])
            best = out.get(f"{hands}_hand")
            if best is None or run["cpu_s"] < best["cpu_s"]:
                out[f"{hands}_hand"] = run
    one, two = out["1_hand"], out["2_hand"]
    out["time_ratio"] = two["cpu_s"] / one["cpu_s"]
    out["wall_ratio"] = two["seconds"] / one["seconds"]
    out["memory_ratio"] = two["peak_mb"] / one["peak_mb"]
    return out


def _row(name: str, per: dict[str, list[dict[str, Any]]], side: str) -> str:
    rows = per[side]
    fa = np.mean([r["frame_accuracy"] for r in rows])
    exact = sum(r["exact"] for r in rows)
    be = np.nanmean([r["boundary_error_s"] for r in rows])
    pred, true = sum(r["predicted"] for r in rows), sum(r["true"] for r in rows)
    return (
        f"| {name} | {side} | {exact}/{len(rows)} | {100 * fa:.1f} % | {be:.2f} s | "
        f"x{pred / true:.2f} ({pred}/{true}) |"
    )


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("data", nargs="?", type=Path, default=DEFAULT_DIR)
    ap.add_argument("--labels", type=Path, help="corrected labels and handovers (outside the repo)")
    ap.add_argument("--minutes", type=float, default=60.0, help="length of the cost run (60)")
    ap.add_argument("--no-cost", action="store_true", help="skip the cost run")
    ap.add_argument("--json", type=Path, help="write every figure here")
    ap.add_argument("--cost-child", type=int, choices=(1, 2), help=argparse.SUPPRESS)
    args = ap.parse_args()
    if not args.data.is_dir():
        print(f"skipped: {args.data} is not here (ManipNet bimanual, ../shared/realmotion)")
        return 0
    if args.cost_child is not None:
        cost_child(args.data, args.minutes, args.cost_child)
        return 0
    doc: dict[str, Any] = {"data": str(args.data), "labels": str(args.labels), "takes": {}}
    per: dict[str, dict[str, list[dict[str, Any]]]] = {"lfd": {}, "changepoint": {}}
    handovers = {"true": 0.0, "found": 0.0, "false": 0.0}
    for right in sorted(args.data.glob("manip_*.right.mcap")):
        seq = right.name.removesuffix(".right.mcap")
        got = score(load_pair(right, args.labels))
        doc["takes"][seq] = got
        for name in per:
            for side, r in got[name].items():
                per[name].setdefault(side, []).append(r)
        for k in handovers:
            handovers[k] += got["handovers"][k]
        cells = "  ".join(
            f"{side} {100 * got['lfd'][side]['frame_accuracy']:.1f}% "
            f"({got['lfd'][side]['predicted']}/{got['lfd'][side]['true']}; change points "
            f"{100 * got['changepoint'][side]['frame_accuracy']:.1f}%)"
            for side in got["lfd"]
        )
        h = got["handovers"]
        print(f"{seq}: {cells}  handovers {h['found']:.0f}/{h['true']:.0f}, {h['false']:.0f} false")
    print("\n| method | hand | exact | frame accuracy | boundary error | segments |")
    print("|---|---|---|---|---|---|")
    for name in per:
        for side in per[name]:
            print(_row("lfd.segment_hands" if name == "lfd" else "change points", per[name], side))
    print(
        f"\nhandovers: {handovers['found']:.0f}/{handovers['true']:.0f} found within 0.3 s, "
        f"{handovers['false']:.0f} false"
    )
    doc["summary"] = {
        name: {
            side: {
                "frame_accuracy": float(np.mean([r["frame_accuracy"] for r in rows])),
                "exact": int(sum(r["exact"] for r in rows)),
                "ratio": sum(r["predicted"] for r in rows) / sum(r["true"] for r in rows),
            }
            for side, rows in per[name].items()
        }
        for name in per
    }
    doc["handovers"] = handovers
    if not args.no_cost:
        c = cost(args.data, args.minutes)
        doc["cost"] = c
        print(
            f"\ncost, {args.minutes:g} minutes: one hand {c['1_hand']['cpu_s']:.1f} s CPU "
            f"({c['1_hand']['seconds']:.1f} s), {c['1_hand']['peak_mb']:.0f} MB; two hands "
            f"{c['2_hand']['cpu_s']:.1f} s CPU ({c['2_hand']['seconds']:.1f} s), "
            f"{c['2_hand']['peak_mb']:.0f} MB (x{c['time_ratio']:.2f} CPU time, "
            f"x{c['wall_ratio']:.2f} wall, x{c['memory_ratio']:.2f} memory)"
        )
    if args.json:
        args.json.write_text(json.dumps(doc, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
