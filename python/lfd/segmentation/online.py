"""Online segmentation: skills settled while the demonstration is being recorded.

:class:`OnlineSegmenter` is fed one preprocessed sample at a time (its features, as
:func:`lfd.features.compute_features` gives them for the hand and for each object as the target,
and the poses the skill parameters need) and returns the skill segments as they *settle*. The
engine (``lfd._hmmseg.OnlineSegmenter``, ``crates/hmmseg/src/segment/online.rs``) keeps stage 1,
the forward states of the template HMMs per start section and the segmental DP incrementally,
with the batch code's arithmetic; this driver adds the evidence the batch pipeline adds between
the score table and the search, with the same functions:

- the co-motion penalty (:func:`~lfd.segmentation.pipeline.co_motion_per_object` on the runs
  ending at each new section; an object's motion at a sample needs the positions
  ``co_motion_window_s`` later, so a section is scored that much after its boundary);
- the maximum over target objects (:func:`~lfd.segmentation.pipeline.max_over_objects`);
- the implicit Moves (:func:`~lfd.segmentation.pipeline.insert_implicit_moves`): a settled Place
  or Stack is held back while the best current path continues with a skill that needs the Move
  (the Move between them takes samples from both), at most ``lag_s``; once emitted, a Move the
  next segment needs is taken from the next segment alone. A settled Locate is held back the
  same way, at most ``3/4 lag_s``, for the skill after it: on another object, a Move goes
  between them; past the wait, without that skill settled, the Move is added when the hand is
  nearest another object ``MOVE_OBJECT_S`` after the Locate (taken from the Locate's end);
- the objects of the Moves (:func:`~lfd.segmentation.pipeline.label_moves`): a settled Move
  waits for the sample ``MOVE_OBJECT_S`` after its end.

**Settling.** A segment is emitted once every DP hypothesis a future segment can still extend
traces back through it (then the batch optimum contains it too); when every hypothesis within
``beam`` nats of the best agrees on it (a hypothesis: a DP state and a segment still going on,
scored over the same samples); when it has led for ``stable_s`` and no close hypothesis has a
segment going on across its end; or, at the latest, once it is the best complete path's oldest
unsettled segment (the batch DP's choice on the samples so far) and ended more than ``lag_s``
ago (the best hypothesis's: ``7/6 lag_s``), *forced*. Each of the last three drops the
hypotheses disagreeing with it (docs/segmentation.md, "Online"). Emitted segments never change.
After :meth:`OnlineSegmenter.finish`, without forced segments, the sequence equals
:func:`lfd.segment`'s on the same features (``tests/test_segment_online.py``).

**Bad input** (each a :class:`~lfd.errors.LfdWarning`, the segmenter keeps going): a sample not
later than the previous one is dropped; a gap in time is bridged by repeating the last sample
(up to ``max_gap_s``; a longer gap is only reported); a NaN feature row or pose holds the last
finite value (causal, where the batch pipeline interpolates over the gap).
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any, get_args

import numpy as np

from .. import _hmmseg
from ..errors import InvalidParameterError, LfdWarning
from ..trajectory import Trajectory
from .band import Band
from .gaps import fill_gaps
from .grammar import (
    RELEASES,
    grammar_json,
    implicit_move_grammar_json,
    needs_implicit_move,
    needs_move_between,
)
from .pipeline import (
    MOVE_OBJECT_S,
    GrammarUse,
    Search,
    SegmentParams,
    _make_segment,
    _resized,
    co_motion_per_object,
    displaced,
    insert_implicit_moves,
    max_over_objects,
    motion_window,
    object_after,
)
from .result import Segment, Segmentation
from .stage1 import OBJECT_COLUMNS, criteria, min_section
from .templates import Templates

TARGET_INDEPENDENT: frozenset[str] = frozenset(
    {"fingertip_distance", "tcp_rise_fall", "hand_velocity"}
)
"""Features that do not depend on the target object (scored once per sample)."""

DEFAULT_BEAM = 160.0
"""Default beam (nats): a segment settles when every hypothesis within this of the best
agrees on it (``inf``: every hypothesis, exact; ``nan``: off, only the lag settles). Chosen with
the other settling defaults on the evaluation demos (seeds 100-105, ``benches/segment_live.py
--seeds 100-105``): 160 and 240 settled 75/78 sequences as the batch DP, 80 74/78, 40 71/78."""

DEFAULT_STABLE_S: float | None = 0.3
"""Default time (s) the best hypothesis's oldest unsettled segment must lead to settle
(chosen on the evaluation demos, seeds 100-105: 0.3 s settled 75/78 sequences as the batch
DP with a median latency of 1.33 s, 0.5 s 74/78 with 1.50 s)."""

DEFAULT_LAG_S = 2.0
"""Default bound (seconds after its end) by which the best complete path's oldest segment is
forced (2.5 s settled the same sequences on the evaluation demos, up to 3.6 s late)."""


HELD: frozenset[str] = frozenset({*RELEASES, "locate"})
"""Settled skills held back until the next skill settles (at most ``lag_s``; a Locate ``3/4
lag_s``): it may need a Move between them (:func:`~lfd.segmentation.grammar.needs_move_between`)."""


@dataclass(frozen=True)
class Provisional:
    """The skill the best current hypothesis ends with (not settled; may still change)."""

    skill: str
    start: int
    start_s: float


@dataclass(frozen=True)
class OnlineUpdate:
    """What one :meth:`OnlineSegmenter.push` produced."""

    segments: list[Segment]
    """Newly settled segments, in time order (never revised)."""
    provisional: Provisional | None
    """The current provisional skill."""


class _Grow:
    """A growing array (amortised O(1) append), viewed as ``[:n]``."""

    def __init__(self, shape: tuple[int, ...], dtype: Any = np.float64):
        self.a = np.zeros((64, *shape), dtype=dtype)
        self.n = 0

    def append(self, row: Any) -> None:
        if self.n == len(self.a):
            self.a = np.concatenate([self.a, np.zeros_like(self.a)])
        self.a[self.n] = row
        self.n += 1

    def view(self) -> np.ndarray:
        return self.a[: self.n]


@dataclass
class _Section:
    """A final boundary's rows, waiting for the object motion of its samples."""

    bound: int
    first_start: int
    scores: np.ndarray  # (R, O, S)
    rising: np.ndarray  # (R,)


@dataclass
class _Hold:
    """The last valid sample, repeated over NaN rows and gaps."""

    values: dict[str, np.ndarray] = field(default_factory=dict)
    nan_since: dict[str, int] = field(default_factory=dict)


class OnlineSegmenter:
    """Segment a demonstration while it is recorded (see the module docs).

    Parameters
    ----------
    templates : Templates
        Skill templates (as offline).
    object_names : sequence of str
        The objects, in the order of the per-object rows.
    dt : float
        Sample period (s) of the preprocessed stream.
    params : SegmentParams, optional
        As offline (stage 1, ``max_segment_s``, ``penalty``, co-motion, rise, implicit moves).
    search, grammar :
        As offline; only the DP search runs online.
    lag_s : float
        Bound on settling (see the module docs).
    beam : float
        Hypotheses within this many nats of the best must agree for a segment to settle before
        the lag (``inf``: all of them, exact; ``nan``: only the lag settles).
    stable_s : float or None
        The best hypothesis's oldest unsettled segment also settles once it has led this long
        (None: off).
    check_every : int
        Samples between two agreement checks.
    max_gap_s : float
        Longest gap in time bridged by repeating the last sample.
    t0_ns : int, optional
        Time of sample 0 (default: the first sample pushed).
    """

    def __init__(
        self,
        templates: Templates,
        object_names: Sequence[str],
        dt: float,
        *,
        params: SegmentParams | None = None,
        search: Search = "dp",
        grammar: GrammarUse = "enforce",
        lag_s: float = DEFAULT_LAG_S,
        beam: float = DEFAULT_BEAM,
        stable_s: float | None = DEFAULT_STABLE_S,
        check_every: int = 1,
        max_gap_s: float = 2.0,
    ):
        p = params or SegmentParams()
        if search != "dp":
            raise InvalidParameterError(
                f"the online segmenter runs the 'dp' search, got {search!r}"
            )
        if grammar not in get_args(_hmmseg.GrammarMode):
            raise InvalidParameterError(
                f"grammar must be 'off', 'warn' or 'enforce', got {grammar!r}"
            )
        if not dt > 0 or not np.isfinite(dt):
            raise InvalidParameterError(f"dt must be positive, got {dt}")
        if not object_names:
            raise InvalidParameterError("the online segmenter needs at least one object")
        if not lag_s >= 0:
            raise InvalidParameterError(f"lag_s must be >= 0, got {lag_s}")
        self.templates = templates
        self.params = p
        self.dt = float(dt)
        self.object_names = list(object_names)
        self.skills = templates.skills
        n_obj = len(self.object_names)
        self.max_len = max(1, round(p.max_segment_s / dt))
        self._lag = round(lag_s / dt)
        self._move_k = round(MOVE_OBJECT_S / dt)
        self._implicit_k = max(1, round(p.implicit_move_s / dt))  # an inserted Move's samples
        self._max_gap = max(0, round(max_gap_s / dt))
        self._w = motion_window(dt, p.co_motion_window_s)
        cols, hyst = criteria(p.stage1, n_obj, len(_hmmseg.FEATURE_NAMES))
        self._object_criteria = p.stage1.object_criteria
        self._n_stage1 = len(_hmmseg.FEATURE_NAMES) + (
            len(OBJECT_COLUMNS) * n_obj if self._object_criteria else 0
        )
        rules = implicit_move_grammar_json() if p.implicit_moves else grammar_json()
        self._engine = _hmmseg.OnlineSegmenter(
            templates.engine,
            rules,
            [name in TARGET_INDEPENDENT for name, _, _ in templates.features],
            n_obj,
            self._n_stage1,
            cols,
            hyst,
            min_section(p.stage1, dt),
            self.max_len,
            p.end,
            grammar,
            p.penalty,
            p.min_rise,
            p.dominance,
            self._lag,
            beam,
            None if stable_s is None else round(stable_s / dt),
        )
        self._beam_on = not np.isnan(beam)
        self._check_every = max(1, int(check_every))
        # histories (samples), for the co-motion evidence, implicit moves and skill parameters
        self._t_ns = _Grow((), np.int64)
        self._tcp = _Grow((3,))
        self._rot = _Grow((3, 3))
        self._pos = _Grow((n_obj, 3))
        self._quat = _Grow((n_obj, 4))
        self._lifted = _Grow((n_obj,), bool)
        self._moving = _Grow((n_obj,), bool)
        self._hand = _Grow((), bool)  # the TCP moves (known as far as _moving)
        self._queue: list[_Section] = []
        self._targets: dict[int, tuple[int, np.ndarray]] = {}  # boundary -> (first start, target)
        self._bounds: list[int] = [0]
        self._held: Segment | None = None
        self._waiting: list[Segment] = []  # settled, waiting for a Move's object (label_moves)
        self._emitted: list[Segment] = []
        self.settle_samples: list[int] = []
        """Samples seen when each emitted segment was settled (same order as the segments)."""
        self.forced = 0
        """Segments settled by the lag bound."""
        self.warnings: list[str] = []
        self._hold = _Hold()
        self._last: tuple[np.ndarray, ...] = ()
        self._finished = False
        self._band_cache: dict[tuple[int, ...], Band] = {}

    # -- input ----------------------------------------------------------------------------------

    def boundaries(self, since: int = 0) -> list[int]:
        """Stage-1 section boundaries (sample indices) found so far, from the ``since``-th on
        (boundary 0 is the first sample)."""
        return self._bounds[since:]

    @property
    def n_samples(self) -> int:
        """Samples consumed (including repeated ones bridging gaps)."""
        return self._t_ns.n

    def _warn(self, message: str) -> None:
        self.warnings.append(message)
        warnings.warn(message, LfdWarning, stacklevel=3)

    def _held_row(self, key: str, row: np.ndarray, t: int) -> np.ndarray:
        """``row`` with its non-finite entries replaced by the last finite ones (a warning when a
        run of them starts); zeros before any finite value."""
        ok = np.isfinite(row)
        last = self._hold.values.get(key)
        if ok.all():
            if key in self._hold.nan_since:
                del self._hold.nan_since[key]
            self._hold.values[key] = row
            return row
        if key not in self._hold.nan_since:
            self._hold.nan_since[key] = t
            self._warn(f"sample {t}: {key} not finite; holding the last finite value")
        out = np.where(ok, row, last if last is not None else 0.0)
        self._hold.values[key] = out
        return out

    def push(
        self,
        t_ns: int,
        values: np.ndarray,
        thresholds: np.ndarray,
        object_values: np.ndarray,
        object_thresholds: np.ndarray,
        tcp: np.ndarray,
        object_position: np.ndarray,
        *,
        rotation: np.ndarray | None = None,
        object_quaternion: np.ndarray | None = None,
    ) -> OnlineUpdate:
        """Feed one preprocessed sample.

        Parameters
        ----------
        t_ns : int
            Its time (ns).
        values, thresholds : array (10,)
            The hand's feature row and Table I thresholds (``compute_features(traj)``).
        object_values, object_thresholds : array (O, 10)
            The feature rows with each object as the target (``compute_features(traj,
            target=o)``).
        tcp : array (3,)
            The TCP position (m); ``tcp[2]`` drives the rise decision.
        object_position : array (O, 3)
            Object positions (m; co-motion evidence, skill parameters).
        rotation, object_quaternion : array (3, 3), (O, 4), optional
            For the skill parameters (grasp orientation, place pose).
        """
        if self._finished:
            raise InvalidParameterError("the online segmenter has finished")
        t_ns = int(t_ns)
        n_obj = len(self.object_names)
        out: list[Segment] = []
        if self._t_ns.n:
            last = int(self._t_ns.view()[-1])
            if t_ns <= last:
                self._warn(
                    f"sample at {t_ns} ns is not after the previous one ({last} ns); dropped"
                )
                return OnlineUpdate([], self.provisional)
            missing = round((t_ns - last) / (self.dt * 1e9)) - 1
            if missing > 0:
                gap = missing * self.dt
                if missing <= self._max_gap:
                    self._warn(f"gap of {gap:.2f} s before {t_ns} ns; last sample repeated")
                    for k in range(missing):
                        out += self._step(last + round((k + 1) * self.dt * 1e9), *self._last)
                else:
                    self._warn(f"gap of {gap:.2f} s before {t_ns} ns; not bridged")
        t = self._t_ns.n
        rows = (
            self._held_row("hand features", np.asarray(values, dtype=np.float64).reshape(-1), t),
            self._held_row(
                "hand thresholds", np.asarray(thresholds, dtype=np.float64).reshape(-1), t
            ),
            self._held_row(
                "object features", np.asarray(object_values, dtype=np.float64).reshape(n_obj, -1), t
            ),
            self._held_row(
                "object thresholds",
                np.asarray(object_thresholds, dtype=np.float64).reshape(n_obj, -1),
                t,
            ),
            self._held_row("tcp", np.asarray(tcp, dtype=np.float64).reshape(3), t),
            self._held_row(
                "object positions",
                np.asarray(object_position, dtype=np.float64).reshape(n_obj, 3),
                t,
            ),
            np.full((3, 3), np.nan) if rotation is None else np.asarray(rotation, dtype=np.float64),
            np.full((n_obj, 4), np.nan)
            if object_quaternion is None
            else np.asarray(object_quaternion, dtype=np.float64),
        )
        self._last = rows
        out += self._step(t_ns, *rows)
        return OnlineUpdate(out, self.provisional)

    def _step(
        self,
        t_ns: int,
        values: np.ndarray,
        thresholds: np.ndarray,
        ov: np.ndarray,
        ot: np.ndarray,
        tcp: np.ndarray,
        pos: np.ndarray,
        rot: np.ndarray,
        quat: np.ndarray,
    ) -> list[Segment]:
        height = OBJECT_COLUMNS["object_height"]
        self._t_ns.append(t_ns)
        self._tcp.append(tcp)
        self._rot.append(rot)
        self._pos.append(pos)
        self._quat.append(quat)
        self._lifted.append(ov[:, height] > ot[:, height])
        n = self._t_ns.n
        # moving at sample n - 1 - w is known now (moving_objects, clipped at the start)
        t = n - 1 - self._w
        if t >= 0:
            p, c, d = self._pos.view(), self._tcp.view(), self.params.co_motion_displacement
            self._moving.append(displaced(p[max(t - self._w, 0)], p[n - 1], d))
            self._hand.append(displaced(c[max(t - self._w, 0)], c[n - 1], d))
        if self._object_criteria:
            cols = list(OBJECT_COLUMNS.values())
            s1v = np.concatenate([values, ov[:, cols].reshape(-1)])
            s1t = np.concatenate([thresholds, ot[:, cols].reshape(-1)])
        else:
            s1v, s1t = values, thresholds
        rows = self._engine.push_sample(
            np.ascontiguousarray(s1v),
            np.ascontiguousarray(s1t),
            np.ascontiguousarray(ov),
            float(tcp[2]),
        )
        if rows is not None:
            _, bound, first, scores, rising = rows
            self._queue.append(_Section(bound, first, scores, rising))
        out = self._drain(final=False)
        if self._beam_on and n % self._check_every == 0:
            out += self._converge()
        out += self._settled(self._engine.tick(n))
        out += self._flush_held(final=False)
        out += self._flush_waiting()
        return out

    # -- sections -> DP -------------------------------------------------------------------------

    def _drain(self, *, final: bool) -> list[Segment]:
        """Score the queued sections whose samples' object motion is known."""
        out: list[Segment] = []
        while self._queue and (final or self._moving.n >= self._queue[0].bound):
            sec = self._queue.pop(0)
            out += self._add(sec)
        return out

    def _add(self, sec: _Section) -> list[Segment]:
        p = self.params
        j = len(self._bounds)
        local = np.asarray([*self._bounds[sec.first_start :], sec.bound], dtype=np.int64)
        lo = int(local[0])
        local = local - lo
        n_obj, ns = sec.scores.shape[1], sec.scores.shape[2]
        extra = None
        if p.co_motion != 0:
            moving = self._moving.view()[lo : sec.bound].T
            lifted = self._lifted.view()[lo : sec.bound].T
            band = self._band(local)
            rows = np.flatnonzero(band.end == len(local) - 1)
            sub = dataclasses.replace(band, start=band.start[rows], end=band.end[rows])
            extra = co_motion_per_object(
                np.ascontiguousarray(moving),
                local,
                self.skills,
                p.co_motion,
                lifted=np.ascontiguousarray(lifted),
                grace=round(p.co_motion_grace_s / self.dt),
                slide=p.co_motion_slide_s / self.dt,
                hand=self._hand.view()[lo : sec.bound],
                left=p.co_motion_left_s / self.dt,
                band=sub,
            )

        def scores_of(o: int) -> np.ndarray:
            cur = sec.scores[:, o, :]
            return cur + extra(o) if extra is not None else np.array(cur, dtype=np.float64)

        best, target = max_over_objects(scores_of, n_obj)
        self._targets[j] = (sec.first_start, target)
        self._bounds.append(sec.bound)
        settled = self._engine.add_section(
            sec.bound,
            sec.first_start,
            np.ascontiguousarray(best.reshape(-1, ns)),
            np.ascontiguousarray(sec.rising),
            self._t_ns.n,
        )
        return self._settled(settled)

    def _converge(self) -> list[Segment]:
        """Settle what the hypotheses within the beam agree on: the DP states followed by a
        segment still going on, with the co-motion evidence of its samples whose object motion
        is known, on its best object."""
        p = self.params
        secs, scores = self._engine.running()
        if len(secs) == 0:
            return []
        e = self._moving.n
        starts = np.asarray([self._bounds[i] for i in secs], dtype=np.int64)
        k = int(np.searchsorted(starts, e))  # runs with samples of known motion
        extra = None
        if p.co_motion != 0 and k > 0:
            lo = int(starts[0])
            local = np.append(starts[:k], e) - lo
            band = Band(local, 0, np.full(k, k), np.arange(k + 1), np.arange(k), np.full(k, k))
            of = co_motion_per_object(
                np.ascontiguousarray(self._moving.view()[lo:e].T),
                local,
                self.skills,
                p.co_motion,
                lifted=np.ascontiguousarray(self._lifted.view()[lo:e].T),
                grace=round(p.co_motion_grace_s / self.dt),
                slide=p.co_motion_slide_s / self.dt,
                hand=self._hand.view()[lo:e],
                left=p.co_motion_left_s / self.dt,
                band=band,
            )
            if of is not None:
                pad = np.zeros((len(secs) - k, len(self.skills)))
                extra = lambda o: np.concatenate([of(o), pad])  # noqa: E731

        def scores_of(o: int) -> np.ndarray:
            cur = scores[:, o, :]
            return cur + extra(o) if extra is not None else np.array(cur, dtype=np.float64)

        best, _ = max_over_objects(scores_of, scores.shape[1])
        return self._settled(self._engine.converge(secs, np.ascontiguousarray(best)))

    def _band(self, local: np.ndarray) -> Band:
        key = tuple(int(b) for b in local)
        band = self._band_cache.get(key)
        if band is None:
            band = Band.of(local, self.max_len)
            self._band_cache = {key: band}
        return band

    # -- settled segments -----------------------------------------------------------------------

    def _history(self) -> Trajectory:
        n, n_obj = self._t_ns.n, len(self.object_names)
        return Trajectory(
            t_ns=self._t_ns.view(),
            tcp=self._tcp.view(),
            rotation=self._rot.view(),
            euler=np.zeros((n, 3)),
            opening=np.zeros(n),
            keypoints=np.zeros((n, 0, 3)),
            object_names=self.object_names,
            object_position=self._pos.view().transpose(1, 0, 2),
            object_quaternion=self._quat.view().transpose(1, 0, 2),
            object_size=np.zeros((n_obj, 3)),
            hand_valid=np.ones(n, dtype=bool),
            object_valid=np.ones((n_obj, n), dtype=bool),
        )

    def _settled(self, raw: list[tuple[Any, ...]]) -> list[Segment]:
        if not raw:
            return []
        hist = self._history()
        out: list[Segment] = []
        for s, i, j, a, b, score, margin, conf, forced in raw:
            first, target = self._targets[j]
            obj = int(target[i - first, s])
            self.forced += int(forced)
            seg = _make_segment(hist, self.skills[s], a, b, obj, score, conf, margin)
            out += self._release(hist, seg)
        for k in [k for k in self._targets if k < raw[-1][2]]:
            del self._targets[k]
        return out

    def _release(self, hist: Trajectory, seg: Segment) -> list[Segment]:
        """Pass a settled segment through the implicit-Move rule, holding back a release."""
        if not self.params.implicit_moves:
            return self._emit([seg])
        length = self._implicit_k
        out: list[Segment] = []
        held = self._held
        last = self._last_passed()
        if held is not None:
            self._held = None
            out = insert_implicit_moves(hist, [held, seg], length)
        elif last is not None and last.skill == "move" and last.end > seg.start:
            # the Move that starts seg was emitted with the release (_flush_held)
            out = [_resized(hist, seg, last.end, seg.end)] if seg.end > last.end else []
        elif last is not None and (
            needs_implicit_move(last.skill, seg.skill)
            or (
                needs_move_between(last.skill, last.object, seg.skill, seg.object)
                and self._t_ns.n - (seg.start + length) <= self._lag
            )
        ):
            # the release or Locate was emitted already: the Move starts seg (after a Locate,
            # unless it would settle later than the lag)
            b = min(seg.start + length, seg.end - 1)
            obj = self.object_names.index(seg.object) if seg.object in self.object_names else None
            mv = _make_segment(hist, "move", seg.start, b, obj)
            out = [mv, _resized(hist, seg, b, seg.end)] if b > seg.start else [seg]
        else:
            out = [seg]
        if out and out[-1].skill in HELD:
            self._held = out.pop()
        return self._emit(out)

    def _last_passed(self) -> Segment | None:
        """The last segment settled and passed on (emitted or waiting)."""
        if self._waiting:
            return self._waiting[-1]
        return self._emitted[-1] if self._emitted else None

    def _flush_waiting(self) -> list[Segment]:
        """Emit the waiting segments whose Moves' object samples have arrived."""
        segs, self._waiting = self._waiting, []
        return self._emit(segs) if segs else []

    def _flush_held(self, *, final: bool) -> list[Segment]:
        held = self._held
        if held is None:
            return []
        nxt = self._engine.best_path()
        after = self.skills[nxt[0][0]] if nxt and nxt[0][1] >= held.end else None
        wait = self._lag if held.skill in RELEASES else self._lag * 3 // 4
        if not final and self._t_ns.n - held.end <= wait:
            # emit it unless the best current path continues with a skill that may need the Move
            if after is None or (
                after != "move"
                and (held.skill == "locate" or needs_implicit_move(held.skill, after))
            ):
                return []
        self._held = None
        out = [held]
        if (
            not final
            and after is not None
            and needs_implicit_move(held.skill, after)
            and held.end + self._implicit_k < self._t_ns.n
        ):
            # past the wait, the next skill unsettled: the Move it will start with (as _release
            # inserts it after an emitted release) is known already
            hist = self._history()
            out.append(_make_segment(hist, "move", held.end, held.end + self._implicit_k, None))
        elif held.skill == "locate" and not final and after not in (None, "move"):
            # past the lag, the next skill unsettled: a Move if the hand has gone to another
            # object (label_moves' rule), taken from the Locate's end
            obj = object_after(self._tcp.view(), self._pos.view(), held.end, self._move_k)
            a = max(held.start + 1, held.end - self._implicit_k)
            if obj is not None and self.object_names[obj] != held.object and a < held.end:
                hist = self._history()
                out = [
                    _resized(hist, held, held.start, a),
                    _make_segment(hist, "move", a, held.end, obj),
                ]
        return self._emit(out)

    def _emit(self, segs: list[Segment]) -> list[Segment]:
        """Emit settled segments in order. A Move gets its object
        (:func:`~lfd.segmentation.pipeline.label_moves`) once the sample ``MOVE_OBJECT_S``
        after its end has arrived; until then it and what follows it wait."""
        segs = self._waiting + [s for s in segs if s.end > s.start]
        self._waiting = []
        n = self._t_ns.n
        for k, seg in enumerate(segs):
            if seg.skill != "move":
                continue
            e = seg.end + self._move_k
            if e > n - 1 and seg.end < n and not self._finished:
                segs, self._waiting = segs[:k], segs[k:]
                break
            obj = None
            if seg.end < n:  # not the demonstration's last segment
                obj = object_after(self._tcp.view(), self._pos.view(), seg.end, self._move_k)
            name = self.object_names[obj] if obj is not None else None
            segs[k] = dataclasses.replace(seg, object=name)
        if not segs:
            return []
        self._emitted += segs
        self.settle_samples += [self._t_ns.n] * len(segs)
        return segs

    # -- queries and the end --------------------------------------------------------------------

    @property
    def provisional(self) -> Provisional | None:
        """The skill the best current hypothesis ends with."""
        p = self._engine.provisional()
        if p is None:
            return None
        s, a, _ = p
        return Provisional(self.skills[s], int(a), a * self.dt)

    @property
    def segments(self) -> list[Segment]:
        """Every segment emitted so far."""
        return list(self._emitted)

    def finish(self) -> list[Segment]:
        """End of the stream: settle everything; returns the segments settled now."""
        if self._finished:
            raise InvalidParameterError("the online segmenter has finished")
        if self._t_ns.n == 0:
            raise InvalidParameterError("no sample was pushed")
        self._finished = True
        n = self._t_ns.n
        # the tail of the object motion, clipped at the end as moving_objects does
        p, c, d = self._pos.view(), self._tcp.view(), self.params.co_motion_displacement
        for t in range(self._moving.n, n):
            a, b = max(t - self._w, 0), min(t + self._w, n - 1)
            self._moving.append(displaced(p[a], p[b], d))
            self._hand.append(displaced(c[a], c[b], d))
        _, bound, first, scores, rising = self._engine.finish_samples()
        self._queue.append(_Section(bound, first, scores, rising))
        out = self._drain(final=True)
        out += self._settled(self._engine.finish())
        out += self._flush_held(final=True)
        out += self._flush_waiting()
        for w in self._engine.warnings:
            if w not in self.warnings:
                self.warnings.append(w)
        return out

    def result(self) -> Segmentation:
        """The segmentation so far (after :meth:`finish`: the whole demonstration)."""
        return Segmentation(
            segments=list(self._emitted),
            warnings=list(self.warnings),
            method="online",
            sections=list(self._bounds),
            object_names=list(self.object_names),
        )


def batch_samples(filled: Trajectory) -> Iterator[dict[str, Any]]:
    """The keyword arguments of :meth:`OnlineSegmenter.push` for every sample of a gap-free
    trajectory, with the batch pipeline's features (for comparing online with offline)."""
    from ..features import compute_features

    feats = compute_features(filled)
    per_object = [compute_features(filled, target=o) for o in range(len(filled.object_names))]
    ov = np.stack([f.values for f in per_object], axis=1)
    ot = np.stack([f.thresholds for f in per_object], axis=1)
    pos = filled.object_position.transpose(1, 0, 2)
    quat = filled.object_quaternion.transpose(1, 0, 2)
    for t in range(len(filled)):
        yield {
            "t_ns": int(filled.t_ns[t]),
            "values": feats.values[t],
            "thresholds": feats.thresholds[t],
            "object_values": ov[t],
            "object_thresholds": ot[t],
            "tcp": filled.tcp[t],
            "object_position": pos[t],
            "rotation": filled.rotation[t],
            "object_quaternion": quat[t],
        }


def segment_online(
    traj: Trajectory,
    templates: Templates,
    *,
    params: SegmentParams | None = None,
    search: Search = "dp",
    grammar: GrammarUse = "enforce",
    lag_s: float = DEFAULT_LAG_S,
    beam: float = DEFAULT_BEAM,
    stable_s: float | None = DEFAULT_STABLE_S,
) -> tuple[Segmentation, np.ndarray]:
    """Feed a whole preprocessed trajectory to an :class:`OnlineSegmenter` sample by sample,
    with the batch pipeline's features (gaps filled as offline, for comparison); returns the
    segmentation and, per segment, the time (s, from the first sample) it was settled at."""
    filled, warns = fill_gaps(traj)
    seg = OnlineSegmenter(
        templates,
        filled.object_names,
        filled.dt,
        params=params,
        search=search,
        grammar=grammar,
        lag_s=lag_s,
        beam=beam,
        stable_s=stable_s,
    )
    for sample in batch_samples(filled):
        seg.push(**sample)
    seg.finish()
    result = seg.result()
    result.warnings[:0] = warns
    return result, np.asarray(seg.settle_samples, dtype=np.float64) * filled.dt
