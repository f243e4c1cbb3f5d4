"""Two-hand takes of real motion capture on the two-arm ALOHA: ManipNet's 7 bimanual sequences
(../shared/realmotion/bimanual) reproduced by ``lfd reproduce TAKE.right.mcap TAKE.left.mcap
--robot aloha`` in the skills and DMP modes (docs/reproduce.md, "Two arms").

Usage::

    MUJOCO_GL=egl python benches/reproduce_bimanual.py [DIR] [--modes skills dmp] [--labels DIR]
        [--json OUT]

DIR holds ``manip_<seq>.right.mcap`` and ``manip_<seq>.left.mcap`` (one file per hand on one
clock; CC-BY-NC 4.0: read there, never copied into this repository). DIR defaults to
``../shared/realmotion/bimanual`` beside the repository (beside the main checkout when run from
a git worktree); without the takes there the bench says it skipped and exits 0. Each pair is joined as the command joins it (``lfd.io.merge_hands``),
its two-hand program made of the files' own labels (``--labels``: corrected labels and
handovers kept outside the repository, as ``benches/bimanual.py`` reads them) and run on the two
arms (:func:`lfd.reproduce.two_arms.reproduce_two_arms`, the command's steps). Prints per take
and mode: achieved, not achieved or refused, the robot's time, and every failure in one line
naming its arm; then the totals. A measurement: exits 0 whatever the outcome.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]


def repository_parent(root: Path = ROOT) -> Path:
    """The directory holding the repository (where ``shared`` lies beside it). In a git
    worktree (``root/.git`` a file ``gitdir: <main>/.git/worktrees/<name>``) it is the main
    checkout's parent, so the bench finds ``../shared`` from a worktree anywhere too."""
    git = root / ".git"
    if git.is_file():
        line = git.read_text(encoding="utf-8").strip()
        if line.startswith("gitdir:"):
            gitdir = Path(line.removeprefix("gitdir:").strip())
            if not gitdir.is_absolute():
                gitdir = (root / gitdir).resolve()
            if gitdir.parent.name == "worktrees":  # <main>/.git/worktrees/<name>
                return gitdir.parents[2].parent
    return root.parent


DEFAULT_DIR = repository_parent() / "shared" / "realmotion" / "bimanual"
MODES = ("skills", "dmp")


def load_take(right: Path, labels: Path | None) -> Any:
    """The two-hand demonstration of ``manip_<seq>.right.mcap`` and its ``.left`` file."""
    import lfd
    from lfd.io import merge_hands

    if labels is not None:
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        from bimanual import load_pair

        return load_pair(right, labels)
    left = right.with_name(right.name.replace(".right.mcap", ".left.mcap"))
    return merge_hands(lfd.load(right, images=False), lfd.load(left, images=False))


def run_take(demo: Any, mode: str) -> dict[str, Any]:
    """One take in one mode: the outcome, why not, how long."""
    from lfd.errors import LfdError
    from lfd.preprocessing import preprocess
    from lfd.reproduce import PREPROCESSING, from_hand_labels
    from lfd.reproduce.two_arms import reproduce_two_arms

    t = time.perf_counter()
    try:
        hands = from_hand_labels(
            demo.labels,
            demo.start_ns,
            sides=demo.sides,
            handovers=demo.handovers,
            objects=demo.objects,
        )
        trajs = {s: preprocess(demo.one_hand(s), **PREPROCESSING) for s in hands.sides}
        r = reproduce_two_arms(trajs, hands, mode)
    except LfdError as err:
        return {"outcome": "refused", "failures": [str(err)], "wall_s": time.perf_counter() - t}
    return {
        "outcome": "achieved" if r.success else "not achieved",
        "failures": r.failures,
        "robot_s": r.execution_time_s,
        "wall_s": time.perf_counter() - t,
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dir", nargs="?", type=Path, default=DEFAULT_DIR)
    ap.add_argument("--modes", nargs="+", choices=MODES, default=list(MODES))
    ap.add_argument("--labels", type=Path, help="corrected labels and handovers (outside the repo)")
    ap.add_argument("--json", type=Path, help="write the results here")
    args = ap.parse_args(argv)
    takes = sorted(args.dir.glob("manip_*.right.mcap")) if args.dir.is_dir() else []
    if not takes:
        print(f"skipped: no two-hand takes in {args.dir}")
        return 0
    results: dict[str, dict[str, Any]] = {}
    for right in takes:
        seq = right.name.removesuffix(".right.mcap")
        demo = load_take(right, args.labels)
        results[seq] = {}
        for mode in args.modes:
            res = results[seq][mode] = run_take(demo, mode)
            robot = f", robot {res['robot_s']:.1f} s" if "robot_s" in res else ""
            print(f"{seq:<18} {mode:<6} {res['outcome']}{robot} ({res['wall_s']:.0f} s)")
            for line in res["failures"]:
                print(f"    {line}")
            sys.stdout.flush()
    for mode in args.modes:
        got = sum(r[mode]["outcome"] == "achieved" for r in results.values())
        print(f"{mode}: {got}/{len(results)} achieved")
    if args.json:
        args.json.write_text(json.dumps(results, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
