"""Is ``lfd.preprocess`` unchanged? Dump its output for every shipped recording, then compare
two dumps array by array (every array of the Trajectory and its ``meta``).

    # with the old checkout first, then this one
    PYTHONPATH=OLD/python python3 benches/preprocess_equivalence.py dump /tmp/old
    PYTHONPATH=python python3 benches/preprocess_equivalence.py dump /tmp/new
    python3 benches/preprocess_equivalence.py compare /tmp/old /tmp/new

``compare`` prints the largest absolute difference and every array whose shape, dtype, NaN
pattern or boolean values differ (exit status 1 if any, or if the difference exceeds 1e-9).
"""

from __future__ import annotations

import pickle
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1] / "recordings"
TOLERANCE = 1e-9


def recordings() -> list[Path]:
    return sorted(ROOT.glob("*.mcap")) + sorted((ROOT / "templates").rglob("*.mcap"))


def dump(out: Path) -> None:
    import lfd

    out.mkdir(parents=True, exist_ok=True)
    for path in recordings():
        key = str(path.relative_to(ROOT)).replace("/", "__")
        try:
            traj = lfd.preprocess(lfd.load(path, images=False))
        except Exception as err:  # the same recordings must fail alike
            (out / f"{key}.err").write_text(repr(err))
            continue
        arrays = {k: np.asarray(v) for k, v in vars(traj).items() if isinstance(v, np.ndarray)}
        np.savez(out / f"{key}.npz", **arrays)
        (out / f"{key}.meta.pkl").write_bytes(pickle.dumps(traj.meta))
    print(f"{len(recordings())} recordings from {lfd.__file__}")


def compare(old: Path, new: Path) -> int:
    worst, where, problems, n = 0.0, "", [], 0
    for f in sorted(old.glob("*.npz")):
        g = new / f.name
        if not g.exists():
            problems.append(f"missing {f.name}")
            continue
        a, b = np.load(f), np.load(g)
        if set(a.files) != set(b.files):
            problems.append(f"{f.name}: arrays {set(a.files) ^ set(b.files)}")
        for k in sorted(set(a.files) & set(b.files)):
            x, y = a[k], b[k]
            if x.shape != y.shape or x.dtype != y.dtype:
                problems.append(f"{f.name}:{k} {x.shape} {x.dtype} vs {y.shape} {y.dtype}")
            elif not np.issubdtype(x.dtype, np.floating):
                if not np.array_equal(x, y):
                    problems.append(f"{f.name}:{k} differs")
            elif not np.array_equal(np.isnan(x), np.isnan(y)):
                problems.append(f"{f.name}:{k} NaN pattern differs")
            else:
                ok = ~np.isnan(x)
                d = float(np.max(np.abs(x[ok] - y[ok]), initial=0.0))
                if d > worst:
                    worst, where = d, f"{f.name}:{k}"
        meta_a = pickle.loads(f.with_suffix(".meta.pkl").read_bytes())
        meta_b = pickle.loads(g.with_suffix(".meta.pkl").read_bytes())
        if meta_a != meta_b:
            problems.append(f"{f.name}: meta differs")
        n += 1
    errs = [sorted(p.name for p in d.glob("*.err")) for d in (old, new)]
    if errs[0] != errs[1]:
        problems.append(f"failing recordings differ: {errs[0]} vs {errs[1]}")
    print(f"{n} recordings compared; max |old - new| = {worst:.3e} {where}")
    for p in problems:
        print("  ", p)
    return int(bool(problems) or worst > TOLERANCE)


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "dump":
        dump(Path(sys.argv[2]))
    elif len(sys.argv) == 4 and sys.argv[1] == "compare":
        sys.exit(compare(Path(sys.argv[2]), Path(sys.argv[3])))
    else:
        sys.exit(__doc__)
