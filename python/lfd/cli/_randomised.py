"""``lfd reproduce --randomise N``'s report, of one arm and of two (``--robot aloha``)."""

from __future__ import annotations

import argparse
from typing import Any

from ._options import console, write_json


def randomised_report(
    args: argparse.Namespace, res: Any, skills: list[str], program: Any, err: Any
) -> int:
    """``--randomise``'s table (per mode: success, of two arms each arm's, per skill, the
    failure reasons), every failure line and the JSON; the exit status."""
    from rich.table import Table

    modes = res.modes
    arms = list(dict.fromkeys(a for r in res.runs for a in (r.arms or {})))
    table = Table(
        title=f"{args.recording}: {args.randomise} layouts (shift <= {args.max_shift:g} m, "
        f"turn <= {args.max_turn:g} deg, seed {args.seed})"
    )
    for col in ("mode", "success", *(f"{a} arm" for a in arms), *skills, "failure reasons"):
        table.add_column(col)
    for mode in modes:
        rates = res.skill_rates(mode)
        runs = [r for r in res.runs if r.mode == mode]
        ok = sum(r.success for r in runs)
        reasons = ", ".join(f"{k} {v}" for k, v in res.reasons(mode).most_common()) or "-"
        table.add_row(
            mode,
            f"{ok}/{args.randomise} ({100 * res.success_rate(mode):.0f}%)",
            *(f"{sum(bool((r.arms or {}).get(a)) for r in runs)}/{len(runs)}" for a in arms),
            *(f"{rates[k][0]}/{rates[k][1]}" if k in rates else "-" for k in skills),
            reasons,
        )
    console(args).print(table)
    for r in res.runs:
        if not r.success:
            for line in r.failures:
                err.print(
                    f"layout {r.layout} {r.mode}: {line}",
                    highlight=False,
                    markup=False,
                    soft_wrap=True,
                )
    if args.json:
        doc = {"recording": args.recording, "program": program} | res.to_json()
        write_json(args.json, doc)
    judged = [m for m in modes if not (args.mode == "all" and m == "replay")]
    return 0 if all(r.success for r in res.runs if r.mode in judged) else 1
