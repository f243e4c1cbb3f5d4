"""Table II (path length replay vs skills vs dmp) and success rates over simulated demos.

Usage::

    MUJOCO_GL=egl python benches/reproduce_table.py --seeds 0 1 2 --json table.json

Experiments: the paper's exp1-4 and exp5 (6-10 pick-carry-place cycles of one box in a row; its
demos differ in length, so its path lengths are not comparable across seeds, only the ratios).
For every experiment and seed: simulate a demonstration (``lfd.sim``), preprocess it, execute the
ground-truth task program with replay / skills / dmp, and once more with dmp after displacing the
first manipulated object by 5-10 cm in a random direction clear of the other objects (and such
that the re-grounded task fits: :func:`lfd.reproduce.randomise.check_layout`).
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np


def _displacement(rng: np.random.Generator, traj, program) -> dict[str, tuple[float, float]]:  # type: ignore[no-untyped-def]
    from lfd.reproduce.randomise import check_layout

    target = next(s.object for s in program.segments if s.skill in ("pick_up", "push", "locate"))
    names = list(traj.object_names)
    p0 = np.nan_to_num(np.asarray(traj.object_position)[:, 0, :2])
    k = names.index(target)
    for _ in range(200):
        r = rng.uniform(0.05, 0.10)
        a = rng.uniform(-np.pi, np.pi)
        d = r * np.array([np.cos(a), np.sin(a)])
        new = p0[k] + d
        others = np.delete(p0, k, axis=0)
        disp = {target: (float(d[0]), float(d[1]))}
        # clear of the others, and the re-grounded task fits (nothing placed into another box)
        if (
            np.min(np.linalg.norm(others - new, axis=1)) > 0.10
            and check_layout(traj, program, disp) is None
        ):
            return disp
    return {target: (0.0, 0.0)}


def main() -> None:
    from lfd.preprocessing import preprocess
    from lfd.reproduce import PREPROCESSING, from_labels, reproduce
    from lfd.sim import simulate

    ap = argparse.ArgumentParser()
    ap.add_argument("--experiments", nargs="+", default=["exp1", "exp2", "exp3", "exp4", "exp5"])
    ap.add_argument("--seeds", nargs="+", type=int, default=[3])
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    rows = []
    for exp in args.experiments:
        for seed in args.seeds:
            demo = simulate(exp, seed=seed).demo
            traj = preprocess(demo, **PREPROCESSING)
            program = from_labels(demo.labels, int(traj.t_ns[0]))
            row: dict = {"experiment": exp, "seed": seed}
            for mode in ("replay", "skills", "dmp"):
                t = time.perf_counter()
                r = reproduce(traj, program, mode)
                row[mode] = r.to_json() | {"wall_s": time.perf_counter() - t}
            disp = _displacement(np.random.default_rng(1000 + seed), traj, program)
            r = reproduce(traj, program, "dmp", displace=disp)
            row["dmp_displaced"] = r.to_json()
            rows.append(row)
            print(
                f"{exp} seed {seed}: length replay {row['replay']['path_length_m']:.3f} "
                f"skills {row['skills']['path_length_m']:.3f} dmp {row['dmp']['path_length_m']:.3f}"
                f" | success replay {row['replay']['success']} skills {row['skills']['success']}"
                f" dmp {row['dmp']['success']} dmp-displaced {row['dmp_displaced']['success']}"
                f" {disp}",
                flush=True,
            )
    print(
        "\nexperiment  replay  skills (ratio)  dmp (ratio)  success replay/skills/dmp/dmp-displaced"
    )
    for exp in args.experiments:
        sel = [r for r in rows if r["experiment"] == exp]
        L = {m: np.mean([r[m]["path_length_m"] for r in sel]) for m in ("replay", "skills", "dmp")}
        S = {
            m: np.mean([r[m]["success"] for r in sel])
            for m in ("replay", "skills", "dmp", "dmp_displaced")
        }
        print(
            f"{exp:10s}  {L['replay']:.4f}  {L['skills']:.4f} ({100 * L['skills'] / L['replay']:.1f}%)"
            f"  {L['dmp']:.4f} ({100 * L['dmp'] / L['replay']:.1f}%)  "
            + "/".join(f"{100 * S[m]:.0f}%" for m in S)
        )
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=1)


if __name__ == "__main__":
    main()
