"""The simulated recording sets and how one recording is made (``lfd simulate``).

The shipped recordings are made this way, deterministically: ``templates`` (the template
tasks x :data:`TEMPLATE_SEEDS`, plus repeated lifts for the natural style), ``eval`` (the
experiments x :data:`EVAL_SEEDS`), ``samples`` (the experiments at :data:`SAMPLE_SEED` and a
short rendered one), ``hands`` (the two-hand experiments x :data:`EVAL_SEEDS`).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from .. import io
from ..errors import UsageError
from .demonstrator import SimResult, crop, simulate
from .render import add_rendering
from .tasks import EXPERIMENTS, NATURAL_EXPERIMENTS, TEMPLATE_TASKS, TWO_HAND_EXPERIMENTS
from .variability import Variability

SETS = ("templates", "eval", "samples", "hands")
"""The recording sets of ``lfd simulate --set``."""
NATURAL_EXP5_TEMPLATES = 6
"""Natural-style template sets also hold this many repeated-lift demos (exp5)."""
TEMPLATE_SEEDS = range(9)
EVAL_SEEDS = range(100, 106)
SAMPLE_SEED = 1000


def set_jobs(which: str, out: Path, style: str = "careful") -> list[dict[str, Any]]:
    """The recordings of the set ``which`` (:data:`SETS`) under ``out``, one dict each: ``task``,
    ``seed``, ``path`` and, for the rendered sample, ``render`` (Hz) and ``duration`` (s).

    Raises
    ------
    UsageError
        ``which`` is not a set name.
    """
    if which not in SETS:
        raise UsageError(f"unknown set {which!r}; choose from {', '.join(SETS)}")
    jobs: list[dict[str, Any]]
    if which == "templates":
        jobs = [
            {"task": s, "seed": k, "path": out / f"{s}_{k}.mcap"}
            for s in TEMPLATE_TASKS
            for k in TEMPLATE_SEEDS
        ]
        if style == "natural":  # re-grasps of the object just put down occur in repeated lifts
            jobs += [
                {"task": "exp5", "seed": k, "path": out / f"exp5_{k}.mcap"}
                for k in TEMPLATE_SEEDS[:NATURAL_EXP5_TEMPLATES]
            ]
        return jobs
    if which == "hands":
        return [
            {"task": e, "seed": k, "path": out / f"{e}_{k}.mcap"}
            for e in TWO_HAND_EXPERIMENTS
            for k in EVAL_SEEDS
        ]
    if which == "eval":
        return [
            {"task": e, "seed": k, "path": out / f"{e}_{k}.mcap"}
            for e in (NATURAL_EXPERIMENTS if style == "natural" else EXPERIMENTS)
            for k in EVAL_SEEDS
        ]
    jobs = [{"task": e, "seed": SAMPLE_SEED, "path": out / f"{e}.mcap"} for e in EXPERIMENTS]
    jobs.append(
        {
            "task": "exp1",
            "seed": SAMPLE_SEED,
            "path": out / "rendered" / "exp1_short.mcap",
            "render": 5.0,
            "duration": 8.0,
        }
    )
    return jobs


def record(
    task: str,
    seed: int,
    path: str | os.PathLike[str],
    *,
    variability: Variability | None = None,
    render_rate: float | None = None,
    duration: float | None = None,
    hand_rate: float | None = None,
    color_format: str = "png",
) -> SimResult:
    """Simulate, optionally crop and render, and save one demonstration; returns the result."""
    result = simulate(task, seed, variability, hand_rate_hz=hand_rate)
    if duration is not None:
        crop(result, duration)
    if render_rate:
        add_rendering(result, rate_hz=render_rate)
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    io.save(result.demo, path, color_format=color_format)
    return result
