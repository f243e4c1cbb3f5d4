"""Evaluate segmentation methods against ground-truth labels over many recordings."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..demo import Demonstration
from ..errors import LfdError, UsageError
from ..skills import SKILLS
from .hands import HandsSegmentation
from .method import Method
from .metrics import (
    EXCLUDE_KEYS,
    METRIC_NAMES,
    all_metrics,
    excluded_spans,
    handover_scores,
    restrict,
    segment_ratio,
)
from .result import Segmentation
from .templates import Templates

METHODS: tuple[str, ...] = ("dp", "paper", "greedy", "changepoint", "proximity", "gripper")
"""Every method :func:`run_method` knows: ``dp`` (lfd's default: segmental DP, with the given
method's grammar use, ``enforce`` by default), ``paper`` (the paper's greedy loop with grammar
warnings), ``greedy`` (the greedy loop with the given method's grammar use), ``changepoint`` (kernel change points +
contact rules, the OKAMI / ORION-style baseline) and the paper's two baselines."""

DEFAULT_METHODS: tuple[str, ...] = ("dp", "paper", "changepoint", "proximity", "gripper")
"""The methods :func:`evaluate` compares by default, the default method first."""

TEMPLATE_METHODS: frozenset[str] = frozenset({"dp", "paper", "greedy"})
"""The methods that match HMM templates (the others are rule-based baselines)."""


def check_methods(methods: Sequence[str]) -> tuple[str, ...]:
    """``methods`` as a tuple, or :class:`UsageError` naming the unknown ones."""
    methods = tuple(methods)
    unknown = [m for m in methods if m not in METHODS]
    if unknown or not methods:
        what = f"unknown method {', '.join(map(repr, unknown))}" if unknown else "no method given"
        raise UsageError(f"{what}; choose from {', '.join(METHODS)}")
    return methods


def method_variant(name: str, method: Method | None = None) -> Method:
    """The :class:`Method` of one template method of :data:`METHODS` on ``method`` (default:
    lfd's): ``dp`` and ``greedy`` are ``method`` with that search; ``paper`` is the paper's
    method (:meth:`Method.paper`), on ``method``'s templates unless they are the shipped
    default ones."""
    base = method or Method.default()
    if name == "paper":
        paper = Method.paper()
        if base.templates is Templates.default():
            return paper
        return dataclasses.replace(paper, name=base.name, templates=base.templates)
    if name not in ("dp", "greedy"):
        raise UsageError(f"{name!r} is not a template method ({', '.join(TEMPLATE_METHODS)})")
    return base.with_options(search=name)  # type: ignore[arg-type]


def run_method(name: str, demo: Demonstration, method: Method | None = None) -> Segmentation:
    """Segment ``demo`` with one of :data:`METHODS`: a template method on ``method``
    (:func:`method_variant`) or a baseline (which takes no method)."""
    from . import changepoint_segmentation, gripper_segmentation, proximity_segmentation, segment

    if name in TEMPLATE_METHODS:
        return segment(demo, method=method_variant(name, method))
    if name == "changepoint":
        return changepoint_segmentation(demo)
    if name == "proximity":
        return proximity_segmentation(demo)
    if name == "gripper":
        return gripper_segmentation(demo)
    raise UsageError(f"unknown method {name!r}; choose from {', '.join(METHODS)}")


@dataclass
class RecordingResult:
    """Metrics of every method on one recording.

    ``excluded_s`` are the spans left out of every score (seconds from the first sample; the
    recording's metadata :data:`~lfd.segmentation.metrics.EXCLUDE_KEYS`), ``duration_s`` the
    recording's length; ``truth`` and ``sequences`` are the skill sequences as scored, i.e.
    seen from outside those spans (:func:`~lfd.segmentation.metrics.restrict`).
    """

    name: str
    task: str
    truth: list[str]
    sequences: dict[str, list[str]] = field(default_factory=dict)
    metrics: dict[str, dict[str, float]] = field(default_factory=dict)
    errors: dict[str, str] = field(default_factory=dict)
    excluded_s: list[tuple[float, float]] = field(default_factory=list)
    duration_s: float = 0.0
    hand: str | None = None
    handovers: dict[str, dict[str, float]] = field(default_factory=dict)

    def excluded_note(self) -> str | None:
        """One line saying what was left out of the scores (None when nothing was)."""
        if not self.excluded_s:
            return None
        total = sum(b - a for a, b in self.excluded_s)
        n = len(self.excluded_s)
        return (
            f"{self.name}: scored outside {n} span{'s' if n > 1 else ''} ({total:.1f} s of "
            f"{self.duration_s:.1f} s) where another hand handles the object "
            f"(metadata {', '.join(EXCLUDE_KEYS)})"
        )


@dataclass
class EvalReport:
    """All recordings' results and their aggregates."""

    recordings: list[RecordingResult]
    methods: tuple[str, ...] = DEFAULT_METHODS

    def tasks(self) -> list[str]:
        """Task names in first-seen order."""
        return list(dict.fromkeys(r.task for r in self.recordings))

    def summary(self, task: str | None = None) -> dict[str, dict[str, float]]:
        """Mean of every metric per method, over one task's recordings or all (``None``).

        ``sequence_match`` is the number of exact matches, ``n`` the number of recordings; a
        method that failed on a recording counts as a mismatch with zero scores.
        """
        rows = [r for r in self.recordings if task is None or r.task == task]
        out: dict[str, dict[str, float]] = {}
        for m in self.methods:
            vals: dict[str, list[float]] = {k: [] for k in METRIC_NAMES}
            for r in rows:
                got = r.metrics.get(m)
                for k in METRIC_NAMES:
                    if got is None:
                        vals[k].append(1.0 if k == "edit_distance" else 0.0)
                    else:
                        vals[k].append(got[k])
            agg = {
                k: (float(np.sum(v)) if k == "sequence_match" else _mean(v))
                for k, v in vals.items()
            }
            agg["n"] = float(len(rows))
            out[m] = agg
        return out

    def hands_summary(self) -> dict[str, dict[str, dict[str, float]]]:
        """Per hand (the two-hand recordings' lanes): the mean of every metric per method,
        ``segment_ratio`` included; empty without two-hand recordings."""
        out: dict[str, dict[str, dict[str, float]]] = {}
        for side in dict.fromkeys(r.hand for r in self.recordings if r.hand is not None):
            rows = [r for r in self.recordings if r.hand == side]
            out[side] = {}
            for m in self.methods:
                got = [r.metrics[m] for r in rows if m in r.metrics]
                keys = [*METRIC_NAMES, "segment_ratio"]
                agg = {k: _mean([g[k] for g in got if k in g]) for k in keys}
                agg["sequence_match"] = float(sum(g["sequence_match"] for g in got))
                agg["n"] = float(len(rows))
                out[side][m] = agg
        return out

    def handover_summary(self) -> dict[str, dict[str, float]]:
        """Per method, the handovers of every two-hand recording summed (``found``,
        ``missed``, ``false``, ``true``, ``predicted``; counted once per recording)."""
        first = [r for r in self.recordings if r.hand is not None and r.hand == "right"]
        out: dict[str, dict[str, float]] = {}
        for m in self.methods:
            got = [r.handovers[m] for r in first if m in r.handovers]
            if not got:
                continue
            keys = ("true", "predicted", "found", "missed", "false")
            out[m] = {k: float(sum(g[k] for g in got)) for k in keys}
        return out

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready report: per recording, per task and overall (and with two-hand
        recordings, per hand and the handovers)."""
        hands = {}
        if any(r.hand is not None for r in self.recordings):
            hands = {
                "hands": {
                    side: {m: _clean(v) for m, v in per.items()}
                    for side, per in self.hands_summary().items()
                },
                "handovers": self.handover_summary(),
            }
        return {
            **hands,
            "methods": list(self.methods),
            "recordings": [
                {
                    "name": r.name,
                    "task": r.task,
                    "truth": r.truth,
                    "sequences": r.sequences,
                    "metrics": {m: _clean(v) for m, v in r.metrics.items()},
                    "errors": r.errors,
                    **({"excluded_s": [list(x) for x in r.excluded_s]} if r.excluded_s else {}),
                    **({"hand": r.hand} if r.hand is not None else {}),
                    **(
                        {"handovers": {m: _clean(v) for m, v in r.handovers.items()}}
                        if r.hand is not None
                        else {}
                    ),
                }
                for r in self.recordings
            ],
            "tasks": {t: {m: _clean(v) for m, v in self.summary(t).items()} for t in self.tasks()},
            "overall": {m: _clean(v) for m, v in self.summary().items()},
        }


def _mean(v: Sequence[float]) -> float:
    finite = [x for x in v if math.isfinite(x)]
    return float(np.mean(finite)) if finite else float("nan")


def _clean(d: dict[str, float]) -> dict[str, float | None]:
    return {k: (v if math.isfinite(v) else None) for k, v in d.items()}


def evaluate_demo(
    demo: Demonstration,
    *,
    name: str = "demo",
    method: Method | None = None,
    methods: Sequence[str] = DEFAULT_METHODS,
) -> RecordingResult:
    """Run every method of ``methods`` (on ``method``: :func:`run_method`) on one labelled
    demonstration and compute the metrics.

    Time the recording's metadata excludes (another hand handling the object:
    :func:`~lfd.segmentation.metrics.excluded_spans`) is left out of every metric. A recording
    none of whose objects moves, where a method still finds a skill that moves one, is scored
    with a :class:`~lfd.errors.LfdWarning` (:func:`lfd.io.checks.unmoved_objects_message`).

    Raises
    ------
    DemonstrationError
        Malformed excluded spans in the metadata, or a hand that reaches no object
        (:func:`lfd.io.checks.check_hand_reaches`: there is nothing to score).
    """
    import warnings

    from ..errors import LfdWarning
    from ..io.checks import check_hand_reaches, unmoved_objects_message

    check_hand_reaches(demo)
    task = str(demo.metadata.get("task") or demo.metadata.get("experiment") or "unknown")
    exclude = excluded_spans(demo.metadata, demo.start_ns)
    t0 = demo.start_ns
    res = RecordingResult(
        name=name,
        task=task,
        truth=[s.skill for s in restrict(demo.labels, exclude)],
        excluded_s=[((a - t0) * 1e-9, (b - t0) * 1e-9) for a, b in exclude],
        duration_s=demo.duration_s,
    )
    for m in methods:
        try:
            seg = run_method(m, demo, method)
        except LfdError as err:
            res.errors[m] = str(err)
            continue
        res.sequences[m] = [s.skill for s in restrict(seg.segments, exclude)]
        res.metrics[m] = all_metrics(seg.segments, demo.labels, exclude=exclude)
    found = [s for m in res.sequences for s in res.sequences[m]]
    unmoved = unmoved_objects_message(demo, found)
    if unmoved is not None:
        warnings.warn(f"{name}: {unmoved}", LfdWarning, stacklevel=2)
    return res


def run_hands(name: str, demo: Demonstration, method: Method | None = None) -> HandsSegmentation:
    """Segment both hands of ``demo`` with one of :data:`METHODS`: a template method through
    :func:`lfd.segment_hands` (the lanes together, handovers found), a baseline on each hand
    alone (no handovers)."""
    from . import segment_hands

    if name in TEMPLATE_METHODS:
        return segment_hands(demo, method=method_variant(name, method))
    return HandsSegmentation(
        lanes={side: run_method(name, demo.one_hand(side), method) for side in demo.sides}
    )


def evaluate_hands_demo(
    demo: Demonstration,
    *,
    name: str = "demo",
    method: Method | None = None,
    methods: Sequence[str] = DEFAULT_METHODS,
) -> list[RecordingResult]:
    """Every method of ``methods`` on a labelled two-hand demonstration: one result per hand
    (named ``name [side]``; its metrics are that hand's lane against that hand's labels, the
    whole recording, nothing excluded, plus ``segment_ratio``), each carrying the handover
    scores of every method (:func:`~lfd.segmentation.metrics.handover_scores` against
    ``demo.handovers``)."""
    task = str(demo.metadata.get("task") or demo.metadata.get("experiment") or "unknown")
    rows = {
        side: RecordingResult(
            name=f"{name} [{side}]",
            task=task,
            truth=[lab.skill for lab in demo.labels_of(side)],
            duration_s=demo.duration_s,
            hand=side,
        )
        for side in demo.sides
    }
    for m in methods:
        try:
            result = run_hands(m, demo, method)
        except LfdError as err:
            for row in rows.values():
                row.errors[m] = str(err)
            continue
        scores = handover_scores(result.handovers, demo.handovers)
        for side, row in rows.items():
            lane, truth = result.lanes[side].segments, demo.labels_of(side)
            row.sequences[m] = [seg.skill for seg in lane]
            row.metrics[m] = {
                **all_metrics(lane, truth),
                "segment_ratio": segment_ratio(lane, truth),
            }
            row.handovers[m] = scores
    return list(rows.values())


def expand_paths(items: Iterable[str | Path]) -> list[Path]:
    """Files and directories -> sorted list of ``.mcap`` files (:func:`lfd.batch.mcap_files`)."""
    from ..batch import mcap_files

    return [Path(p) for p in mcap_files(items)]


def evaluate_file(
    path: str | Path,
    *,
    method: Method | None = None,
    methods: Sequence[str] = DEFAULT_METHODS,
    object_sizes: Mapping[str, Sequence[float]] | None = None,
) -> RecordingResult | list[RecordingResult] | None:
    """:func:`evaluate_demo` of one recording file (``None`` without ground-truth labels; a
    two-hand file: :func:`evaluate_hands_demo`, a result per hand): the
    task :func:`evaluate` runs per recording (``object_sizes`` for files that do not carry
    them, :func:`lfd.load`)."""
    from ..io import load

    demo = load(path, object_sizes=object_sizes)
    if not demo.labels:
        return None
    if len(demo.sides) > 1:
        return evaluate_hands_demo(demo, name=Path(path).name, method=method, methods=methods)
    return evaluate_demo(demo, name=Path(path).name, method=method, methods=methods)


def evaluate(
    paths: Iterable[str | Path],
    *,
    method: Method | None = None,
    methods: Sequence[str] = DEFAULT_METHODS,
    progress: Callable[[str], None] | None = None,
    object_sizes: Mapping[str, Sequence[float]] | None = None,
    jobs: int | None = 1,
    ray_address: str | None = None,
    failed: dict[str, str] | None = None,
) -> EvalReport:
    """Evaluate ``methods`` on every labelled recording among ``paths`` (files or directories).

    ``method`` is what the template methods run (:func:`method_variant`; default: lfd's,
    and the paper's for ``paper``): its templates, parameters and grammar use (``paper``
    always warns). Recordings without ground-truth labels are skipped. ``jobs`` /
    ``ray_address``: how many recordings at once, and where (:func:`lfd.batch.run_batch`; the
    method goes to the workers pickled, :meth:`Method.portable`). A recording that cannot be
    evaluated raises its error, or with ``failed`` (a dict) is recorded there as
    ``{path: message}`` and skipped. ``object_sizes`` go to :func:`lfd.load` (for files that
    do not carry them).
    """
    from functools import partial

    from ..batch import raise_failed, reemit_warnings, run_batch

    methods = check_methods(methods)
    task = partial(
        evaluate_file,
        method=method,
        methods=methods,
        object_sizes=dict(object_sizes) if object_sizes else None,
    )

    def step(res: Any) -> None:
        if progress is not None:
            progress(Path(res.item).name)

    results = run_batch(
        task, expand_paths(paths), jobs=jobs, ray_address=ray_address, progress=step
    )
    rows = []
    for res in results:
        reemit_warnings(res)
        if not res.ok and failed is not None:
            failed[str(res.item)] = str(res.error)
        elif not res.ok:
            raise_failed([res])
        elif isinstance(res.value, list):
            rows.extend(res.value)
        elif res.value is not None:
            rows.append(res.value)
    return EvalReport(rows, tuple(methods))


def leave_one_out(
    paths: Iterable[str | Path],
    *,
    base: Templates | None = None,
    base_name: str = "default",
    methods: Sequence[str] = ("dp",),
    method: Method | None = None,
    progress: Callable[[str], None] | None = None,
    object_sizes: Mapping[str, Sequence[float]] | None = None,
) -> EvalReport:
    """Segment each labelled recording with templates trained on all the others.

    With ``base``, each fold's templates are ``base`` adapted to the other recordings
    (:func:`~lfd.segmentation.adapt.adapt_templates`); without, they are trained from scratch
    on them (only the skills the others show); each fold runs ``method`` (default: lfd's) with
    its templates. ``progress`` is called with ``"read NAME"`` for each recording read and
    ``"NAME"`` after each fold.

    Raises
    ------
    UsageError
        Fewer than two labelled recordings, or (from scratch) a fold whose training recordings
        leave a skill of its test recording without an example.
    """
    from ..io import load
    from .adapt import adapt_templates
    from .templates import fit_templates, preprocessing_options, template_examples

    methods = check_methods(methods)
    if not set(methods) & TEMPLATE_METHODS:
        raise UsageError(
            f"leave-one-out trains templates; give a template method ({', '.join(TEMPLATE_METHODS)})"
        )
    opts = base.preprocessing if base is not None else preprocessing_options()
    demos: list[tuple[str, Demonstration, list[tuple[str, np.ndarray]]]] = []
    for path in expand_paths(paths):
        demo = load(path, images=False, object_sizes=object_sizes)
        if demo.labels:
            demos.append((path.name, demo, template_examples(demo, preprocessing=opts)))
        if progress is not None:
            progress(f"read {path.name}")
    if len(demos) < 2:
        raise UsageError(
            f"leave-one-out needs at least 2 recordings with ground-truth labels, got {len(demos)}"
        )
    rows = []
    for i, (name, demo, _) in enumerate(demos):
        others = [d for j, d in enumerate(demos) if j != i]
        examples = [e for _, _, ex in others for e in ex]
        names = [n for n, _, _ in others]
        if base is not None:
            templates = adapt_templates(base, examples, names=names, base_name=base_name)
        else:
            skills = [s for s in SKILLS if any(k == s for k, _ in examples)]
            missing = sorted(set(demo.skill_sequence) - set(skills))
            if missing:
                raise UsageError(
                    f"{name} shows {', '.join(missing)}, which no other recording has an "
                    "example of; give more recordings, or --base to adapt the shipped templates"
                )
            templates = fit_templates(examples, names=names, skills=skills)
        fold = dataclasses.replace(
            method or Method.default(), name=f"leave out {name}", templates=templates
        )
        rows.append(evaluate_demo(demo, name=name, method=fold, methods=methods))
        if progress is not None:
            progress(name)
    return EvalReport(rows, tuple(methods))
