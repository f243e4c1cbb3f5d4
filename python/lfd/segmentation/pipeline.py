"""The two-stage segmentation of one demonstration (paper Sec. III-B, Fig. 4).

trajectory -> gap filling -> Table I features -> stage 1 (section boundaries) -> stage 2 (score
table from the templates, TCP rise decision, greedy loop or segmental DP under the grammar)
-> :class:`~lfd.segmentation.result.Segmentation` with target objects and skill parameters.
"""

from __future__ import annotations

import dataclasses
import functools
from bisect import bisect_left, bisect_right
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from itertools import pairwise
from typing import TYPE_CHECKING, Any, Literal, get_args

import numpy as np

from .. import _hmmseg
from .._hmmseg import EndState, GrammarMode
from ..contact import ContactParams, refine
from ..demo import Demonstration
from ..errors import DemonstrationError, InvalidParameterError
from ..trajectory import Trajectory

if TYPE_CHECKING:
    from ..features import Features
from .band import Band, StageTwoScores
from .gaps import fill_gaps
from .grammar import compiled_grammar, needs_move_between
from .params import skill_params_batch
from .result import Run, Segment, Segmentation
from .stage1 import OBJECT_COLUMNS, Stage1Params, section_boundaries
from .templates import Templates

Search = Literal["dp", "greedy"]
"""The stage-2 search: the segmental DP or the paper's greedy loop."""
GrammarUse = GrammarMode
"""How the skill grammar is used (the engine's ``GrammarMode``: "off", "warn", "enforce")."""

DEFAULT_SEARCH: Search = "dp"
"""The default stage-2 search: the segmental DP (11/12 exact sequences on held-out demos, against
6/12 for the paper's greedy loop; docs/segmentation.md)."""
DEFAULT_GRAMMAR: GrammarUse = "enforce"
"""The default grammar use: only allowed skill transitions are considered."""
PAPER_SEARCH: Search = "greedy"
"""The paper's algorithm: the greedy cut loop of Eq. 3-5..."""
PAPER_GRAMMAR: GrammarUse = "warn"
"""...keeping the best result and warning about impossible transitions (Fig. 6)."""


@dataclass(frozen=True)
class SegmentParams:
    """Parameters of the segmentation beyond the templates.

    Attributes
    ----------
    stage1 : Stage1Params
        Stage-1 hysteresis and minimum section length.
    end : {"final", "any"}
        ``final``: a segment must end in the last state of the skill's left-right HMM (a
        complete execution); ``any``: the plain forward likelihood of Eq. 3.
    min_rise : float
        A run of sections is "rising" (Fig. 5: only Move / Move with) if the TCP climbs at least
        this much (metres) in one go (largest rise inside the run)...
    dominance : float
        ...and its summed climb is at least ``dominance`` times its summed descent (0: off).
    max_segment_s : float
        Longest skill segment considered (seconds; the template skills last 1-4 s); bounds the
        forward passes.
    lookahead : bool
        Greedy search: value each candidate cut by its per-sample score together with the best
        segment that may follow it, instead of its own per-sample score alone (measured in
        docs/segmentation.md: 14 -> 19 of 24 exact sequences with the grammar enforced).
    penalty : float
        Per-segment penalty of the DP (nats).
    min_duration_s : float
        A demonstration shorter than this cannot hold a skill (DemonstrationError).
    co_motion : float
        Co-motion evidence (beyond the paper): a skill acts on its own object only, so every
        sample of a segment in which another object moves (speed above ``v_th``), or in which
        the target itself moves during a Move or Locate, costs this many nats
        (:func:`co_motion_penalty`; 0: off). Without it a segment can explain a real carry of
        one box as an empty-hand Move "relative to" a box that stays put.
    co_motion_grace_s : float
        Object motion this close to a segment's ends is not charged (boundaries are uncertain
        by about this much).
    co_motion_slide_s : float
        A carried target (Move with) moves while it still rests on the table only as it is
        lifted off (0.07-0.23 s in the ground truth of the tuning demos; a Push slides its box
        0.37-1 s): beyond this much sliding, every sliding sample costs ``co_motion`` nats
        (:data:`CARRIED`; negative: off). Without it a Push is read live as Pick up -> Move with
        until the missing Place shows it.
    co_motion_left_s : float
        A carried target moves with the hand: beyond this many seconds in which the hand moves
        (:func:`moving_hand`) while the target stays (at most 0.4 s in the ground truth of
        the tuning demos, median 0), every such sample of a Move with costs ``co_motion`` nats
        (negative: off). Without it a Push, or a Move away from a box, is read live as a Move with
        that is never put down.
    implicit_moves : bool
        A Move between a release (Place, Stack) and the next skill may be shorter than a stage-1
        section: when the hand re-grasps the object it has just put down, it opens a little,
        rises a few millimetres and closes again in 0.1-0.3 s. With this on the search may go
        from the release straight to the next skill and the Move is inserted around the
        TCP's highest point between them (:func:`insert_implicit_moves`).
    implicit_move_s : float
        Length of an inserted Move (seconds).
    contacts : ContactParams or None
        Put the boundaries of the skills that touch an object where contact says
        (:func:`lfd.contact.refine`: a Pick up from the last sample the hand was 8 cm from the
        object to its first motion, a Place or Stack to the release, the Moves around them);
        None: the search's boundaries as they are (the paper).
    co_motion_window_s, co_motion_displacement : float
        An object moves at a sample when it is displaced by more than ``co_motion_displacement``
        metres between ``co_motion_window_s`` before and after it (:func:`moving_objects`;
        a displacement, unlike a speed threshold, ignores tag noise and interpolated gaps).
    """

    stage1: Stage1Params = field(default_factory=Stage1Params)
    end: EndState = "final"
    min_rise: float = 0.025
    dominance: float = 0.0
    max_segment_s: float = 10.0
    lookahead: bool = True
    penalty: float = 10.0
    min_duration_s: float = 0.5
    co_motion: float = 20.0
    co_motion_grace_s: float = 0.0
    co_motion_slide_s: float = 0.25
    co_motion_left_s: float = 0.4
    co_motion_window_s: float = 1.0 / 6.0
    implicit_moves: bool = True
    implicit_move_s: float = 0.2
    co_motion_displacement: float = 0.015
    contacts: ContactParams | None = field(default_factory=ContactParams)

    def __post_init__(self) -> None:
        from ..rules import check_fields
        from .schema import SEGMENT_RULES

        check_fields(self, SEGMENT_RULES, "params.")


PAPER_PARAMS = SegmentParams(
    stage1=Stage1Params(object_criteria=False, min_section_s=0.2),
    min_rise=0.02,
    co_motion=0.0,
    implicit_moves=False,
    contacts=None,
)
"""The paper's pipeline around the search (with :data:`PAPER_SEARCH`, :data:`PAPER_GRAMMAR` and the
paper-recipe templates, ``lfd segment --paper``): stage 1 on the hand signals only (sections
>= 0.2 s), a 2 cm rise threshold, no co-motion evidence, no implicit moves."""


def segment_trajectory(
    traj: Trajectory,
    templates: Templates,
    *,
    search: Search = "dp",
    grammar: GrammarUse = "enforce",
    params: SegmentParams | None = None,
    complete: bool = True,
) -> Segmentation:
    """Segment a preprocessed trajectory (see :func:`lfd.segment`)."""
    from ..features import compute_features

    p = params or SegmentParams()
    for option, value, allowed in (
        ("search", search, get_args(Search)),
        ("grammar", grammar, get_args(GrammarMode)),
        ("end", p.end, get_args(EndState)),
    ):
        if value not in allowed:
            raise InvalidParameterError(
                f"{option} must be one of {', '.join(map(repr, allowed))}, got {value!r}"
            )
    if len(traj) < 2 or traj.dt <= 0 or (len(traj) - 1) * traj.dt < p.min_duration_s:
        dur = max(len(traj) - 1, 0) * max(traj.dt, 0.0)
        raise DemonstrationError(
            f"the demonstration lasts {dur:.2f} s, too short for any skill "
            f"(at least {p.min_duration_s} s)"
        )
    filled, warnings = fill_gaps(traj)
    feats = compute_features(filled)
    values = np.ascontiguousarray(feats.values, dtype=np.float64)
    per_object = [compute_features(filled, target=o) for o in range(len(filled.object_names))]
    bounds = section_boundaries(
        values,
        feats.thresholds,
        traj.dt,
        p.stage1,
        objects=[(f.values, f.thresholds) for f in per_object],
    )
    st = stage2_scores(filled, templates, bounds, p, per_object, complete=complete)
    max_len = st.band.max_len
    rising = _hmmseg.rising_band(
        np.ascontiguousarray(filled.tcp[:, 2]), bounds, max_len, p.min_rise, p.dominance
    )
    skills = templates.skills
    rules = compiled_grammar(tuple(skills), p.implicit_moves)
    if search == "greedy":
        cuts, warn = _hmmseg.segment_greedy(
            st.scores, bounds, rules, rising, grammar, p.lookahead, max_len
        )
    else:
        cuts, warn = _hmmseg.segment_dp(
            st.scores, bounds, rules, rising, grammar, p.penalty, max_len
        )
    segments = _make_segments(
        filled,
        [
            _Draft(skills[c.skill], c.start, c.end, _target(st, c), c.score, c.confidence, c.margin)
            for c in cuts
        ],
    )
    if p.implicit_moves:
        segments = insert_implicit_moves(
            filled, segments, max(1, round(p.implicit_move_s / traj.dt))
        )
    if p.contacts is not None:
        segments = refine_contacts(filled, segments, p.contacts, complete=complete)
    segments = label_moves(filled, segments)
    return Segmentation(
        segments=segments,
        warnings=warnings + list(warn),
        method=search,
        sections=[int(b) for b in bounds],
        object_names=list(filled.object_names),
        run=Run(filled, feats, per_object, st),
    )


def _target(st: StageTwoScores, cut: _hmmseg.Cut) -> int:
    """The target object of a chosen segment (a run of the band: the search picks no other)."""
    i, j = cut.start_section, cut.end_section
    r = st.band.index(i, j)
    if r is None:
        raise AssertionError(f"the search chose sections {i}..{j}, outside the score band")
    return int(st.target[r, cut.skill])


def stage2_scores(
    traj: Trajectory,
    templates: Templates,
    bounds: np.ndarray,
    params: SegmentParams,
    per_object: list[Features] | None = None,
    *,
    complete: bool = True,
) -> StageTwoScores:
    """The score table of a gap-free trajectory's runs of sections as the search sees it, and
    the target object of each entry, over the runs of at most ``max_segment_s`` (a
    :class:`~lfd.segmentation.band.Band`: memory and time linear in the demonstration).

    The skills are object-centred: for every run of sections and skill the features are taken
    relative to each object in turn, the co-motion evidence (:func:`co_motion_penalty`) is
    added, and the best-explaining object is the segment's target (``c^{r,s} = max_o sum_f log
    P(O_f^{r,o} | lambda_f^s) + co-motion``). This replaces a fixed per-sample target labelling,
    which cannot know the target of skills that never move their object (Locate).
    ``per_object``: ``compute_features(traj, target=o)`` for every object (computed if None).
    ``complete`` False (a recording still being made): the runs that end with the recording so
    far are scored with ``end="any"``, as the skill under way need not have finished.
    """
    from ..features import compute_features

    p = params
    if per_object is None:
        per_object = [compute_features(traj, target=o) for o in range(len(traj.object_names))]
    band = Band.of(bounds, max(1, round(p.max_segment_s / traj.dt)))
    moving = moving_objects(traj, p.co_motion_window_s, p.co_motion_displacement)
    hand = moving_hand(traj, p.co_motion_window_s, p.co_motion_displacement)
    height = OBJECT_COLUMNS["object_height"]  # above the object's rest height + gamma: lifted

    values = [np.ascontiguousarray(f.values, dtype=np.float64) for f in per_object]
    shared = shared_features(values, templates)

    extra = co_motion_per_object(
        moving,
        bounds,
        templates.skills,
        p.co_motion,
        lifted=np.stack([f.values[:, height] > f.thresholds[:, height] for f in per_object]),
        grace=round(p.co_motion_grace_s / traj.dt),
        slide=p.co_motion_slide_s / traj.dt,
        hand=hand,
        left=p.co_motion_left_s / traj.dt,
        band=band,
    )
    st = scores_over_objects(values, templates, band, p.end, extra=extra, shared=shared)
    if complete or p.end == "any":
        return st
    k = band.n_sections
    last = [r for i in range(k) if (r := band.index(i, k)) is not None]
    if last:
        # only these runs are scored again: over the band of the sections from the first of
        # them on, whose rows are the band's from that section's on (a run's score depends on
        # its own samples only)
        i0 = int(band.start[last[0]])
        r0 = int(band.offsets[i0])
        tail = Band.of(band.bounds[i0:] - band.bounds[i0], band.max_len)
        same = (
            tail.n_runs == band.n_runs - r0
            and np.array_equal(tail.start + i0, band.start[r0:])
            and np.array_equal(tail.end + i0, band.end[r0:])
        )
        a = int(band.bounds[i0]) if same else 0
        st_any = scores_over_objects(
            [v[a:] for v in values] if same else values,
            templates,
            tail if same else band,
            "any",
            extra=_rows(extra, r0) if same else extra,
            shared=shared,
        )
        rows = np.asarray(last) - (r0 if same else 0)
        st.scores[last] = st_any.scores[rows]
        st.target[last] = st_any.target[rows]
    return st


def _rows(extra: Callable[[int], np.ndarray] | None, r0: int) -> Callable[[int], np.ndarray] | None:
    """``extra`` (:func:`co_motion_per_object`) from row ``r0`` on."""
    if extra is None:
        return None
    if isinstance(extra, CoMotion) and extra.banded:
        return dataclasses.replace(extra, lo=extra.lo[r0:], hi=extra.hi[r0:])
    return lambda o: extra(o)[r0:]


def insert_implicit_moves(traj: Trajectory, segments: list[Segment], length: int) -> list[Segment]:
    """Insert the Move that a release -> skill transition, or a Locate followed by a skill on
    another object, stands for (see :func:`~lfd.segmentation.grammar.needs_move_between`):
    ``length`` samples centred on the TCP's highest point in the last ``length`` samples of the
    first skill and the first ``length`` of the next, taken from both (each keeps at least one
    sample)."""
    names = list(traj.object_names)
    out: list[_Draft] = []
    z = traj.tcp[:, 2]
    for seg in segments:
        prev = out[-1] if out else None
        if prev is None or not needs_move_between(
            prev.skill, prev.object_name(names), seg.skill, seg.object
        ):
            out.append(_Draft.of(seg, names))
            continue
        lo, hi = max(prev.start + 1, seg.start - length), min(seg.end - 1, seg.start + length)
        peak = lo + int(np.argmax(z[lo:hi])) if hi > lo else seg.start
        a = min(max(lo, peak - length // 2), seg.start)
        b = max(min(hi, a + length), seg.start)
        a = min(a, b - 1)
        nxt = _Draft.of(seg, names)
        out[-1] = prev.resized(prev.start, a)
        out.append(_Draft("move", a, b, nxt.obj))
        out.append(nxt.resized(b, seg.end))
    return _make_segments(traj, [d for d in out if d.end > d.start])


def refine_contacts(
    traj: Trajectory, segments: list[Segment], params: ContactParams, *, complete: bool = True
) -> list[Segment]:
    """The segments with the boundaries of the skills that touch an object put where contact
    says (:func:`lfd.contact.refine`, ``complete`` as there); unchanged segments are kept as
    they are."""
    names = list(traj.object_names)
    spans = [
        (s.skill, s.start, s.end, names.index(s.object) if s.object in names else None)
        for s in segments
    ]
    refined = refine(
        spans,
        traj.tcp,
        traj.keypoints[:, 4],
        traj.object_position,
        traj.object_quaternion,
        traj.object_size,
        params,
        opening=traj.opening,
        complete=complete,
    )
    if refined == spans:
        return segments
    source = _overlapping(segments)
    out: list[_Draft] = []
    for skill, a, b, o in refined:
        # the segment of the search it came from: the same skill, overlapping it most (its
        # score, confidence and margin are the search's; an inserted Move has none)
        best, src = 0, None
        for s in source(a, b):
            if s.skill == skill and (ov := min(b, s.end) - max(a, s.start)) > best:
                best, src = ov, s
        if src is not None:
            d = _Draft.of(src, names)
            out.append(d if (src.start, src.end) == (a, b) else d.resized(a, b))
        else:
            out.append(_Draft(skill, a, b, o))
    return _make_segments(traj, out)


def _overlapping(segments: list[Segment]) -> Callable[[int, int], list[Segment]]:
    """``of(a, b)``: the ``segments`` that share a sample with ``a..b``, in their order (a
    bisection when they are in time order without overlaps, as the search gives them; else
    all of them)."""
    starts = [s.start for s in segments]
    ends = [s.end for s in segments]
    ordered = all(s.start <= s.end <= nxt.start for s, nxt in pairwise(segments))
    if not ordered:
        return lambda a, b: segments

    def of(a: int, b: int) -> list[Segment]:
        return segments[bisect_right(ends, a) : bisect_left(starts, b)]

    return of


MOVE_OBJECT_S = 1.0
"""A Move's object is the one nearest the hand this long (s) after the Move ends
(:func:`label_moves`)."""


def nearest_object(tcp: np.ndarray, positions: np.ndarray) -> int | None:
    """Index of the object (rows of ``positions``, ``(O, 3)``) nearest ``tcp`` (None if no
    position is finite)."""
    d = np.linalg.norm(np.asarray(positions) - np.asarray(tcp), axis=-1)
    return int(np.nanargmin(d)) if np.isfinite(d).any() else None


def object_after(tcp: np.ndarray, positions: np.ndarray, end: int, k: int) -> int | None:
    """The object a Move ending at sample ``end`` goes towards (:func:`label_moves`' rule): the
    one nearest the hand ``k`` samples later, or at the last sample if that is sooner. ``tcp``
    ``(n, 3)``, ``positions`` ``(n, O, 3)``: the samples so far (live) or all of them."""
    e = min(end + k, len(tcp) - 1)
    return nearest_object(tcp[e], positions[e])


def label_moves(
    traj: Trajectory, segments: list[Segment], after_s: float = MOVE_OBJECT_S
) -> list[Segment]:
    """Give every Move the object it goes towards: the one nearest the hand ``after_s`` after
    the Move ends (then the hand is at, or carrying, the object of the skill after the Move,
    the ground truth's convention, in 160 of 165 Moves of the evaluation demos); a Move that
    ends the demonstration has none. The object that best explains a Move's own samples is
    ambiguous (the hand is near no box, or near several); decided this way the label depends
    on positions only, so the live segmentation, which knows them by then, gives the same."""
    out = list(segments)
    k = max(0, round(after_s / traj.dt)) if traj.dt > 0 else 0
    moves = [i for i, seg in enumerate(out) if seg.skill == "move"]
    # object_after of every Move but a last one, at once
    inner = [i for i in moves if i + 1 < len(out)]
    e = np.minimum(np.array([out[i].end for i in inner], dtype=np.intp) + k, len(traj.tcp) - 1)
    positions = np.asarray(traj.object_position)[:, e].transpose(1, 0, 2)  # (m, O, 3)
    d = np.linalg.norm(positions - np.asarray(traj.tcp)[e][:, None, :], axis=-1)
    some = np.isfinite(d).any(axis=-1)
    nearest = np.nanargmin(np.where(some[:, None], d, 0.0), axis=-1) if some.any() else some
    after = {i: int(j) for i, j, ok in zip(inner, nearest, some, strict=True) if ok}
    for i in moves:
        seg = out[i]
        obj = after.get(i)
        name = traj.object_names[obj] if obj is not None else None
        if name != seg.object:
            out[i] = dataclasses.replace(seg, object=name)
    return out


def moving_objects(traj: Trajectory, window_s: float, displacement: float) -> np.ndarray:
    """``(O, n)``: object ``o`` moves at sample ``t`` if it is displaced by more than
    ``displacement`` (m) between ``t - window_s`` and ``t + window_s`` (NaN-free input)."""
    return _moving(traj, np.asarray(traj.object_position, dtype=np.float64), window_s, displacement)


def moving_hand(traj: Trajectory, window_s: float, displacement: float) -> np.ndarray:
    """``(n,)``: the TCP moves at sample ``t``, by the rule of :func:`moving_objects`."""
    return _moving(traj, np.asarray(traj.tcp, dtype=np.float64), window_s, displacement)


def _moving(traj: Trajectory, pos: np.ndarray, window_s: float, displacement: float) -> np.ndarray:
    """The rule of :func:`moving_objects` on positions ``(..., n, 3)`` of ``traj``'s samples."""
    n = len(traj)
    w = motion_window(traj.dt, window_s)
    idx = np.arange(n)
    a, b = np.clip(idx - w, 0, n - 1), np.clip(idx + w, 0, n - 1)
    return displaced(pos[..., a, :], pos[..., b, :], displacement)


def motion_window(dt: float, window_s: float) -> int:
    """Half-width in samples of the window of :func:`moving_objects`."""
    return max(1, round(window_s / dt)) if dt > 0 else 1


def displaced(before: np.ndarray, after: np.ndarray, displacement: float) -> np.ndarray:
    """Is an object displaced by more than ``displacement`` (m) between two positions (``(...,
    3)`` each)? The co-motion rule of :func:`moving_objects`."""
    return np.asarray(np.linalg.norm(after - before, axis=-1) > displacement)


TARGET_STILL: frozenset[str] = frozenset({"move", "locate", "pick_up"})
"""Skills whose target object does not move (a Pick up ends when the fingers have closed, before
the lift; the other skills move their target or may)."""
NO_SET_DOWN: frozenset[str] = frozenset({"move_with", "pick_up"})
"""Skills in which a lifted target is not put down again (that is a Place or a Stack)."""
NO_LIFT: frozenset[str] = frozenset({"place", "stack", "push"})
"""Skills in which a resting target is not lifted (after a Place or Stack that is a new Pick up;
a Push slides its object on the table)."""
CARRIED: frozenset[str] = frozenset({"move_with"})
"""Skills that carry their target lifted: it slides on the table only while it is lifted off."""


def _next_true(mask: np.ndarray) -> np.ndarray:
    """``(O, n + 1)``: the first index ``>= t`` where ``mask[o]`` is true (``n`` if none)."""
    n_obj, n = mask.shape
    out = np.full((n_obj, n + 1), n, dtype=np.int64)
    at = np.where(mask, np.arange(n), n)  # t where true
    out[:, :n] = np.minimum.accumulate(at[:, ::-1], axis=1)[:, ::-1]  # smallest from t on
    return out


def _cumulative(mask: np.ndarray) -> np.ndarray:
    """``(n + 1,)``: how many samples of ``mask`` (n,) come before each index."""
    cum = np.zeros(len(mask) + 1)
    np.cumsum(mask, out=cum[1:])
    return cum


def _count_from(
    cum: np.ndarray, first: np.ndarray | None, lo: np.ndarray, hi: np.ndarray
) -> np.ndarray:
    """Samples of a mask in ``[max(lo, first[lo]), hi)`` per run, from its
    :func:`_cumulative` counts ``cum``, for sample indices ``lo`` and ``hi`` of broadcastable
    shapes (one pair per run); ``first`` (n + 1,): the first index ``>= t`` where the mask is
    true (:func:`_next_true`; None: ``t`` itself)."""
    start = lo if first is None else first[lo]
    d = cum[hi] - cum[start]
    np.maximum(d, 0.0, out=d)
    return np.asarray(np.where(hi > start, d, 0.0))


def co_motion_penalty(
    moving: np.ndarray,
    bounds: np.ndarray,
    skills: list[str],
    weight: float,
    *,
    lifted: np.ndarray | None = None,
    grace: int = 0,
    slide: float = -1.0,
    hand: np.ndarray | None = None,
    left: float = -1.0,
    band: Band | None = None,
) -> np.ndarray | None:
    """Penalty ``(O, N, S)`` over the runs of ``band``, or ``(O, K, K + 1, S)`` over every run
    without one (quadratic in ``K``), of object motion a segment cannot explain.

    ``moving`` (O, n) says where each object moves, ``lifted`` (O, n) where it is above its
    resting height. A segment from section ``i`` to ``j`` with target ``o`` and skill ``s`` is
    charged ``weight`` per sample

    - in which another object moves (a skill acts on its own object only);
    - in which ``o`` moves, if ``s`` keeps its target still (:data:`TARGET_STILL`);
    - in which ``o`` rests after it was lifted in the segment, if ``s`` does not put it down
      (:data:`NO_SET_DOWN`), or is lifted after it rested, if ``s`` does not lift it
      (:data:`NO_LIFT`): repeated cycles on one object come out as separate segments;
    - beyond the first ``slide`` (samples, negative: none charged) in which ``o`` moves while it
      rests, if ``s`` carries it lifted (:data:`CARRIED`): that is a Push;
    - beyond the first ``left`` (samples, negative: none charged) in which the hand moves
      (``hand`` (n,), :func:`moving_hand`) while ``o`` stays, if ``s`` carries ``o``: the hand
      has left it behind.

    ``grace`` samples at each end of a segment are free. ``None`` if ``weight`` is 0.
    """
    of = co_motion_per_object(
        moving,
        bounds,
        skills,
        weight,
        lifted=lifted,
        grace=grace,
        slide=slide,
        hand=hand,
        left=left,
        band=band,
    )
    return None if of is None else np.stack([of(o) for o in range(moving.shape[0])])


def co_motion_per_object(
    moving: np.ndarray,
    bounds: np.ndarray,
    skills: list[str],
    weight: float,
    *,
    lifted: np.ndarray | None = None,
    grace: int = 0,
    slide: float = -1.0,
    hand: np.ndarray | None = None,
    left: float = -1.0,
    band: Band | None = None,
) -> CoMotion | None:
    """:func:`co_motion_penalty` one target object at a time: ``of(o)`` is its ``[o]``, and
    with a ``band`` ``of.rows(o, r0, r1)`` its rows ``r0:r1`` (the sample counts behind it are
    computed per object and run, without the skill axis, when asked for)."""
    if np.isnan(slide):
        raise InvalidParameterError("co_motion_slide_s must be a number (negative: off), got nan")
    if np.isnan(left):
        raise InvalidParameterError("co_motion_left_s must be a number (negative: off), got nan")
    if weight == 0 or moving.size == 0:
        return None
    n_obj, n = moving.shape
    b = np.asarray(bounds, dtype=np.int64)
    lo = np.minimum(b[:-1] + grace, n)  # (K,)
    hi = np.maximum(b - grace, 0)  # (K + 1,)
    if band is None:  # every run: (K, 1) x (1, K + 1)
        lo, hi = lo[:, None], hi[None, :]
    else:  # the band's runs: (N,)
        lo, hi = lo[band.start], hi[band.end]
    still = _skill_mask(skills, TARGET_STILL)
    no_set_down, no_lift = _skill_mask(skills, NO_SET_DOWN), _skill_mask(skills, NO_LIFT)
    carried = _skill_mask(skills, CARRIED)
    h = np.asarray(hand, dtype=bool)[:n] if hand is not None and left >= 0 else None
    lift = None
    if lifted is not None:  # (lifted, resting, next lifted, next resting)
        resting = ~lifted
        lift = (lifted, resting, _next_true(lifted), _next_true(resting))

    # per skill, the counts it is charged for, in the order they are summed (a count times 0 adds
    # nothing: every count is finite and >= 0)
    masks = [still, no_set_down, no_lift, carried, carried]
    present = [True, lifted is not None, lifted is not None, lifted is not None and slide >= 0]
    present.append(h is not None)
    charged = [
        tuple(k for k, mask in enumerate(masks) if present[k] and mask[s])
        for s in range(len(skills))
    ]

    # each mask's cumulative counts, computed once, when first asked for
    mask_of: dict[str, Callable[[int], np.ndarray]] = {"moving": lambda o: moving[o]}
    if lift is not None:
        lifted_, resting_ = lift[0], lift[1]
        mask_of["resting"] = lambda o: resting_[o]
        mask_of["lifted"] = lambda o: lifted_[o]
        mask_of["sliding"] = lambda o: moving[o] & resting_[o]
    if h is not None:
        hand_ = h
        mask_of["left"] = lambda o: hand_ & ~moving[o]
    cums: dict[tuple[str, int], np.ndarray] = {}

    def cum(kind: str, o: int) -> np.ndarray:
        if (kind, o) not in cums:
            cums[kind, o] = _cumulative(mask_of[kind](o))
        return cums[kind, o]

    last: list[Any] = []  # [(lo, hi) as asked, their key, (own, total)]

    def own_counts(lo: np.ndarray, hi: np.ndarray) -> tuple[list[np.ndarray], np.ndarray]:
        # every object's own motion over the runs lo..hi and their sum: the same for every
        # target, so kept for the last runs asked for (the rows of one piece, object by object;
        # the arrays asked with are held, so equal buffers are the same indices)
        key = [(a.__array_interface__["data"][0], a.shape, a.strides) for a in (lo, hi)]
        if not last or last[1] != key:
            own = [_count_from(cum("moving", q), None, lo, hi) for q in range(n_obj)]
            total = own[0].copy()
            for q in range(1, n_obj):
                total += own[q]
            last[:] = [(lo, hi), key, (own, total)]
        result: tuple[list[np.ndarray], np.ndarray] = last[2]
        return result

    def of(o: int, lo: np.ndarray, hi: np.ndarray, into: np.ndarray | None = None) -> np.ndarray:
        # object o's counts over the runs lo..hi, in the order of ``masks``; the other
        # objects' motion is the objects' summed own motion less o's (exact: sample counts)
        own, total = own_counts(lo, hi)
        counts: list[np.ndarray | None] = [own[o], None, None, None, None]
        if lift is not None:
            counts[1] = _count_from(cum("resting", o), lift[2][o], lo, hi)
            counts[2] = _count_from(cum("lifted", o), lift[3][o], lo, hi)
            if slide >= 0:
                sliding = _count_from(cum("sliding", o), None, lo, hi) - slide
                counts[3] = np.maximum(sliding, 0.0)
        if h is not None:
            counts[4] = np.maximum(_count_from(cum("left", o), None, lo, hi) - left, 0.0)
        out = np.empty((*total.shape, len(skills))) if into is None else into
        done: dict[tuple[int, ...], np.ndarray] = {}
        for s, which in enumerate(charged):
            if which not in done:  # skills charged for the same counts share a column
                col = total - own[o]
                for k in which:
                    count = counts[k]
                    assert count is not None
                    col += count
                col *= -weight
                done[which] = col
            if into is None:
                out[..., s] = done[which]
            else:
                out[..., s] += done[which]
        return out

    return CoMotion(of, lo, hi, band is not None)


@dataclass(frozen=True, eq=False)
class CoMotion:
    """The co-motion penalty of :func:`co_motion_per_object`: ``self(o)`` that of target
    object ``o`` over all runs, ``self.rows(o, r0, r1)`` its rows ``r0:r1`` of a band's table
    (each computed when asked for)."""

    of: Callable[[int, np.ndarray, np.ndarray, np.ndarray | None], np.ndarray]
    lo: np.ndarray
    hi: np.ndarray
    banded: bool

    def __call__(self, o: int) -> np.ndarray:
        return self.of(o, self.lo, self.hi, None)

    def rows(self, o: int, r0: int, r1: int) -> np.ndarray:
        """Rows ``r0:r1`` of ``self(o)``."""
        if not self.banded:
            return self(o)[r0:r1]
        return self.of(o, self.lo[r0:r1], self.hi[r0:r1], None)

    def add_rows(self, o: int, r0: int, r1: int, table: np.ndarray) -> None:
        """``table += self.rows(o, r0, r1)``, without the rows as an array of their own."""
        if not self.banded:
            table += self.rows(o, r0, r1)
        else:
            self.of(o, self.lo[r0:r1], self.hi[r0:r1], table)


def _skill_mask(skills: list[str], which: frozenset[str]) -> np.ndarray:
    return np.array([s in which for s in skills], dtype=np.float64)


SCORE_CHUNK = 1 << 15
"""The score band is built in pieces of the runs starting in about this many samples
(:func:`scores_over_objects`): only the maximum over the objects is held for all runs."""


def scores_over_objects(
    values: list[np.ndarray],
    templates: Templates,
    band: Band,
    end: EndState,
    *,
    extra: np.ndarray | Callable[[int], np.ndarray] | None = None,
    shared: list[int] | None = None,
    chunk: int = SCORE_CHUNK,
) -> StageTwoScores:
    """The score table over the runs of ``band`` maximised over the target object, from the
    feature matrices, one (n, 10) array per target object; ``extra`` (O, N, S), or a function
    of the object giving its (N, S) (:func:`co_motion_per_object`), is added per target before
    the maximum (e.g. :func:`co_motion_penalty`). ``shared``: the features scored once for all
    objects (default: :func:`shared_features`).

    The runs starting in about ``chunk`` samples are scored at a time, each piece over its own
    samples (a run's score depends on its own samples only: the entries are those of the whole
    band), so besides the result only one piece's tables are held."""
    engine = templates.engine
    groups = getattr(templates, "features", None)
    max_len = band.max_len
    extra_of = extra if callable(extra) or extra is None else extra.__getitem__
    if shared is None:
        shared = shared_features(values, templates)
    if groups is None:  # a stand-in without feature metadata: a dense table per object
        bounds = band.bounds

        def dense_of(o: int) -> np.ndarray:
            cur = np.asarray(band.take(engine.score_table(values[o], bounds, max_len, end)))
            cur = np.asarray(cur, dtype=np.float64)
            if extra_of is not None:
                cur += extra_of(o)
            return cur

        best, target = max_over_objects(dense_of, len(values))
        return StageTwoScores(band, best, target)
    rest = [g for g in range(len(groups)) if g not in shared]
    n_obj = len(values) if rest or extra is not None else 1
    n_skills = len(templates.skills)
    best = np.empty((band.n_runs, n_skills))
    target = np.zeros(best.shape, dtype=np.min_scalar_type(n_obj - 1))
    for i0, i1, e in _pieces(band, chunk):
        a, b = int(band.bounds[i0]), int(band.bounds[e])
        r0, r1 = int(band.offsets[i0]), int(band.offsets[i1])
        if i0 == 0 and e == band.n_sections:  # the whole band
            piece, view = band.bounds, list(values)
        else:
            piece, view = band.bounds[i0 : e + 1] - a, [v[a:b] for v in values]
        add_extra: Callable[[int, np.ndarray], None] | None = None
        if isinstance(extra_of, CoMotion):
            add_extra = functools.partial(_add_co_motion, extra_of, r0, r1)
        elif extra_of is not None:
            add_extra = _AddRows(extra_of, r0, r1)
        base = _band_rows(engine, view[0], piece, max_len, end, shared, r1 - r0) if shared else 0.0
        scores_of = functools.partial(
            _piece_scores, engine, view, piece, max_len, end, base, rest, add_extra, r1 - r0
        )
        best[r0:r1], target[r0:r1] = max_over_objects(scores_of, n_obj)
    return StageTwoScores(band, best, target)


@dataclass(frozen=True)
class _AddRows:
    """Add rows ``r0:r1`` of ``of(o)`` to a table."""

    of: Callable[[int], np.ndarray]
    r0: int
    r1: int

    def __call__(self, o: int, table: np.ndarray) -> None:
        table += self.of(o)[self.r0 : self.r1]


def _add_co_motion(extra: CoMotion, r0: int, r1: int, o: int, table: np.ndarray) -> None:
    extra.add_rows(o, r0, r1, table)


def _band_rows(
    engine: Any,
    v: np.ndarray,
    piece: np.ndarray,
    max_len: int,
    end: EndState,
    feats: list[int],
    n_rows: int,
) -> np.ndarray:
    """The first ``n_rows`` rows of ``engine.score_band``."""
    t = np.asarray(engine.score_band(v, piece, max_len, end, feats))
    return t if len(t) == n_rows else t[:n_rows]


def _piece_scores(
    engine: Any,
    view: list[np.ndarray],
    piece: np.ndarray,
    max_len: int,
    end: EndState,
    base: np.ndarray | float,
    rest: list[int],
    add_extra: Callable[[int, np.ndarray], None] | None,
    n_rows: int,
    o: int,
) -> np.ndarray:
    """Target object ``o``'s rows of a piece of :func:`scores_over_objects`: the first
    ``n_rows`` rows of the band of ``max_len`` samples over the boundaries ``piece`` of the
    samples ``view[o]``, plus ``base`` (the shared features') and what ``add_extra(o, table)``
    adds."""
    # in place where the array is our own (a sum is the same either way round)
    if rest:
        cur = _band_rows(engine, view[o], piece, max_len, end, rest, n_rows)
        cur += base
    else:
        cur = np.array(base, dtype=np.float64)
    if add_extra is not None:
        add_extra(o, cur)
    return cur


def _pieces(band: Band, chunk: int) -> list[tuple[int, int, int]]:
    """The start sections ``i0:i1`` of :func:`scores_over_objects`' pieces, each spanning about
    ``chunk`` samples (at least one section), and the last end section ``e`` of their runs:
    the band over the boundaries ``i0..=e`` holds the runs of starts ``i0:i1`` as the whole band
    does, at its first rows."""
    out = []
    k, bounds = band.n_sections, band.bounds
    i0 = 0
    while i0 < k:
        i1 = max(i0 + 1, int(np.searchsorted(bounds, bounds[i0] + chunk, side="left")))
        i1 = min(i1, k)
        out.append((i0, i1, int(band.last[i1 - 1])))
        i0 = i1
    return out


def shared_features(values: list[np.ndarray], templates: Templates) -> list[int]:
    """The templates' features (indices into ``templates.features``) that do not depend on the
    target (fingertip distance, TCP rise, hand speed): equal in the feature matrices of all
    targets ``values``; these are scored once. ``[]`` without feature metadata."""
    groups = getattr(templates, "features", None)
    if groups is None:
        return []
    return [
        g
        for g, (_name, a, b) in enumerate(groups)
        if all(np.array_equal(values[0][:, a:b], v[:, a:b]) for v in values[1:])
    ]


def max_over_objects(
    scores_of: Callable[[int], np.ndarray], n_obj: int
) -> tuple[np.ndarray, np.ndarray]:
    """The maximum over the target objects of ``scores_of(o)`` and the first object reaching it
    (np.max / np.argmax over the objects; the scores are never NaN), one object's table at a
    time."""
    best = np.ascontiguousarray(scores_of(0))
    target = np.zeros(best.shape, dtype=np.min_scalar_type(n_obj - 1))
    better = np.empty(best.shape, dtype=bool) if n_obj > 1 else None
    for o in range(1, n_obj):
        cur = scores_of(o)
        np.greater(cur, best, out=better)
        np.copyto(best, cur, where=better)
        target[better] = o
        del cur
    return best, target


@dataclass
class _Draft:
    """A segment being built: ``skill`` on ``start..end`` with target object index ``obj``
    (its parameters are computed once, for all drafts together, by :func:`_make_segments`);
    ``source``: the finished segment it is, unchanged."""

    skill: str
    start: int
    end: int
    obj: int | None
    score: float = float("nan")
    confidence: float = float("nan")
    margin: float = float("nan")
    source: Segment | None = None

    @classmethod
    def of(cls, seg: Segment, names: list[str]) -> _Draft:
        """``seg`` as it is (its target object looked up by name in ``names``)."""
        obj = names.index(seg.object) if seg.object in names else None
        return cls(seg.skill, seg.start, seg.end, obj, seg.score, seg.confidence, seg.margin, seg)

    def resized(self, start: int, end: int) -> _Draft:
        """The same skill, target and scores on ``start..end`` (a new segment)."""
        return dataclasses.replace(self, start=start, end=end, source=None)

    def object_name(self, names: list[str]) -> str | None:
        """The target object's name."""
        if self.source is not None:
            return self.source.object
        return names[self.obj] if self.obj is not None else None


def _make_segments(traj: Trajectory, drafts: list[_Draft]) -> list[Segment]:
    """The segments of ``drafts`` (a draft of a finished segment is that segment), their times
    and skill parameters computed in one vectorised pass."""
    new = [d for d in drafts if d.source is None]
    made: list[Segment] = []
    if new:
        n = len(traj)
        t_ns = np.asarray(traj.t_ns)
        start = np.array([d.start for d in new], dtype=np.intp)
        end = np.minimum(np.array([d.end for d in new], dtype=np.intp), n - 1)
        # as Trajectory.t_s at these samples (an end past the last sample: the last sample)
        start_s = ((t_ns[start] - t_ns[0]).astype(np.float64) * 1e-9).tolist()
        end_s = ((t_ns[end] - t_ns[0]).astype(np.float64) * 1e-9).tolist()
        start_ns, end_ns = t_ns[start].tolist(), t_ns[end].tolist()
        params = skill_params_batch(
            traj,
            [d.skill for d in new],
            [d.start for d in new],
            [d.end for d in new],
            [d.obj for d in new],
        )
        made = [
            Segment(
                skill=d.skill,
                start=int(d.start),
                end=int(d.end),
                start_s=float(start_s[i]),
                end_s=float(end_s[i]),
                start_ns=int(start_ns[i]),
                end_ns=int(end_ns[i]),
                object=traj.object_names[d.obj] if d.obj is not None else None,
                score=float(d.score),
                confidence=float(d.confidence),
                margin=float(d.margin),
                params=params[i],
            )
            for i, d in enumerate(new)
        ]
    it = iter(made)
    return [d.source if d.source is not None else next(it) for d in drafts]


def _make_segment(
    traj: Trajectory,
    skill: str,
    start: int,
    end: int,
    target: np.ndarray | int | None,
    score: float = float("nan"),
    confidence: float = float("nan"),
    margin: float = float("nan"),
) -> Segment:
    """One segment (:func:`_make_segments`); ``target``: the object index, or per-sample
    object indices whose most common one on ``start..end`` is the target."""
    obj: int | None = None
    if isinstance(target, int):
        obj = target
    elif target is not None and end > start:
        obj = Counter(target[start:end].tolist()).most_common(1)[0][0]
    return _make_segments(traj, [_Draft(skill, start, end, obj, score, confidence, margin)])[0]


def as_trajectory(
    demo_or_traj: Demonstration | Trajectory, preprocessing: dict[str, Any] | None = None
) -> Trajectory:
    """Preprocess a demonstration (a trajectory passes through) with the keyword arguments
    ``preprocessing`` of :func:`lfd.preprocess` (default: those of the shipped templates)."""
    if isinstance(demo_or_traj, Trajectory):
        return demo_or_traj
    if isinstance(demo_or_traj, Demonstration):
        from ..preprocessing import preprocess

        if len(demo_or_traj.hand) == 0 or not np.isfinite(demo_or_traj.hand.keypoints).any():
            raise DemonstrationError("the demonstration has no hand data")
        if preprocessing is None:
            from .templates import preprocessing_options

            preprocessing = preprocessing_options()
        return preprocess(demo_or_traj, **preprocessing)
    raise TypeError(f"expected a Demonstration or Trajectory, got {type(demo_or_traj).__name__}")
