"""Log a whole segmentation run: trajectory, features, sections, greedy scores, skills.

Everything is read from the segmentation's run (``result.run``: the trajectory it segmented,
its features, the stage-2 score band, the method); the per-iteration candidate scores of the
greedy loop are read off that band so the viewer can show why each cut was made.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from .features import log_features
from .segmentation import log_segmentation, log_text

if TYPE_CHECKING:
    from ..demo import Demonstration
    from ..segmentation import HandsSegmentation, Method, Segmentation
    from ..segmentation.band import StageTwoScores
    from ..trajectory import Trajectory


def greedy_trace(
    table: np.ndarray | StageTwoScores,
    boundaries: Sequence[int] | np.ndarray,
    segment_starts: Sequence[int],
    skills: Sequence[str],
) -> tuple[list[dict[str, np.ndarray]], list[np.ndarray]]:
    """Per greedy iteration, the per-sample score of every candidate run under every skill.

    Parameters
    ----------
    table : array, shape (K, K + 1, S), or StageTwoScores
        Summed log-likelihoods of sections ``i..j`` under skill ``s`` (``-inf`` = not scored),
        dense or over a band of runs (whose runs are then the candidates).
    boundaries : sequence of int, length K + 1
        Stage-1 boundaries ``[0, ..., n]`` (sample indices).
    segment_starts : sequence of int
        Start sample of each cut segment, in cut order (the greedy loop cuts front to back).
    skills : sequence of str, length S

    Returns
    -------
    scores : list of dict skill -> array, shape (c_k,)
        Mean log-likelihood per sample of the candidate runs of iteration ``k``.
    candidate_ends : list of array of int, shape (c_k,)
        End sample (exclusive) of each candidate run.
    """
    b = np.asarray(boundaries, dtype=np.int64)
    k = len(b) - 1
    band = getattr(table, "band", None)  # a StageTwoScores
    tab = np.asarray(getattr(table, "scores", table), dtype=np.float64)
    if band is not None:
        if (
            band.n_sections != k
            or not np.array_equal(band.bounds, b)
            or tab.shape[1:] != (len(skills),)
        ):
            raise ValueError(
                f"score band over {band.n_sections} sections, {tab.shape[1:]} skills does not "
                f"match {k} sections, {len(skills)} skills"
            )
    elif tab.shape[:2] != (k, k + 1) or tab.shape[2] != len(skills):
        raise ValueError(
            f"score table {tab.shape} does not match {k} sections, {len(skills)} skills"
        )
    where = {int(x): i for i, x in enumerate(b)}
    scores: list[dict[str, np.ndarray]] = []
    ends: list[np.ndarray] = []
    for start in segment_starts:
        i = where.get(int(start))
        if i is None or i >= k:
            continue
        if band is not None:
            j = band.ends(i)
            mean = tab[band.rows(i)] / (b[j] - b[i])[:, None]
        else:
            j = np.arange(i + 1, k + 1)
            mean = tab[i, j, :] / (b[j] - b[i])[:, None]
        scores.append({s: mean[:, c] for c, s in enumerate(skills)})
        ends.append(b[j])
    return scores, ends


def log_recorded_demo(
    demo: Demonstration,
    *,
    trajectory: bool = True,
    features: bool = True,
    recording: Any = None,
    **kwargs: Any,
) -> Trajectory | None:
    """Log a demonstration, with ``trajectory`` its preprocessed form (the shipped templates'
    preprocessing, :meth:`lfd.Method.preprocessing`; with ``features`` also its Table I
    features) and its labels. Extra keyword arguments go to :func:`lfd.viz.log_demonstration`.
    Returns the trajectory logged.

    To show a segmentation, log the demonstration with ``trajectory=False`` and then
    :func:`log_segment_run`: it logs the trajectory that was segmented.

    Of a two-hand demonstration, each hand's trajectory and ground-truth lane
    (``/segmentation/skills/<side>/ground_truth``) and the ground-truth handovers; no
    features (their plots are one hand's). Returns the right hand's trajectory.
    """
    from ..errors import LfdError
    from .demo import log_demonstration

    if len(demo.sides) > 1:
        return _log_recorded_hands(demo, trajectory=trajectory, recording=recording, **kwargs)

    traj: Trajectory | None = None
    filled: Trajectory | None = None
    problem = None
    if trajectory:
        from ..preprocessing import preprocess
        from ..segmentation.gaps import fill_gaps
        from ..segmentation.method import Method

        try:
            traj = preprocess(demo, **Method.default().preprocessing)
            filled, _ = fill_gaps(traj)
        except LfdError as err:
            problem = f"preprocessing failed: {err}"
    log_demonstration(demo, trajectory=traj, recording=recording, **kwargs)
    if filled is not None and features:
        from ..features import compute_features

        try:
            feats = compute_features(filled)
            log_features(feats, object_names=list(filled.object_names), recording=recording)
        except LfdError as err:
            problem = f"features failed: {err}"
    if problem:
        log_text([problem], recording=recording)
    if demo.labels:
        log_segmentation(ground_truth=demo.labels, recording=recording)
    return traj


def _log_recorded_hands(
    demo: Demonstration, *, trajectory: bool, recording: Any, **kwargs: Any
) -> Trajectory | None:
    """:func:`log_recorded_demo` of a two-hand demonstration."""
    from ..errors import LfdError
    from .demo import log_demonstration
    from .handovers import log_handovers

    trajs: dict[str, Trajectory] = {}
    problems = []
    if trajectory:
        from ..preprocessing import preprocess
        from ..segmentation.method import Method

        for side in demo.sides:
            try:
                trajs[side] = preprocess(demo.one_hand(side), **Method.default().preprocessing)
            except LfdError as err:
                problems.append(f"{side} hand: preprocessing failed: {err}")
    log_demonstration(demo, trajectory=trajs, recording=recording, **kwargs)
    if problems:
        log_text(problems, recording=recording)
    for side in demo.sides:
        labels = demo.labels_of(side)
        if labels:
            log_segmentation(ground_truth=labels, recording=recording, side=side)
    log_handovers(demo.handovers, source="ground_truth", demo=demo, recording=recording)
    return trajs.get(demo.sides[0])


def log_hands_run(
    demo: Demonstration | None,
    result: HandsSegmentation,
    *,
    ground_truth: bool = True,
    trajectory: bool = True,
    recording: Any = None,
) -> None:
    """Log a segmentation of both hands (:func:`lfd.segment_hands`): per hand the trajectory
    that was segmented (``/world/hand/<side>/gripper``, ``/tcp_path``) and the skill lane
    ``/segmentation/skills/<side>/result`` (with ``ground_truth``, the demonstration's lane
    beside it), the handovers (``/segmentation/handovers/result``, ``/world/handovers/result``;
    the demonstration's as ``ground_truth``), the warnings. A one-lane result is logged as
    :func:`log_segment_run` logs a one-hand segmentation."""
    from .demo import log_trajectory
    from .handovers import log_handovers
    from .recording import get_recording
    from .timeline import time_origin

    if len(result.lanes) == 1:
        (lane,) = result.lanes.values()
        log_segment_run(
            demo, lane, ground_truth=ground_truth, trajectory=trajectory, recording=recording
        )
        return
    rec = get_recording(recording)
    for side, seg in result.lanes.items():
        run = seg.run
        if trajectory and run is not None and len(run.trajectory):
            origin = time_origin(rec, first_ns=int(run.trajectory.t_ns[0]))
            log_trajectory(run.trajectory, origin, rec, side=side)
        truth = demo.labels_of(side) if ground_truth and demo is not None else []
        log_segmentation(
            seg.segments, ground_truth=truth or None, recording=rec, side=side,
            warnings=[f"{side} hand: {w}" for w in seg.warnings],
        )  # fmt: skip
        log_text(
            [(s.start_ns, f"{side} hand " + _describe(k, s)) for k, s in enumerate(seg.segments)],
            path="/segmentation/log",
            level="INFO",
            recording=rec,
        )
    log_handovers(result.handovers, source="result", demo=demo, recording=rec)
    if ground_truth and demo is not None:
        log_handovers(demo.handovers, source="ground_truth", demo=demo, recording=rec)
    if result.warnings:
        log_text(list(result.warnings), recording=rec)


def log_segment_run(
    demo: Demonstration | None,
    result: Segmentation,
    *,
    baselines: Mapping[str, Segmentation] | None = None,
    ground_truth: bool = True,
    trajectory: bool = True,
    recording: Any = None,
) -> None:
    """Log one segmentation from its run (``result.run``): the trajectory that was segmented
    (with ``trajectory``), its features, the stage-1 sections, the scores and the skills. Nothing
    is preprocessed or scored again; the demonstration itself is logged separately.

    Parameters
    ----------
    demo : Demonstration or None
        For the ground-truth lane (its labels).
    result : Segmentation
        A segmentation made by :func:`lfd.segment` (it carries its :class:`~lfd.segmentation.Run`).
    baselines : mapping name -> Segmentation, optional
        Other methods' results, one lane each.
    ground_truth : bool
        Log the demonstration's labels too (off when :func:`log_recorded_demo` did already).
    trajectory : bool
        Log the segmented trajectory (gripper, TCP path, opening) too.
    """
    from ..errors import InvalidParameterError
    from .demo import log_trajectory
    from .recording import get_recording
    from .timeline import time_origin

    run = result.run
    if run is None:
        raise InvalidParameterError(
            "the segmentation carries no run (a baseline, or read back from JSON): "
            "log its segments with lfd.viz.log_skill_spans"
        )
    filled = run.trajectory
    if trajectory:
        rec = get_recording(recording)
        origin = time_origin(rec, first_ns=int(filled.t_ns[0]) if len(filled) else 0)
        log_trajectory(filled, origin, rec)
    log_features(run.features, object_names=list(filled.object_names), recording=recording)

    t = np.asarray(filled.t_ns, dtype=np.int64)
    n = len(t)
    # a segment's end may be n (exclusive): its time is the last sample's
    t_end = np.r_[t, t[-1]] if n else t
    scores: list[dict[str, Any]] | None = None
    candidate_ns: list[np.ndarray] | None = None
    spans: list[tuple[int, int]] | None = None
    if result.method == "greedy" and result.sections and result.segments:
        bounds = np.asarray(result.sections, dtype=np.int64)
        skills = run.method.templates.skills if run.method is not None else None
        if skills is not None:
            trace, ends = greedy_trace(
                run.scores, bounds, [s.start for s in result.segments], skills
            )
            scores = list(trace)
            candidate_ns = [t_end[e] for e in ends]
    if scores is None:
        # one score per cut segment: the chosen skill's own
        scores = [{s.skill: s.score} for s in result.segments if np.isfinite(s.score)]
        if len(scores) == len(result.segments):
            spans = [(s.start_ns, s.end_ns) for s in result.segments]
        else:
            scores = None
    log_segmentation(
        result.segments,
        ground_truth=demo.labels if ground_truth and demo is not None and demo.labels else None,
        baselines={k: v.segments for k, v in (baselines or {}).items()},
        boundaries=np.asarray(result.sections, dtype=np.int64) if result.sections else None,
        t_ns=t if result.sections else None,
        scores=scores,
        spans=spans,
        candidate_end_ns=candidate_ns,
        warnings=list(result.warnings),
        recording=recording,
    )
    if candidate_ns is not None:
        _log_cuts(result, recording)
    log_text(
        [(s.start_ns, _describe(k, s)) for k, s in enumerate(result.segments)],
        path="/segmentation/log",
        level="INFO",
        recording=recording,
    )


def _log_cuts(result: Segmentation, recording: Any) -> None:
    """The chosen (run, skill) of each greedy iteration: a marker at its end and score."""
    from .recording import get_recording, import_rerun
    from .timeline import current_origin, time_columns

    rr = import_rerun()
    rec = get_recording(recording)
    segs = [s for s in result.segments if np.isfinite(s.score)]
    if not segs:
        return
    origin = current_origin(rec) or int(segs[0].start_ns)
    path = "/segmentation/greedy/chosen"
    rec.log(
        path,
        rr.SeriesPoints(names="cut", colors=[(255, 255, 255)], markers="diamond", marker_sizes=6.0),
        static=True,
    )
    rec.send_columns(
        path,
        indexes=time_columns(np.array([s.end_ns for s in segs], dtype=np.int64), origin),
        columns=rr.Scalars.columns(scalars=np.array([s.score for s in segs])),
    )


def _describe(k: int, s: Any) -> str:
    obj = f"({s.object})" if s.object else ""
    return (
        f"{k}: {s.skill}{obj} {s.start_s:.2f}-{s.end_s:.2f} s, "
        f"score {s.score:.2f}, confidence {s.confidence:.2f}, margin {s.margin:.2f}"
    )


def log_methods(
    demo: Demonstration,
    methods: Sequence[str],
    *,
    method: Method | None = None,
    recording: Any = None,
) -> dict[str, Segmentation]:
    """Run segmentation methods on ``demo`` (:func:`lfd.segmentation.evaluate.run_method`:
    the template methods on ``method``, default lfd's) and log each result as soon as it is
    ready.

    The first template method (``dp``, ``paper``, ``greedy``) is logged in full (lane
    ``result``, features, sections, scores); the others get a lane each (``dp``/``paper``/
    ``greedy``, ``baseline_<name>``). A method that fails is reported in
    ``/segmentation/warnings``. Returns the results by method.
    """
    from ..errors import LfdError
    from ..segmentation.evaluate import TEMPLATE_METHODS, run_method
    from .segmentation import log_skill_spans

    results: dict[str, Segmentation] = {}
    main = None
    for name in methods:
        try:
            seg = run_method(name, demo, method)
        except LfdError as err:
            log_text([f"{name}: {err}"], recording=recording)
            continue
        results[name] = seg
        if main is None and name in TEMPLATE_METHODS:
            main = name
            log_segment_run(demo, seg, ground_truth=False, recording=recording)
        else:
            lane = name if name in TEMPLATE_METHODS else f"baseline_{name}"
            log_skill_spans(seg.segments, source=lane, recording=recording)
    return results


def log_result(
    demo: Demonstration | None,
    result: Segmentation | HandsSegmentation,
    **options: Any,
) -> None:
    """Log a segmentation of one hand (:func:`log_segment_run`) or of both
    (:func:`log_hands_run`, a result with ``lanes``); ``options`` go to either."""
    lanes = getattr(result, "lanes", None)
    if lanes is not None:
        log_hands_run(demo, result, **options)  # type: ignore[arg-type]
    else:
        log_segment_run(demo, result, **options)  # type: ignore[arg-type]
