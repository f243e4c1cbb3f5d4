"""How soon could a live skill settle? A bound for every rule built on runs of the recording so far.

Run::

    python benches/live_latency_bound.py "/tmp/lfd_live_perceived/*/exp*_9403.mcap"

The live segmenter (``lfd.segmentation.live``, docs/live.md) runs the batch segmentation on the
recording so far every ``every_s`` and settles a skill once the runs agree on it. Whatever rule
decides that, it cannot settle a skill correctly before the runs stop changing it. For each
one-hand recording this replays the file's messages through ``LiveSegmentation`` (the default
rules), keeps every run it makes, and reports per skill (against the batch ``lfd.segment`` of the
whole file, the last segment left out, recordings whose live sequence equals batch only):

* **settled**: when the live segmenter settled it, minus the batch segment's end (docs/live.md's
  latency);
* **bound, open runs**: the first run from which on *every* later run of the recording so far
  has the batch skills and objects up to this one, this one ending within ``tolerance_s`` of the
  batch end and followed by another segment (an oracle: it knows which runs are the last to
  change; no rule that looks only at the runs so far can be both earlier and always right);
* **bound, with the check runs**: the same over the open runs and the check runs with every
  unseen object at rest (what a hidden tag could still change).

Median and quartiles per skill and over all skills. Prints a table; ``--json`` writes the
numbers.
"""

from __future__ import annotations

import argparse
import glob
import json
import warnings
from collections import defaultdict
from typing import Any

import numpy as np


def replay(path: str) -> dict[str, Any] | None:
    """Batch and live results of one recording and every run the live segmenter made."""
    import lfd
    from lfd.segmentation.live import LiveSegmentation, demo_messages

    runs: list[tuple[str, int, list[tuple[str, str | None, int]]]] = []

    def keep(kind: str, now: int, run: Any) -> Any:
        if run is not None:
            runs.append((kind, now, [(s.skill, s.object, int(s.end_ns)) for s in run.segments]))
        return run

    class Recorded(LiveSegmentation):
        def _run(self, *, complete: bool = False) -> Any:
            run = super()._run(complete=complete)
            return run if complete else keep("open", int(self._now or 0), run)

        def _run_at_rest(self) -> Any:
            return keep("rest", int(self._now or 0), super()._run_at_rest())

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        demo = lfd.load(path, images=False)
        if demo.other_hand is not None:
            return None
        batch = [(s.skill, s.object, int(s.end_ns)) for s in lfd.segment(demo).segments]
        live = Recorded.for_demonstration(demo)
        for msg in demo_messages(demo):
            live.push(msg)
        live.finish()
    got = [(s.skill, s.object) for s in live.result().segments]
    return {
        "batch": batch,
        "equal": got == [(a, b) for a, b, _ in batch],
        "settled": [int(t) for t in live.settled_ns],
        "tolerance_ns": live.tolerance_ns,
        "runs": runs,
    }


def bound(rec: dict[str, Any], k: int, kinds: tuple[str, ...]) -> int:
    """The first run time from which every later run of ``kinds`` has batch segment ``k``."""
    batch, tol = rec["batch"], rec["tolerance_ns"]
    want = [(a, b) for a, b, _ in batch[: k + 1]]
    first = None
    for kind, now, segs in rec["runs"]:
        if kind not in kinds:
            continue
        ok = (
            len(segs) >= k + 2
            and [(a, b) for a, b, _ in segs[: k + 1]] == want
            and abs(segs[k][2] - batch[k][2]) <= tol
        )
        first = (first if first is not None else now) if ok else None
    return first if first is not None else rec["settled"][k]  # else: only the end tells


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("pattern", help="glob of perceived one-hand recordings (benches/segment_live)")
    ap.add_argument("--json", help="write the figures here")
    args = ap.parse_args()
    cols = {
        "settled": None,
        "bound, open runs": ("open",),
        "bound, with check runs": ("open", "rest"),
    }
    lat: dict[str, dict[str, list[float]]] = {c: defaultdict(list) for c in cols}
    n = equal = 0
    for path in sorted(glob.glob(args.pattern)):
        rec = replay(path)
        if rec is None:
            continue
        n += 1
        print(f"{path}: {len(rec['runs'])} runs, live {'=' if rec['equal'] else '!='} batch")
        if not rec["equal"]:
            continue
        equal += 1
        for k, (skill, _, end) in enumerate(rec["batch"][:-1]):
            for c, kinds in cols.items():
                t = rec["settled"][k] if kinds is None else bound(rec, k, kinds)
                for key in (skill, "all"):
                    lat[c][key].append((t - end) * 1e-9)
    print(
        f"\n{equal}/{n} recordings equal to batch; latency after the batch end (s), median (p25-p75)"
    )
    skills = sorted(lat["settled"], key=lambda s: (s == "all", s))
    print(f"{'skill':10s} {'n':>4s}  " + "  ".join(f"{c:>24s}" for c in cols))
    for s in skills:
        cells = []
        for c in cols:
            v = np.asarray(lat[c][s])
            cells.append(
                f"{np.median(v):5.2f} ({np.percentile(v, 25):.2f}-{np.percentile(v, 75):.2f})"
            )
        print(f"{s:10s} {len(lat['settled'][s]):4d}  " + "  ".join(f"{x:>24s}" for x in cells))
    if args.json:
        with open(args.json, "w") as f:
            json.dump({c: dict(v) for c, v in lat.items()}, f, indent=1)


if __name__ == "__main__":
    main()
