"""How long reading, preprocessing and segmenting a long recording take, step by step.

The recordings are the shipped natural-style ``exp5`` recordings played end to end until 5, 30
and 60 minutes (``benches/segment_memory.py``'s ``long_demo``: a 30 Hz hand, three tagged boxes,
ground-truth labels), written with ``lfd.save``. Each step is timed in this process (median of
``--repeat`` runs), the commands in subprocesses (wall time from start to exit, peak resident
memory from ``os.wait4``):

- ``mcap iterate``: the reference: every record of the file iterated with the ``mcap`` package's
  own reader (``make_reader(f).iter_messages()``), decoding nothing;
- ``python load``: the pure-Python reader (``lfd.io.mcapfile.scan`` + protobuf decoding, the
  loader before the engine read MCAP);
- ``lfd.load``: the engine's reader (``crates/lfd-mcap``) and the arrays;
- ``preprocess``, ``segment``: ``lfd.preprocess``, ``lfd.segment`` of that;
- ``lfd segment``: ``lfd segment REC --json OUT``, whole command; ``lfd info``: ``lfd info REC``
  (summary section); ``info killed``: ``lfd info`` of the file cut at 60 % (no summary section).

Then the cold ``lfd segment recordings/exp1.mcap`` (a 15 s recording), with the split of one
run between imports, load, preprocess and segment.

Run: ``python benches/load_speed.py [--minutes 5 30 60] [--keep DIR]``.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).parent))


def timed(fn: Callable[[], Any], repeat: int) -> tuple[float, Any]:
    """Median wall seconds of ``repeat`` calls of ``fn`` and its last result."""
    times, out = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def command(args: list[str]) -> tuple[float, float, int]:
    """``python -m lfd.cli ARGS`` in a subprocess: wall seconds, peak RSS MB, exit status
    (:func:`segment_memory.measure`)."""
    from segment_memory import measure

    wall, peak, status, _ = measure([sys.executable, "-m", "lfd.cli", *args])
    return wall, peak, status


def mcap_iterate(path: Path) -> int:
    from mcap.reader import make_reader

    n = 0
    with open(path, "rb") as f:
        for _ in make_reader(f).iter_messages(log_time_order=False):
            n += 1
    return n


def python_load(path: Path) -> Any:
    from lfd.io.mcapfile import scan
    from lfd.io.reader import demonstration_of

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return demonstration_of(scan(path), images=False)


COLD = """
import time, warnings
t0 = time.perf_counter()
import lfd, lfd.cli, lfd.io, lfd.preprocessing, lfd.segmentation
t1 = time.perf_counter()
demo = lfd.load({path!r})
t2 = time.perf_counter()
method = lfd.Method.load("default")
traj = lfd.preprocess(demo, **method.preprocessing)
t3 = time.perf_counter()
lfd.segment(traj, method=method)
t4 = time.perf_counter()
print(t1 - t0, t2 - t1, t3 - t2, t4 - t3)
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--minutes", type=float, nargs="+", default=[5, 30, 60])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--keep", metavar="DIR", help="keep (and reuse) the generated recordings here")
    args = ap.parse_args()

    import lfd
    from lfd.io import save
    from segment_memory import long_demo

    tmp = Path(args.keep or tempfile.mkdtemp(prefix="lfd-loadspeed-"))
    tmp.mkdir(parents=True, exist_ok=True)
    cols = (
        "minutes",
        "MB",
        "messages",
        "mcap iterate",
        "python load",
        "lfd.load",
        "vs python",
        "vs iterate",
        "preprocess",
        "segment",
        "lfd segment",
        "peak MB",
        "lfd info",
        "info killed",
    )
    print(" ".join(f"{c:>12}" for c in cols), flush=True)
    for minutes in args.minutes:
        rec = tmp / f"exp5_{minutes:g}min.mcap"
        if not rec.exists():
            save(long_demo(minutes), rec)
        killed = tmp / f"exp5_{minutes:g}min_killed.mcap"
        if not killed.exists():
            data = rec.read_bytes()
            killed.write_bytes(data[: int(len(data) * 0.6)])
        it, n = timed(lambda rec=rec: mcap_iterate(rec), args.repeat)
        old, _ = timed(lambda rec=rec: python_load(rec), 1)
        new, demo = timed(lambda rec=rec: lfd.load(rec, images=False), args.repeat)
        prep, traj = timed(lambda demo=demo: lfd.preprocess(demo), args.repeat)
        seg, _ = timed(lambda traj=traj: lfd.segment(traj), args.repeat)
        wall, peak, status = command(["segment", str(rec), "--json", str(tmp / "out.json")])
        assert status == 0, f"lfd segment {rec} failed ({status})"
        info, _, status = command(["info", str(rec)])
        assert status == 0, f"lfd info {rec} failed ({status})"
        info_killed, _, status = command(["info", str(killed)])
        assert status == 0, f"lfd info {killed} failed ({status})"
        row = (
            f"{minutes:g}",
            f"{rec.stat().st_size / 1e6:.0f}",
            f"{n}",
            f"{it:.2f}",
            f"{old:.2f}",
            f"{new:.3f}",
            f"{old / new:.0f}x",
            f"{it / new:.1f}x",
            f"{prep:.2f}",
            f"{seg:.2f}",
            f"{wall:.2f}",
            f"{peak:.0f}",
            f"{info:.2f}",
            f"{info_killed:.2f}",
        )
        print(" ".join(f"{c:>12}" for c in row), flush=True)

    exp1 = ROOT / "recordings" / "exp1.mcap"
    walls = [command(["segment", str(exp1)])[0] for _ in range(args.repeat)]
    proc = subprocess.run(
        [sys.executable, "-c", COLD.format(path=str(exp1))], capture_output=True, text=True
    )
    imports, load, prep, seg = (float(v) for v in proc.stdout.split())
    print(
        f"\ncold `lfd segment recordings/exp1.mcap`: {statistics.median(walls):.2f} s wall "
        f"(median of {args.repeat}); one run's split: imports {imports:.2f} s, load {load:.3f} s, "
        f"preprocess {prep:.3f} s, segment {seg:.3f} s"
    )


if __name__ == "__main__":
    main()
