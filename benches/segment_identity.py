"""Dump ``lfd.segment`` results of a set of recordings to compare two checkouts bit for bit.

    PYTHONPATH=/work/main/python python3 benches/segment_identity.py dump before.pkl
    PYTHONPATH=python python3 benches/segment_identity.py dump after.pkl
    python3 benches/segment_identity.py compare before.pkl after.pkl [TOLERANCE]

Every segment field (skill, start, end, times, object, score, confidence, margin, params) is
compared as its ``repr`` (NaN equal to NaN), for the default method on complete recordings,
``complete=False`` (the live segmentation's batch runs), the paper's method and the baselines.
"""

from __future__ import annotations

import glob
import math
import pickle
import sys
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent


def _key(seg: Any) -> str:
    return repr(
        (
            seg.skill,
            seg.start,
            seg.end,
            seg.start_s,
            seg.end_s,
            seg.start_ns,
            seg.end_ns,
            seg.object,
            seg.score,
            seg.confidence,
            seg.margin,
            sorted(seg.params.items()),
        )
    )


def files(extra: list[str]) -> list[str]:
    out = sorted(glob.glob(str(ROOT / "recordings/*.mcap")))
    out += sorted(glob.glob(str(ROOT / "recordings/templates/**/*.mcap"), recursive=True))
    return out + extra


def dump(path: str, extra: list[str]) -> None:
    import lfd
    from lfd.segmentation import PAPER, gripper_segmentation, proximity_segmentation

    res: dict[str, Any] = {}
    for k, f in enumerate(files(extra)):
        name = f.replace(str(ROOT) + "/", "")
        t0 = time.perf_counter()
        demo = lfd.load(f, images=False)
        for label, kwargs in (("default", {}), ("live", {"complete": False})):
            try:
                s = lfd.segment(demo, **kwargs)
                res[f"{name}:{label}"] = ([_key(x) for x in s.segments], list(s.warnings))
            except Exception as e:  # an error is a result too
                res[f"{name}:{label}"] = repr(e)
        if k % 8 == 0 or "exp5" in f:  # a sample for the other methods
            try:
                tr = lfd.preprocess(demo)
                s = lfd.segment(tr, **PAPER)
                res[f"{name}:paper"] = ([_key(x) for x in s.segments], list(s.warnings))
                for fn in (gripper_segmentation, proximity_segmentation):
                    s = fn(tr)
                    res[f"{name}:{fn.__name__}"] = [_key(x) for x in s.segments]
            except Exception as e:
                res[f"{name}:other"] = repr(e)
        print(f"{name} {time.perf_counter() - t0:.1f} s", flush=True)
    Path(path).write_bytes(pickle.dumps(res))


def _close(x: Any, y: Any, tol: float) -> bool:
    """The same segments, their score, confidence and margin (the last three of each key)
    within ``tol`` relative; everything else equal."""
    if isinstance(x, str) or isinstance(y, str) or x[1] != y[1] or len(x[0]) != len(y[0]):
        return False
    env = {"nan": math.nan, "inf": math.inf}
    for kx, ky in zip(x[0], y[0], strict=True):
        # our own repr of tuples of numbers and names (nan, inf as names)
        sx, sy = eval(kx, env), eval(ky, env)
        if sx[:8] != sy[:8] or sx[11:] != sy[11:]:
            return False
        for u, v in zip(sx[8:11], sy[8:11], strict=True):
            same = u == v or (math.isnan(u) and math.isnan(v))
            if not same and not abs(u - v) <= tol * max(abs(u), abs(v), 1.0):
                return False
    return True


def compare(a: str, b: str, tol: float = 0.0) -> int:
    """Print the results that differ; with ``tol`` > 0, a result whose segments are the same
    and whose scores, confidences and margins agree within ``tol`` (relative) counts as equal
    and is counted apart."""
    ra, rb = pickle.loads(Path(a).read_bytes()), pickle.loads(Path(b).read_bytes())
    differ = [k for k in sorted(set(ra) | set(rb)) if ra.get(k) != rb.get(k)]
    close = [k for k in differ if tol > 0 and k in ra and k in rb and _close(ra[k], rb[k], tol)]
    bad = [k for k in differ if k not in close]
    for k in bad:
        print("DIFFERS:", k)
    print(
        f"{len(ra)} / {len(rb)} results, {len(differ) - len(close)} differ"
        + (
            f", {len(close)} more equal within {tol:g} (scores, confidences, margins)"
            if tol
            else ""
        )
    )
    return 1 if bad or set(ra) != set(rb) else 0


if __name__ == "__main__":
    if sys.argv[1] == "dump":
        dump(sys.argv[2], sys.argv[3:])
    else:
        sys.exit(compare(sys.argv[2], sys.argv[3], float(sys.argv[4]) if sys.argv[4:] else 0.0))
