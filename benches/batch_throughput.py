"""Throughput of ``lfd segment`` over many recordings: --jobs 1, --jobs 2 and a local Ray.

200 recordings: 199 simulated demonstrations (the paper's experiments exp1-exp4, careful style,
seeds 400+, used nowhere else) plus one broken file (a recording cut short). Each mode runs the
real command, ``lfd segment DIR --jobs N [--ray] --json OUT``, in a subprocess (start-up
included), and the benchmark checks that the broken file is reported at its place in the JSON
list and the other 199 results are written, identical in every mode.

Reported: recordings per second per mode, each mode's ratio against ``--jobs 1`` (the
reference), the scaling efficiency from 1 to 2 processes ((T1 / T2) / 2, target >= 80 %), and
Ray's overhead per recording against the local pool of the same size ((T_ray - T_2) / N).
The machine may be shared: the load average before each mode, the CPU seconds the command and
its processes used and how many cores that kept busy on average (CPU / wall) are printed, so a
lack of scaling from other load shows. Every mode runs one engine/BLAS thread per process (:data:`lfd.batch.WORKER_ENV`), so
``--jobs 1`` is one core and ``--jobs 2`` two.

Run: ``MUJOCO_GL=egl python benches/batch_throughput.py [--n 200] [--cache DIR]``. The demos are
generated once into ``--cache`` (in parallel, with :func:`lfd.batch.run_batch`) and reused.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from functools import partial
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")

SEED0 = 400
"""First seed of the benchmark's demos (the shipped sets use 0-8, 100-105 and 1000)."""


def _make(job: tuple[str, int], out: str) -> str:
    from lfd.sim.sets import record

    task, seed = job
    path = Path(out) / f"{task}_{seed}.mcap"
    if not path.exists():
        record(task, seed, path.with_suffix(".tmp"))
        path.with_suffix(".tmp").rename(path)
    return str(path)


def generate(n: int, cache: Path) -> Path:
    """A folder of ``n - 1`` simulated demos (made once into ``cache/demos``, linked) and one
    broken recording (its first 2000 bytes: not a usable recording)."""
    from lfd.batch import run_batch
    from lfd.sim.tasks import EXPERIMENTS

    demos = cache / "demos"
    demos.mkdir(parents=True, exist_ok=True)
    jobs = [(EXPERIMENTS[k % len(EXPERIMENTS)], SEED0 + k) for k in range(n - 1)]
    t0 = time.perf_counter()
    made = run_batch(partial(_make, out=str(demos)), jobs, jobs=2)
    bad = [r for r in made if not r.ok]
    if bad:
        raise SystemExit(f"could not simulate {bad[0].item}: {bad[0].error}")
    folder = cache / f"n{n}"
    folder.mkdir(exist_ok=True)
    for old in folder.glob("*.mcap"):
        old.unlink()
    for r in made:
        (folder / Path(str(r.value)).name).symlink_to(Path(str(r.value)).resolve())
    broken = folder / "exp0_broken.mcap"  # sorts first among the exp*: its place is checked
    broken.write_bytes(Path(str(made[0].value)).read_bytes()[:2000])
    print(f"{n - 1} demos + 1 broken file in {folder} ({time.perf_counter() - t0:.1f} s)")
    return folder


def run_mode(folder: Path, out: Path, extra: list[str]) -> tuple[float, float, int, list[dict]]:
    """Run the command: (wall s, CPU s of it and its processes, exit status, JSON list)."""
    import resource

    from lfd.batch import WORKER_ENV

    cmd = [sys.executable, "-m", "lfd.cli", "segment", str(folder), "--json", str(out), *extra]
    # one thread per process in every mode, --jobs 1 too (in-process it would otherwise use
    # every core through the engine's thread pool): 1 -> 2 processes is 1 -> 2 cores
    env = {**os.environ, **WORKER_ENV}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False, env=env)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
    return wall, cpu, proc.returncode, json.loads(out.read_text())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=200, help="recordings, one of them broken (200)")
    ap.add_argument(
        "--cache",
        type=Path,
        default=Path(tempfile.gettempdir()) / "lfd-bench-batch",
        help="where the simulated demos are kept between runs",
    )
    args = ap.parse_args()
    folder = generate(args.n, args.cache)
    files = sorted(folder.glob("*.mcap"))
    n = len(files)
    print(f"load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())} "
          f"({os.cpu_count()} cores)")  # fmt: skip
    modes = [("--jobs 1", ["--jobs", "1"]), ("--jobs 2", ["--jobs", "2"]),
             ("local Ray, 2 CPUs", ["--jobs", "2", "--ray"])]  # fmt: skip
    walls: dict[str, float] = {}
    cpus: dict[str, float] = {}
    docs: dict[str, list[dict]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name, extra in modes:
            load = os.getloadavg()[0]
            wall, cpu, status, doc = run_mode(folder, Path(tmp) / "out.json", extra)
            failed = [d for d in doc if "error" in d]
            assert status == 2, f"{name}: exit status {status}, expected 2 (one file failed)"
            assert len(doc) == n and [d["recording"] for d in doc] == [str(f) for f in files]
            assert [d["recording"] for d in failed] == [str(folder / "exp0_broken.mcap")], name
            walls[name], cpus[name], docs[name] = wall, cpu, doc
            # Ray's processes are not the command's children: their CPU time is not counted
            use = (
                "CPU n/a (Ray's daemons)"
                if "--ray" in extra
                else (
                    f"CPU {cpu:6.1f} s ({1e3 * cpu / n:5.0f} ms/recording, {cpu / wall:.2f} cores busy)"
                )
            )
            print(f"{name:18s} {wall:7.1f} s  {n / wall:6.2f} recordings/s  {use}  "
                  f"load {load:.1f}  ({n - len(failed)} results, {len(failed)} error: "
                  f"{failed[0]['error'][:40]}...)")  # fmt: skip
        # the fixed cost (pool or Ray start-up) apart from the per-recording cost: the same
        # modes on two recordings (the broken one and the first demo)
        small = Path(tmp) / "small"
        small.mkdir()
        for f in files[:2]:
            (small / f.name).symlink_to(f.resolve())
        fixed = {
            name: run_mode(small, Path(tmp) / "small.json", extra)[0] for name, extra in modes[1:]
        }
    ref = walls["--jobs 1"]
    assert docs["--jobs 2"] == docs["--jobs 1"] == docs["local Ray, 2 CPUs"], "results differ"
    print("\nratios against --jobs 1 (the reference): throughput")
    for name in walls:
        print(f"  {name:18s} x{ref / walls[name]:.2f}")
    eff = ref / walls["--jobs 2"] / 2
    print(f"scaling efficiency 1 -> 2 processes: {100 * eff:.0f} % (target >= 80 %)")
    # what the parallel run costs in CPU per recording (worker start-up, passing results
    # back): the efficiency on two otherwise idle cores, whatever the load here was
    print(f"CPU per recording --jobs 2 / --jobs 1: {cpus['--jobs 2'] / cpus['--jobs 1']:.2f} "
          f"(work efficiency {100 * cpus['--jobs 1'] / cpus['--jobs 2']:.0f} %)")  # fmt: skip
    ray, pool = "local Ray, 2 CPUs", "--jobs 2"
    overhead = (walls[ray] - walls[pool]) / n
    start = fixed[ray] - fixed[pool]
    marginal = ((walls[ray] - fixed[ray]) - (walls[pool] - fixed[pool])) / (n - 2)
    print(f"Ray overhead vs the local pool: {walls[ray] - walls[pool]:+.1f} s in all, "
          f"{1e3 * overhead:+.1f} ms per recording; of which start-up {start:+.1f} s "
          f"(2 recordings: pool {fixed[pool]:.1f} s, Ray {fixed[ray]:.1f} s) and "
          f"{1e3 * marginal:+.1f} ms per further recording")  # fmt: skip
    print(f"load average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
