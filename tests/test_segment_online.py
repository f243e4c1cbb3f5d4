"""The online segmenter (lfd.segmentation.online, engine crates/hmmseg/src/segment/online.rs):
its final sequence equals the batch segmentation's on the same features, emitted segments are
never revised, segments settle within the lag, bad input is reported and survived."""

from __future__ import annotations

import itertools
import warnings
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from lfd.errors import InvalidParameterError, LfdWarning
from lfd.segmentation import Segmentation, Templates, segment
from lfd.segmentation.online import DEFAULT_LAG_S, OnlineSegmenter, segment_online
from lfd.segmentation.pipeline import SegmentParams, as_trajectory
from lfd.trajectory import Trajectory

STREAMED = SegmentParams(contacts=None)
"""The batch pipeline without the contact boundaries (lfd.contact), which need the thumb and the
object sizes that the stream does not carry: what the online segmenter computes."""

ROOT = Path(__file__).resolve().parents[1]
RECORDINGS = [ROOT / "recordings" / f"exp{k}.mcap" for k in (1, 2, 3, 4)]


@cache
def _traj(path: Path) -> Trajectory:
    from lfd.io import load

    return as_trajectory(load(path, images=False))


@cache
def _templates() -> Templates:
    return Templates.default()


@cache
def _sim_traj() -> Trajectory:
    from lfd.sim import simulate

    return as_trajectory(simulate("exp3", 301).demo)


def _key(result: Segmentation) -> list[tuple[str, int, int, str | None]]:
    return [(s.skill, s.start, s.end, s.object) for s in result.segments]


def _feed(traj: Trajectory, seg: OnlineSegmenter) -> list[list[tuple[str, int, int]]]:
    """Push every sample of a gap-free trajectory (its batch features); returns what each push
    emitted."""
    from lfd.features import compute_features

    feats = compute_features(traj)
    per = [compute_features(traj, target=o) for o in range(len(traj.object_names))]
    ov = np.stack([f.values for f in per], axis=1)
    ot = np.stack([f.thresholds for f in per], axis=1)
    pos = traj.object_position.transpose(1, 0, 2)
    emitted = []
    for t in range(len(traj)):
        up = seg.push(
            int(traj.t_ns[t]),
            feats.values[t],
            feats.thresholds[t],
            ov[t],
            ot[t],
            traj.tcp[t],
            pos[t],
        )
        emitted.append([(s.skill, s.start, s.end) for s in up.segments])
    return emitted


EXACT: dict[str, Any] = {"lag_s": 1e9, "beam": float("inf"), "stable_s": None}
"""Settle only what every hypothesis agrees on (no lag, no beam, no leader rule)."""


@pytest.mark.parametrize("path", RECORDINGS, ids=lambda p: p.stem)
def test_exact_online_sequence_equals_offline_on_the_recordings(path: Path) -> None:
    traj = _traj(path)
    offline = segment(traj, _templates(), params=STREAMED)
    online, settled_s = segment_online(traj, _templates(), **EXACT)
    assert _key(online) == _key(offline)
    for a, b in zip(online.segments, offline.segments, strict=True):
        assert (a.score, a.margin, a.confidence) == (b.score, b.margin, b.confidence)
        assert a.params == b.params
    # (every hypothesis of the last max_segment_s = 10 s is live: in these 15-19 s demos the
    # exact agreement settles everything at the end)
    assert len(settled_s) == len(online.segments)


@pytest.mark.parametrize("path", RECORDINGS, ids=lambda p: p.stem)
def test_default_online_segmentation_settles_fast_and_agrees(path: Path) -> None:
    traj = _traj(path)
    offline = segment(traj, _templates(), params=STREAMED)
    online, settled_s = segment_online(traj, _templates())
    assert online.skill_sequence == offline.skill_sequence
    n = len(traj)
    agree = np.mean(_frames(online, n) == _frames(offline, n))
    assert agree >= 0.95
    # each segment settles after its end, at worst the lag plus the time a boundary takes to
    # become final and its objects' motion to be known (the median over held-out demos is
    # measured by benches/segment_online.py)
    ends = np.array([s.end_s for s in online.segments])
    assert np.all(settled_s >= ends - 1e-9)
    assert np.median(settled_s - ends) <= 2.0
    assert np.max(settled_s - ends) <= DEFAULT_LAG_S * 7 / 6 + 0.1


def _frames(result: Segmentation, n: int) -> np.ndarray:
    out = np.full(n, "", dtype=object)
    for s in result.segments:
        out[s.start : s.end] = s.skill
    return out


def test_online_sequence_equals_offline_on_a_simulated_demo() -> None:
    traj = _sim_traj()
    offline = segment(traj, _templates(), params=STREAMED)
    online, _ = segment_online(traj, _templates(), **EXACT)
    assert _key(online) == _key(offline)
    online, _ = segment_online(traj, _templates())
    assert online.skill_sequence == offline.skill_sequence


def test_emitted_segments_are_never_revised_and_settle_within_the_lag() -> None:
    traj = _traj(RECORDINGS[2])
    lag_s = 1.0
    seg = OnlineSegmenter(_templates(), traj.object_names, traj.dt, lag_s=lag_s)
    emitted = _feed(traj, seg)
    seg.finish()
    final = [(s.skill, s.start, s.end) for s in seg.segments]
    flat = [x for e in emitted for x in e]
    # what was emitted while streaming is the final sequence's prefix, unchanged
    assert final[: len(flat)] == flat
    assert len(flat) >= len(final) - 2  # all but the last one or two settle before the end
    # the segments tile the demonstration
    assert final[0][1] == 0 and final[-1][2] == len(traj)
    assert all(a[2] == b[1] for a, b in itertools.pairwise(final))
    # a short lag settles each segment at most lag + its longest possible length after its end
    late = [
        (n - s.end) * traj.dt
        for s, n in zip(seg.segments, seg.settle_samples, strict=True)
        if n < len(traj)
    ]
    assert max(late) <= lag_s + seg.params.max_segment_s
    assert np.median(late) <= lag_s + 0.5
    # the provisional skill is a skill name
    assert seg.provisional is None or seg.provisional.skill in seg.skills


def test_bad_input_is_reported_and_survived() -> None:
    from lfd.features import compute_features

    traj = _traj(RECORDINGS[0])
    feats = compute_features(traj)
    per = [compute_features(traj, target=o) for o in range(len(traj.object_names))]
    ov = np.stack([f.values for f in per], axis=1)
    ot = np.stack([f.thresholds for f in per], axis=1)
    pos = traj.object_position.transpose(1, 0, 2)
    seg = OnlineSegmenter(_templates(), traj.object_names, traj.dt)
    n = len(traj)
    got: list[tuple[str, int, int]] = []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for t in range(n):
            if n // 3 <= t < n // 3 + 10:
                continue  # a gap of 10 samples
            values = feats.values[t].copy()
            if n // 2 <= t < n // 2 + 5:
                values[:] = np.nan  # the hand lost for 5 samples
            up = seg.push(
                int(traj.t_ns[t]), values, feats.thresholds[t], ov[t], ot[t], traj.tcp[t], pos[t]
            )
            got += [(s.skill, s.start, s.end) for s in up.segments]
            if t == n // 4:  # a sample out of order
                before = len(seg.segments)
                up = seg.push(
                    int(traj.t_ns[t - 3]),
                    feats.values[t],
                    feats.thresholds[t],
                    ov[t],
                    ot[t],
                    traj.tcp[t],
                    pos[t],
                )
                assert up.segments == [] and len(seg.segments) == before
        seg.finish()
    text = [str(w.message) for w in caught if issubclass(w.category, LfdWarning)]
    assert any("not after the previous one" in w for w in text)
    assert any("gap of" in w for w in text)
    assert any("not finite" in w for w in text)
    assert seg.warnings == text[: len(seg.warnings)] or set(text) <= set(seg.warnings)
    final = seg.segments
    # the gap was bridged (one sample per period), nothing emitted was lost, and the result is
    # still the offline sequence of skills
    assert final[-1].end == n
    assert [(s.skill, s.start, s.end) for s in final][: len(got)] == got
    assert [s.skill for s in final] == [
        s.skill for s in segment(traj, _templates(), params=STREAMED).segments
    ]
    with pytest.raises(InvalidParameterError):
        seg.finish()


def test_bad_options_are_errors() -> None:
    traj = _traj(RECORDINGS[0])
    with pytest.raises(InvalidParameterError):
        OnlineSegmenter(_templates(), traj.object_names, traj.dt, search="greedy")
    with pytest.raises(InvalidParameterError):
        OnlineSegmenter(_templates(), traj.object_names, 0.0)
    with pytest.raises(InvalidParameterError):
        OnlineSegmenter(_templates(), [], traj.dt)
    seg = OnlineSegmenter(_templates(), traj.object_names, traj.dt)
    with pytest.raises(InvalidParameterError):
        seg.finish()  # nothing pushed


def test_engine_rejects_bad_rows() -> None:
    from lfd import _hmmseg
    from lfd.errors import ShapeMismatchError
    from lfd.segmentation.grammar import grammar_json

    t = _templates()
    with pytest.raises(ShapeMismatchError):  # one "shared" flag per feature
        _hmmseg.OnlineSegmenter(t.engine, grammar_json(), [False], 1, 10, [0], [0.0], 1, 30)
    seg = OnlineSegmenter(t, ["a"], 1 / 30)
    with pytest.raises(ShapeMismatchError):
        seg._engine.push_sample(np.zeros(3), np.zeros(3), np.zeros((1, 10)), 0.0)
    with pytest.raises(ShapeMismatchError):
        seg._engine.add_section(5, 0, np.zeros((2, len(t.skills))), np.zeros(2, dtype=bool), 5)
