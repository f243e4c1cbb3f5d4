"""Log segmentation results: stage-1 sections, skill spans, stage-2 HMM scores, warnings."""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from ..errors import DemonstrationError
from ..skills import SKILLS
from .paths import LOG, SECTIONS, WARNINGS, hand_lane
from .recording import get_recording, import_rerun
from .timeline import GREEDY_ITERATION, as_ns, current_origin, time_columns, time_origin

SKILL_COLORS: dict[str, tuple[int, int, int]] = {
    "pick_up": (66, 133, 244),
    "place": (52, 168, 83),
    "locate": (251, 188, 5),
    "stack": (171, 71, 188),
    "push": (234, 67, 53),
    "move": (0, 172, 193),
    "move_with": (255, 112, 67),
}
"""One colour per skill, the same in every lane."""
UNKNOWN_COLOR = (150, 150, 150)
SECTION_COLORS = ((110, 110, 120), (160, 160, 175))


class SegmentLike(Protocol):
    """A skill span (``lfd.SkillLabel`` or a segmentation result's segment)."""

    @property
    def skill(self) -> str: ...
    @property
    def start_ns(self) -> int: ...
    @property
    def end_ns(self) -> int: ...


def _rgba(color: tuple[int, int, int]) -> int:
    r, g, b = color
    return (r << 24) | (g << 16) | (b << 8) | 0xFF


def skill_state(skill: str, obj: str | None) -> str:
    """The state value of a span: the skill name, with its object when known."""
    return skill if not obj else f"{skill}({obj})"


def log_skill_spans(
    segments: Iterable[SegmentLike],
    *,
    source: str = "result",
    recording: Any = None,
    origin_ns: int | None = None,
    side: str | None = None,
) -> None:
    """Log skill spans as coloured states in the lane ``/segmentation/skills/<source>`` (with
    ``side``, one of two hands': ``/segmentation/skills/<side>/<source>``).

    Parameters
    ----------
    segments : iterable of SegmentLike
        Objects with ``skill``, ``start_ns``, ``end_ns`` (absolute ns) and optionally ``object``.
    source : str
        Lane name: ``result``, ``ground_truth``, or a baseline's name.
    """
    rr = import_rerun()
    segs = sorted(segments, key=lambda s: int(s.start_ns))
    rec = get_recording(recording)
    if not segs:
        return
    for s in segs:
        if int(s.end_ns) < int(s.start_ns):
            raise DemonstrationError(f"segment {s.skill!r} ends before it starts")
    origin = time_origin(rec, first_ns=int(segs[0].start_ns), origin_ns=origin_ns)
    path = hand_lane(side, source)
    values: dict[str, tuple[str, int]] = {}
    times: list[int] = []
    states: list[str] = []
    for i, s in enumerate(segs):
        obj = getattr(s, "object", None)
        state = skill_state(s.skill, obj)
        label = s.skill + (f" {obj}" if obj else "")
        values[state] = (label, _rgba(SKILL_COLORS.get(s.skill, UNKNOWN_COLOR)))
        times.append(int(s.start_ns))
        states.append(state)
        nxt = segs[i + 1] if i + 1 < len(segs) else None
        if nxt is None or int(nxt.start_ns) > int(s.end_ns):
            times.append(int(s.end_ns))
            states.append("")  # a reset: gap until the next span
    rec.log(
        path,
        rr.StateConfiguration(
            values=list(values),
            labels=[v[0] for v in values.values()],
            colors=np.array([v[1] for v in values.values()], dtype=np.uint32),
        ),
        static=True,
    )
    rec.send_columns(
        path,
        indexes=time_columns(np.asarray(times, dtype=np.int64), origin),
        columns=rr.StateChange.columns(state=states),
    )


def log_sections(
    boundaries: npt.ArrayLike,
    t_ns: npt.ArrayLike,
    *,
    recording: Any = None,
    origin_ns: int | None = None,
) -> None:
    """Log the stage-1 data sections as a state lane ``/segmentation/sections``.

    Parameters
    ----------
    boundaries : array of int
        Sample indices where a section starts (0 and ``n`` are implied).
    t_ns : array, shape (n,)
        Absolute times of the samples the indices refer to (the feature clock).
    """
    rr = import_rerun()
    t = as_ns(t_ns, "sections")
    n = t.shape[0]
    b = np.asarray(boundaries)
    if b.size and not np.issubdtype(b.dtype, np.integer):
        raise DemonstrationError(f"section boundaries must be sample indices, got {b.dtype}")
    if b.size and (b.min() < 0 or b.max() > n):
        raise DemonstrationError(
            f"section boundaries must lie in [0, {n}], got {b.min()}..{b.max()}"
        )
    rec = get_recording(recording)
    if n == 0:
        return
    starts = np.unique(np.r_[0, b.astype(np.int64)])
    starts = starts[starts < n]
    origin = time_origin(rec, first_ns=int(t[0]), origin_ns=origin_ns)
    names = [f"section {i}" for i in range(len(starts))]
    rec.log(
        SECTIONS,
        rr.StateConfiguration(
            values=names,
            colors=np.array(
                [_rgba(SECTION_COLORS[i % 2]) for i in range(len(starts))], dtype=np.uint32
            ),
        ),
        static=True,
    )
    idx = np.r_[starts, n - 1]
    rec.send_columns(
        SECTIONS,
        indexes=time_columns(t[idx], origin, frame=idx),
        columns=rr.StateChange.columns(state=[*names, ""]),
    )


def log_greedy_scores(
    scores: Sequence[Mapping[str, Any]],
    *,
    spans: Sequence[tuple[int, int]] | None = None,
    candidate_end_ns: Sequence[npt.ArrayLike] | None = None,
    recording: Any = None,
    origin_ns: int | None = None,
) -> None:
    """Log the stage-2 HMM scores per skill for each greedy iteration.

    Parameters
    ----------
    scores : sequence of mapping skill -> score
        One mapping per greedy iteration ``k``. A float score is the score of the segment
        cut in that iteration: it goes to ``/segmentation/greedy/scores/<skill>`` on the
        ``greedy_iteration`` timeline (and on ``demo_time`` at the segment's end when ``spans``
        are given). An array score holds one score per candidate segment (1, 2, ... sections)
        and goes to ``/segmentation/greedy/iteration_<k>/<skill>`` on ``demo_time`` at the
        candidates' end times ``candidate_end_ns[k]``.
    spans : sequence of (start_ns, end_ns), optional
        The segment cut in each iteration.
    candidate_end_ns : sequence of arrays, optional
        End times of the candidate segments of each iteration (needed for array scores).
    """
    rr = import_rerun()
    rec = get_recording(recording)
    if spans is not None and len(spans) != len(scores):
        raise DemonstrationError(f"{len(spans)} spans for {len(scores)} greedy iterations")
    first: int | None = None
    if spans:
        first = int(spans[0][0])
    elif candidate_end_ns:
        first = int(np.min(as_ns(candidate_end_ns[0], "candidates")))
    origin = None if first is None else time_origin(rec, first_ns=first, origin_ns=origin_ns)

    skills = [s for s in SKILLS if any(s in m for m in scores)]
    skills += sorted({s for m in scores for s in m} - set(skills))
    for skill in skills:
        color = SKILL_COLORS.get(skill, UNKNOWN_COLOR)
        iters = [k for k, m in enumerate(scores) if skill in m and np.ndim(m[skill]) == 0]
        if iters:
            path = f"/segmentation/greedy/scores/{skill}"
            rec.log(
                path, rr.SeriesPoints(names=skill, colors=[color], marker_sizes=4.0), static=True
            )
            y = np.array([float(scores[k][skill]) for k in iters])
            indexes = [rr.TimeColumn(GREEDY_ITERATION, sequence=np.asarray(iters))]
            if spans is not None and origin is not None:
                ends = np.array([int(spans[k][1]) for k in iters], dtype=np.int64)
                indexes += time_columns(ends, origin)
            y[~np.isfinite(y)] = np.nan
            rec.send_columns(path, indexes=indexes, columns=rr.Scalars.columns(scalars=y))
        for k, m in enumerate(scores):
            if skill not in m or np.ndim(m[skill]) == 0:
                continue
            if candidate_end_ns is None or origin is None:
                raise DemonstrationError("array scores need candidate_end_ns")
            ends = as_ns(candidate_end_ns[k], f"greedy iteration {k}")
            y = np.asarray(m[skill], dtype=np.float64)
            if y.shape != ends.shape:
                raise DemonstrationError(
                    f"iteration {k}, {skill}: {y.shape[0]} scores for {ends.shape[0]} candidates"
                )
            path = f"/segmentation/greedy/iteration_{k}/{skill}"
            rec.log(path, rr.SeriesLines(names=f"{skill} (it. {k})", colors=[color]), static=True)
            ok = np.isfinite(y)
            if ok.any():
                rec.send_columns(
                    path,
                    indexes=time_columns(ends[ok], origin),
                    columns=rr.Scalars.columns(scalars=y[ok]),
                )


def log_text(
    messages: Sequence[Any],
    *,
    path: str = WARNINGS,
    level: str = "WARN",
    recording: Any = None,
    origin_ns: int | None = None,
) -> None:
    """Log messages as ``rr.TextLog`` rows.

    ``messages`` items are strings (shown at ``demo_time = 0``), ``(t_ns, text)`` pairs, or
    objects with ``message`` (or ``text``) and optionally ``t_ns``.
    """
    rr = import_rerun()
    rec = get_recording(recording)
    if not messages:
        return
    times: list[int | None] = []
    texts: list[str] = []
    for m in messages:
        if isinstance(m, str):
            times.append(None)
            texts.append(m)
        elif isinstance(m, tuple) and len(m) == 2:
            times.append(int(m[0]))
            texts.append(str(m[1]))
        else:
            t = getattr(m, "t_ns", None)
            times.append(None if t is None else int(t))
            texts.append(str(getattr(m, "message", getattr(m, "text", m))))
    known = [t for t in times if t is not None]
    if known or origin_ns is not None:
        origin = time_origin(rec, first_ns=min(known, default=0), origin_ns=origin_ns)
    else:  # untimed messages only: do not fix the origin of later data
        origin = current_origin(rec) or 0
    t_arr = np.array([origin if t is None else t for t in times], dtype=np.int64)
    rec.send_columns(
        path,
        indexes=time_columns(t_arr, origin),
        columns=rr.TextLog.columns(text=texts, level=[level] * len(texts)),
    )


def log_segmentation(
    segments: Iterable[SegmentLike] | None = None,
    *,
    ground_truth: Iterable[SegmentLike] | None = None,
    baselines: Mapping[str, Iterable[SegmentLike]] | None = None,
    boundaries: npt.ArrayLike | None = None,
    t_ns: npt.ArrayLike | None = None,
    scores: Sequence[Mapping[str, Any]] | None = None,
    spans: Sequence[tuple[int, int]] | None = None,
    candidate_end_ns: Sequence[npt.ArrayLike] | None = None,
    warnings: Sequence[Any] | None = None,
    log: Sequence[Any] | None = None,
    recording: Any = None,
    origin_ns: int | None = None,
    side: str | None = None,
) -> None:
    """Log everything a segmentation produced, each part optional (with ``side``, the skill
    lanes are that hand's, ``/segmentation/skills/<side>/...``).

    Parameters
    ----------
    segments : iterable of SegmentLike, optional
        The result's skill spans (lane ``result``).
    ground_truth : iterable of SegmentLike, optional
        The demonstration's labels (lane ``ground_truth``).
    baselines : mapping name -> segments, optional
        Baseline results, one lane each (``baseline_<name>``).
    boundaries, t_ns : optional
        Stage-1 section starts (sample indices) and the sample times, see :func:`log_sections`.
    scores, spans, candidate_end_ns : optional
        Stage-2 greedy scores, see :func:`log_greedy_scores`.
    warnings : sequence, optional
        Grammar violations and other warnings (``/segmentation/warnings``), see :func:`log_text`.
    log : sequence, optional
        Informational messages (``/segmentation/log``).
    """
    rec = get_recording(recording)
    if boundaries is not None:
        if t_ns is None:
            raise DemonstrationError("section boundaries need the sample times t_ns")
        log_sections(boundaries, t_ns, recording=rec, origin_ns=origin_ns)
    lanes = {"ground_truth": ground_truth, "result": segments}
    lanes |= {f"baseline_{name}": segs for name, segs in (baselines or {}).items()}
    for source, spans_of in lanes.items():
        if spans_of is not None:
            log_skill_spans(spans_of, source=source, recording=rec, origin_ns=origin_ns, side=side)
    if scores is not None:
        log_greedy_scores(
            scores,
            spans=spans,
            candidate_end_ns=candidate_end_ns,
            recording=rec,
            origin_ns=origin_ns,
        )
    if warnings:
        log_text(warnings, recording=rec, origin_ns=origin_ns)
    if log:
        log_text(log, path=LOG, level="INFO", recording=rec, origin_ns=origin_ns)
