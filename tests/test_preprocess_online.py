"""Online (causal) preprocessing and features against the offline path.

Three kinds of checks:

- exactness: the online feature rows equal ``compute_features`` of the trajectory the online
  preprocessor emitted (same targets), except the ``object_height`` threshold before an
  object first moves;
- closeness: on the shipped recordings and a simulated natural demonstration, the online
  features track the offline ones once the causal filter's lag is accounted for, and stage 1
  cuts the online features within a few samples of the offline cuts;
- robustness: out-of-order messages, NaN and low-confidence keypoints, long gaps, a stalled
  stream.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import lfd
import numpy as np
import pytest
from lfd.demo import HandTrack
from lfd.features import compute_features
from lfd.preprocessing.online import (
    CausalLowpass,
    HandMessage,
    ObjectMessage,
    OnlineFeatures,
    OnlinePreprocessor,
    demo_messages,
    replay,
)
from lfd.segmentation.gaps import fill_gaps
from lfd.segmentation.stage1 import section_boundaries
from lfd.segmentation.templates import preprocessing_options

RECORDINGS = Path(__file__).resolve().parent.parent / "recordings"
OPTIONS = preprocessing_options()  # what lfd segment uses with the shipped templates


def _run(demo: lfd.Demonstration, **options: object) -> tuple[OnlinePreprocessor, OnlineFeatures]:
    pre = OnlinePreprocessor.for_demonstration(demo, **{**OPTIONS, **options})
    feats = OnlineFeatures(pre.object_names, pre.object_sizes, pre.rate_hz)
    for _ in replay(demo, preprocessor=pre, features=feats):
        pass
    return pre, feats


@pytest.fixture(scope="module")
def sim_demo() -> lfd.Demonstration:
    from lfd.sim import simulate
    from lfd.sim.variability import Variability

    return simulate("exp2", seed=5, variability=Variability(style="natural")).demo


def _demo(name: str, sim_demo: lfd.Demonstration) -> lfd.Demonstration:
    return sim_demo if name == "sim" else lfd.load(RECORDINGS / f"{name}.mcap")


CASES = ["exp1", "exp2", "exp3", "exp4", "sim"]


@pytest.mark.parametrize("name", CASES)
def test_online_rows_are_compute_features_of_the_online_trajectory(
    name: str, sim_demo: lfd.Demonstration
) -> None:
    pre, feats = _run(_demo(name, sim_demo))
    a = feats.arrays()
    traj = pre.trajectory()
    assert len(traj) == a["values"].shape[0] > 100
    np.testing.assert_array_equal(a["index"], np.arange(len(traj)))
    filled, _ = fill_gaps(traj)
    hand = compute_features(filled, target=a["target"])
    np.testing.assert_allclose(a["values"], hand.values, rtol=0, atol=1e-9)
    other = [c for c in range(10) if c != 4]
    np.testing.assert_allclose(a["thresholds"][:, other], hand.thresholds[:, other], atol=1e-12)
    for o in range(len(traj.object_names)):
        ref = compute_features(filled, target=o)
        np.testing.assert_allclose(a["object_values"][o], ref.values, rtol=0, atol=1e-9)
        # the resting height known at the end is the offline one
        assert a["object_thresholds"][o][-1, 4] == pytest.approx(ref.thresholds[-1, 4], abs=1e-12)


def _stage1(values, thresholds, objects, dt):  # type: ignore[no-untyped-def]
    return section_boundaries(values, thresholds, dt, objects=objects)[1:-1]


# RMS error over the column's range allowed: (hand-object columns, object-only columns, the
# hand's own columns). The fixed-lag smoother is the offline filter on a window; the causal
# filter only tracks it once its delay is taken out.
TOLERANCE = {"fixed-lag": (0.015, 0.08, 0.03), "causal": (0.03, 0.15, 0.06)}


@pytest.mark.parametrize("smoother", ["fixed-lag", "causal"])
@pytest.mark.parametrize("name", CASES)
def test_online_features_track_the_offline_features(
    name: str, smoother: str, sim_demo: lfd.Demonstration
) -> None:
    demo = _demo(name, sim_demo)
    pre, feats = _run(demo, smoother=smoother)
    a = feats.arrays()
    off = lfd.preprocess(demo, **OPTIONS)
    np.testing.assert_array_equal(pre.trajectory().t_ns[: len(off)], off.t_ns[: len(a["t_ns"])])
    filled, _ = fill_gaps(off)
    tol_pair, tol_object, tol_hand = TOLERANCE[smoother]
    hand_lag = pre.shift_samples
    obj_lag = (
        0 if smoother == "fixed-lag" else round(pre.lag_s()["objects"] * pre.rate_hz)
    ) + pre.object_delay_samples
    if smoother == "fixed-lag":  # the rows carry the time they describe; all of them come out
        assert hand_lag == obj_lag == 0 and pre.lag_s()["hand"] == pytest.approx(0.3)
        assert abs(len(a["t_ns"]) - len(off)) <= 1  # the clock ends like offline
    n = min(len(off), len(a["t_ns"]))
    per_object = [compute_features(filled, target=o) for o in range(len(off.object_names))]
    for o, ref in enumerate(per_object):
        for c in range(10):
            lag = obj_lag if c in (3, 4, 8) else hand_lag  # object-only columns lag less
            want, got = ref.values[: n - lag, c], a["object_values"][o][lag:n, c]
            err = np.sqrt(np.mean((want - got) ** 2)) / max(float(np.ptp(ref.values[:, c])), 1e-9)
            # hand-object columns need the objects delayed to the hand's lag (match_lag)
            assert err < (tol_pair if c in (2, 5, 6, 7) else tol_object), (o, ref.names[c], err)
    offline = compute_features(filled)
    for c in (0, 1, 9):  # the hand's own columns: lag only
        want, got = offline.values[: n - hand_lag, c], a["values"][hand_lag:n, c]
        err = np.sqrt(np.mean((want - got) ** 2)) / float(np.ptp(offline.values[:, c]))
        assert err < tol_hand, (offline.names[c], err)
    b_off = _stage1(
        offline.values, offline.thresholds, [(f.values, f.thresholds) for f in per_object], off.dt
    )
    b_on = _stage1(
        a["values"],
        a["thresholds"],
        [(a["object_values"][o], a["object_thresholds"][o]) for o in range(len(per_object))],
        off.dt,
    )
    dist = np.array([np.min(np.abs(b_on - hand_lag - b)) for b in b_off])
    assert np.mean(dist <= 3) >= 0.8, dist
    assert np.median(dist) <= 1
    assert 0.7 * len(b_off) <= len(b_on) <= 1.3 * len(b_off)


def test_causal_lowpass_is_sosfilt_with_kept_state() -> None:
    from scipy.signal import group_delay, sos2tf, sosfilt, sosfilt_zi

    rng = np.random.default_rng(0)
    x = np.cumsum(rng.normal(size=(200, 2)), axis=0)
    f = CausalLowpass(2.0, 30.0, 2)
    got = np.array([f.step(row, np.ones(2, bool)) for row in x])
    want = sosfilt(f.sos, x, axis=0, zi=sosfilt_zi(f.sos)[:, :, None] * x[0])[0]
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
    b, a = sos2tf(f.sos)
    _, gd = group_delay((b, a), w=[2 * np.pi * 0.05 / 30.0])
    assert f.delay_s == pytest.approx(gd[0] / 30.0, rel=1e-3)
    assert f.delay_s == pytest.approx(2.6131 / (2 * np.pi * 2.0), rel=0.02)  # Butterworth 4
    # an invalid sample drops the state of its column; the run restarts at steady state
    y = f.step(np.array([5.0, 7.0]), np.array([False, True]))
    assert np.isnan(y[0]) and np.isfinite(y[1])
    assert f.step(np.array([5.0, 7.0]), np.ones(2, bool))[0] == pytest.approx(5.0)


def _messages(demo: lfd.Demonstration) -> list[HandMessage | ObjectMessage]:
    return list(demo_messages(demo))


def _feed(pre: OnlinePreprocessor, msgs: list[HandMessage | ObjectMessage]) -> list[object]:
    out: list[object] = []
    for m in msgs:
        out += pre.push(m)
    return out + pre.flush()


def test_out_of_order_messages() -> None:
    demo = lfd.load(RECORDINGS / "exp1.mcap")
    msgs = _messages(demo)
    ref = OnlinePreprocessor.for_demonstration(demo, **OPTIONS)
    _feed(ref, msgs)
    # a late message already behind the emitted clock is dropped with a warning
    late = [m for m in msgs if isinstance(m, HandMessage)][10]
    pos = next(i for i, m in enumerate(msgs) if m.t_ns > late.t_ns + 2_000_000_000)
    pre = OnlinePreprocessor.for_demonstration(demo, **OPTIONS)
    _feed(pre, [*msgs[:pos], late, *msgs[pos:]])
    assert pre.dropped == 1 and len(pre.warnings) == 1 and "dropped" in pre.warnings[0]
    np.testing.assert_array_equal(pre.trajectory().tcp, ref.trajectory().tcp)
    # object messages a little out of order (not yet emitted) are sorted in: same output
    swapped = list(msgs)
    objs = [i for i, m in enumerate(swapped) if isinstance(m, ObjectMessage)]
    for i, j in zip(objs[100:200:2], objs[101:200:2], strict=True):
        swapped[i], swapped[j] = swapped[j], swapped[i]
    pre = OnlinePreprocessor.for_demonstration(demo, **OPTIONS)
    _feed(pre, swapped)
    assert pre.dropped == 0
    np.testing.assert_array_equal(
        pre.trajectory().object_position, ref.trajectory().object_position
    )


def _with_hand(demo: lfd.Demonstration, keypoints: np.ndarray, confidence: np.ndarray):  # type: ignore[no-untyped-def]
    hand = HandTrack(demo.hand.t_ns, keypoints, confidence, side=demo.hand.side)
    return dataclasses.replace(demo, hand=hand)


@pytest.mark.parametrize("how", ["nan", "low_confidence"])
def test_missing_keypoints_and_long_gaps_like_offline(how: str) -> None:
    demo = lfd.load(RECORDINGS / "exp2.mcap")
    kp = demo.hand.keypoints.copy()
    conf = demo.hand.confidence.copy()
    short, long = [20], [40, 41, 42, 43]  # 0.4 s (interpolated) and 1.0 s (a gap) at 5 Hz
    for frames in (short, long):
        if how == "nan":
            kp[frames, 4] = np.nan
        else:
            conf[frames, 4] = 0.1
    demo = _with_hand(demo, kp, conf)
    options = {**OPTIONS, "min_keypoint_confidence": 0.3}
    off = lfd.preprocess(demo, **options)
    pre, feats = _run(demo, **options)
    traj = pre.trajectory()
    n = min(len(off), len(traj))
    np.testing.assert_array_equal(traj.hand_valid[:n], off.hand_valid[:n])
    gap = ~traj.hand_valid
    assert 20 <= gap.sum() <= 35  # about 0.8 s at 30 Hz
    assert np.isnan(traj.tcp[gap]).all() and np.isfinite(traj.tcp[~gap]).all()
    a = feats.arrays()
    assert not a["valid"][gap].any() and a["valid"][~gap].all()
    assert np.isfinite(a["values"]).all()  # held through the gap, like fill_gaps


@pytest.mark.parametrize("smoother", ["fixed-lag", "causal"])
def test_object_gap_without_filling_is_invalid_like_offline(smoother: str) -> None:
    demo = lfd.load(RECORDINGS / "exp3.mcap")
    name = next(iter(demo.objects))
    ob = demo.objects[name]
    vis = ob.visible.copy()
    vis[100:150] = False  # 1.7 s at 30 Hz
    demo.objects[name] = dataclasses.replace(ob, visible=vis)
    options = {**OPTIONS, "fill_hidden": False}
    off = lfd.preprocess(demo, **options)
    pre, _ = _run(demo, **options, smoother=smoother)
    traj = pre.trajectory()
    n = min(len(off), len(traj))
    d = pre.object_delay_samples  # causal: the objects are delayed to the hand's lag
    assert d == (5 if smoother == "causal" else 0)
    np.testing.assert_array_equal(traj.object_valid[:, d:n], off.object_valid[:, : n - d])
    assert (~traj.object_valid[0]).sum() > 30
    # with filling, the hidden object is held (valid, flagged as filled)
    pre = OnlinePreprocessor.for_demonstration(demo, **OPTIONS, smoother=smoother)
    _feed(pre, _messages(demo))
    assert all(s.object_valid.all() for s in pre.samples)
    assert sum(bool(s.object_filled[0]) for s in pre.samples) > 30


def test_a_stalled_stream_is_waited_for_at_most_max_wait() -> None:
    demo = lfd.load(RECORDINGS / "exp1.mcap")
    msgs = _messages(demo)
    t_cut = msgs[0].t_ns + 5_000_000_000
    # the hand stops at 5 s, the objects go on
    msgs = [m for m in msgs if isinstance(m, ObjectMessage) or m.t_ns < t_cut]
    pre = OnlinePreprocessor.for_demonstration(demo, **OPTIONS, max_wait_s=0.3)
    last_t = 0
    for m in msgs:
        out = pre.push(m)
        if out:
            last_t = out[-1].t_ns
            # never more than max_wait (and the smoother's lag) behind
            assert m.t_ns - last_t <= 0.3e9 + pre.lag_s()["hand"] * 1e9 + 34e6
    assert not pre.samples[-1].hand_valid  # emitted as a gap, not waited for forever
    assert last_t > t_cut + 1e9


def test_options_are_checked_and_the_buffers_stay_small_before_the_start() -> None:
    demo = lfd.load(RECORDINGS / "exp1.mcap")
    with pytest.raises(lfd.errors.UsageError, match="hand frame period"):
        OnlinePreprocessor.for_demonstration(demo, max_wait_s=0.1)
    with pytest.raises(lfd.errors.DemonstrationError, match="unknown object"):
        OnlinePreprocessor.for_demonstration(demo).add_object("nope", 0, [0, 0, 0], [0, 0, 0, 1])
    # objects without a hand: nothing is emitted, and old poses are not kept
    pre = OnlinePreprocessor.for_demonstration(demo, **OPTIONS)
    objects = [m for m in _messages(demo) if isinstance(m, ObjectMessage)]
    assert all(pre.push(m) == [] for m in objects) and pre.flush() == []
    assert max(len(s.t) for s in pre._objects) <= 40  # 1 s at 30 Hz
