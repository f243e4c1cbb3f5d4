"""DTW distance of two length-200 series: lfd's Rust engine vs dtaidistance's C ``distance_fast``.

Run: ``python benches/dtw_vs_dtaidistance.py [--length 200] [--repeat 2000]``. Both run in this
process on the same float64 arrays; the median time per call is reported (all wrapper overhead
included: ``lfd.dtw.dtw_distance`` converts and checks its input in Python first).
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

import numpy as np


def median_us(fn: Callable[[], object], repeat: int) -> float:
    """Median wall time of ``fn()`` in microseconds (after a warm-up)."""
    for _ in range(min(50, repeat)):
        fn()
    times = np.empty(repeat)
    for k in range(repeat):
        t0 = time.perf_counter_ns()
        fn()
        times[k] = time.perf_counter_ns() - t0
    return float(np.median(times)) * 1e-3


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--length", type=int, default=200)
    parser.add_argument("--repeat", type=int, default=2000)
    args = parser.parse_args()

    from dtaidistance import dtw as dd
    from lfd import _hmmseg
    from lfd.dtw import dtw_distance

    rng = np.random.default_rng(0)
    a = rng.normal(size=args.length).cumsum()
    b = rng.normal(size=args.length).cumsum()
    a2, b2 = a[:, None].copy(), b[:, None].copy()
    ours, ref = dtw_distance(a, b), dd.distance_fast(a, b)
    assert abs(ours - ref) <= 1e-9 * ref, (ours, ref)

    rows = [
        ("dtaidistance.dtw.distance_fast", median_us(lambda: dd.distance_fast(a, b), args.repeat)),
        ("lfd.dtw.dtw_distance", median_us(lambda: dtw_distance(a, b), args.repeat)),
        (
            "lfd._hmmseg.dtw_distance (raw)",
            median_us(lambda: _hmmseg.dtw_distance(a2, b2), args.repeat),
        ),
    ]
    base = rows[0][1]
    print(f"DTW distance, two random walks of length {args.length}, median of {args.repeat} calls")
    for name, us in rows:
        print(f"  {name:34s} {us:9.1f} us   speed-up vs dtaidistance: {base / us:5.2f}x")
    print(f"  distance: lfd {ours:.6f}  dtaidistance {ref:.6f}")


if __name__ == "__main__":
    main()
