"""Preprocessing: MATLAB-parity filter, spline/slerp resampling, gaps, hand -> gripper mapping."""

from __future__ import annotations

import numpy as np
import pytest
from _synthetic import HAND_TEMPLATE, T0, make_demo
from lfd import _hmmseg
from lfd.demo import INDEX_MCP, INDEX_TIP, THUMB_TIP, HandTrack
from lfd.errors import DemonstrationError
from lfd.preprocessing import (
    gripper_frame,
    lowpass,
    preprocess,
    resample_positions,
    resample_quaternions,
)
from scipy.linalg import companion
from scipy.signal import butter, lfilter, lfilter_zi
from scipy.spatial.transform import Rotation


# --- filter -------------------------------------------------------------------------------
def matlab_filtfilt(b: np.ndarray, a: np.ndarray, x: np.ndarray) -> np.ndarray:
    """MATLAB's filtfilt written out: odd extension of 3*(order) samples, zi scaled, 2 passes."""
    pad = 3 * (max(len(a), len(b)) - 1)
    ext = np.concatenate([2 * x[0] - x[pad:0:-1], x, 2 * x[-1] - x[-2 : -pad - 2 : -1]])
    zi = lfilter_zi(b, a)
    y, _ = lfilter(b, a, ext, zi=zi * ext[0])
    y = y[::-1]
    y, _ = lfilter(b, a, y, zi=zi * y[0])
    return y[::-1][pad:-pad]


@pytest.mark.parametrize("cutoff", [0.625, 0.0625, 3.0])
def test_lowpass_matches_matlab_filtfilt(cutoff: float) -> None:
    rng = np.random.default_rng(1)
    t = np.arange(300) / 30.0
    x = np.sin(2 * np.pi * 0.2 * t) + 0.3 * rng.standard_normal(t.size) + 0.5 * t
    # the engine's coefficients (scipy's design agrees to a few units in the last place,
    # tests/unit/engine/test_signal.py): the filtering is compared, and agrees to the
    # conditioning of the initial-state solve (1e-15 of it, relative)
    b, a = _hmmseg.butter_lowpass(4, cutoff, 30.0)
    np.testing.assert_array_max_ulp(a, butter(4, cutoff / 15.0)[1], maxulp=16)
    expected = matlab_filtfilt(b, a, x)
    cond = np.linalg.cond(np.eye(4) - companion(a).T)
    tol = 1e-15 * max(cond, 10.0) * np.abs(expected).max()
    np.testing.assert_allclose(lowpass(x, cutoff, 30.0), expected, rtol=0, atol=tol)
    # columns are independent
    two = lowpass(np.stack([x, -2 * x], axis=1), cutoff, 30.0)
    np.testing.assert_allclose(two[:, 1], -2 * expected, atol=2 * tol)


def test_lowpass_gain_and_errors() -> None:
    t = np.arange(3000) / 30.0
    at_cutoff = lowpass(np.sin(2 * np.pi * 0.625 * t), 0.625, 30.0)
    assert abs(np.abs(at_cutoff[500:-500]).max() - 0.5) < 0.01  # two passes: gain 1/2
    with pytest.raises(DemonstrationError, match="too short"):
        lowpass(np.zeros(12), 0.625, 30.0)
    lowpass(np.zeros(13), 0.625, 30.0)
    with pytest.raises(DemonstrationError, match="Nyquist"):
        lowpass(np.zeros(100), 20.0, 30.0)
    # a cut-off too small to design a filter for: the rule's message, not the engine's
    for tiny in (1e-300, 0.001):
        with pytest.raises(DemonstrationError, match=r"between 0\.01 Hz and the Nyquist"):
            lowpass(np.zeros(100), tiny, 30.0)


def test_preprocess_refuses_a_tiny_object_cutoff_in_one_line() -> None:
    """``preprocess(demo, object_cutoff_hz=1e-300)`` from Python says what the cut-off must be
    (the method file's bound, 0.01 Hz), not the engine's "singular linear system"."""
    demo = make_demo(duration_s=10.0)
    with pytest.raises(DemonstrationError, match=r"cut-off 1e-300 Hz must be between 0\.01 Hz"):
        preprocess(demo, object_cutoff_hz=1e-300)


def test_lowpass_filters_runs_between_gaps() -> None:
    rng = np.random.default_rng(2)
    x = rng.standard_normal(200)
    x[100:110] = np.nan
    x[150:160] = np.nan  # leaves a 40-sample run and a 5-sample run (too short)
    x[195:] = np.nan
    short: list[tuple[int, int]] = []
    y = lowpass(x, 0.625, 30.0, report=short)
    np.testing.assert_array_equal(np.isnan(y), np.isnan(x))
    np.testing.assert_allclose(y[:100], lowpass(x[:100], 0.625, 30.0), atol=1e-15)
    np.testing.assert_allclose(y[110:150], lowpass(x[110:150], 0.625, 30.0), atol=1e-15)
    assert short == [(160, 195)] or short == []  # 35 samples is enough
    x[165:170] = np.nan
    short.clear()
    y = lowpass(x, 0.625, 30.0, report=short)
    assert (160, 165) in short
    np.testing.assert_array_equal(y[160:165], x[160:165])  # left as is, reported


# --- resampling ---------------------------------------------------------------------------
def test_cubic_resampling_of_a_sine() -> None:
    ts = np.arange(0, 10.0001, 0.2)  # 5 Hz
    td = np.arange(0, 10.0001, 1 / 30)
    x = np.stack([np.sin(2 * np.pi * 0.3 * ts), np.cos(2 * np.pi * 0.3 * ts)], axis=1)
    y, valid = resample_positions(ts, x, td, max_gap_s=0.5)
    assert valid.all()
    truth = np.stack([np.sin(2 * np.pi * 0.3 * td), np.cos(2 * np.pi * 0.3 * td)], axis=1)
    err = np.abs(y - truth)
    assert err[15:-15].max() < 5e-4  # interior, h = 0.2 s
    assert err.max() < 5e-3  # not-a-knot ends
    np.testing.assert_allclose(y[::6], x, atol=1e-12)  # passes through the samples


def test_resampling_gaps_short_filled_long_kept() -> None:
    ts = np.arange(0, 10.0001, 0.2)
    x = np.sin(ts)[:, None].repeat(2, axis=1)
    x[10:12, 0] = np.nan  # 0.6 s between real samples: filled (max_gap 0.7)
    x[20:28, 0] = np.nan  # 1.8 s: kept as NaN
    td = np.arange(0, 10.0001, 1 / 30)
    y, valid = resample_positions(ts, x, td, max_gap_s=0.7)
    assert valid[:, 1].all()
    gap = (td > ts[19]) & (td < ts[28])
    assert not valid[gap, 0].any() and np.isnan(y[gap, 0]).all()
    assert valid[~gap, 0].all()
    np.testing.assert_allclose(y[~gap, 0], np.sin(td[~gap]), atol=2e-3)
    # nothing outside the data
    y2, v2 = resample_positions(ts, x, np.array([-0.1, 10.5]), max_gap_s=0.7)
    assert not v2.any() and np.isnan(y2).all()


def test_slerp_resampling_is_sign_consistent() -> None:
    ts = np.arange(0, 4.0001, 1 / 30)
    angle = 0.8 * ts  # rotation about z crossing pi
    q = Rotation.from_rotvec(np.outer(angle, [0, 0, 1])).as_quat()
    q[::3] *= -1  # the same rotations with flipped signs
    q[40:45] = np.nan
    td = np.arange(0, 4.0001, 0.01)
    out, valid = resample_quaternions(ts, q, td, max_gap_s=0.5)
    assert valid.all()
    truth = Rotation.from_rotvec(np.outer(0.8 * td, [0, 0, 1]))
    err = (Rotation.from_quat(out) * truth.inv()).magnitude()
    assert err.max() < 1e-9
    assert (np.einsum("ij,ij->i", out[1:], out[:-1]) > 0).all()


# --- mapping ------------------------------------------------------------------------------
def test_gripper_frame_known_configuration() -> None:
    # B at the origin, TCP on +z, I and T in the y-z plane: the frame is the identity.
    kp = np.zeros((1, 21, 3))
    kp[0, INDEX_MCP] = (0, 0, 0)
    kp[0, INDEX_TIP] = (0, 0.03, 0.1)  # x = (I - B) x (T - B) points along +x
    kp[0, THUMB_TIP] = (0, -0.03, 0.1)
    tcp, R, opening = gripper_frame(kp)
    np.testing.assert_allclose(tcp[0], (0, 0, 0.1), atol=1e-15)
    np.testing.assert_allclose(opening, [0.06])
    np.testing.assert_allclose(R[0], np.eye(3), atol=1e-15)
    # rotate and translate the hand: R follows, TCP follows, opening is unchanged
    rots = Rotation.random(50, random_state=3)
    shift = np.random.default_rng(3).normal(size=(50, 3))
    moved = np.einsum("nij,kj->nki", rots.as_matrix(), kp[0]) + shift[:, None, :]
    tcp, R, opening = gripper_frame(moved)
    np.testing.assert_allclose(R, rots.as_matrix(), atol=1e-12)
    np.testing.assert_allclose(tcp, rots.apply([0, 0, 0.1]) + shift, atol=1e-12)
    np.testing.assert_allclose(opening, 0.06, atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=1e-12)
    # a left hand is the mirror image S of a right hand: x (palm normal) and z are mirrored,
    # y flips so that the frame stays right-handed: R_left = S R diag(1, -1, 1)
    S = np.diag([-1.0, 1.0, 1.0])
    tcp_l, R_left, open_l = gripper_frame(moved @ S, side="left")
    np.testing.assert_allclose(R_left, S @ rots.as_matrix() @ np.diag([1.0, -1.0, 1.0]), atol=1e-12)
    np.testing.assert_allclose(tcp_l, tcp @ S, atol=1e-12)
    np.testing.assert_allclose(open_l, opening, atol=1e-12)
    with pytest.raises(DemonstrationError, match="side"):
        gripper_frame(kp, side="middle")


def test_gripper_frame_degenerate_and_missing() -> None:
    kp = np.tile(HAND_TEMPLATE, (3, 1, 1))
    kp[1, INDEX_TIP] = (0, 0.2, 0)
    kp[1, THUMB_TIP] = (0, 0.3, 0)
    kp[1, INDEX_MCP] = (0, 0.1, 0)  # collinear
    kp[2, THUMB_TIP] = np.nan
    tcp, R, opening = gripper_frame(kp)
    assert np.isfinite(R[0]).all() and np.isnan(R[1:]).all()
    assert np.isfinite(tcp[1]).all() and np.isnan(tcp[2]).all() and np.isnan(opening[2])
    with pytest.raises(DemonstrationError, match="collinear"):
        gripper_frame(kp, strict=True)
    with pytest.raises(DemonstrationError, match="shape"):
        gripper_frame(np.zeros((4, 20, 3)))


# --- the pipeline -------------------------------------------------------------------------
def test_preprocess_synthetic_demo() -> None:
    demo = make_demo(duration_s=10.0)
    traj = preprocess(demo)
    n = len(traj)
    assert traj.dt == pytest.approx(1 / 30, abs=1e-9)
    # the clock spans the hand (objects are held at rest outside their sightings) ...
    assert traj.t_ns[0] == max(demo.hand.t_ns[0], min(o.t_ns[0] for o in demo.objects.values()))
    # ... or, without filling, only the time every object was seen
    strict = preprocess(demo, fill_hidden=False)
    assert strict.t_ns[0] == max(demo.hand.t_ns[0], *(o.t_ns[0] for o in demo.objects.values()))
    assert traj.t_ns[-1] <= demo.hand.t_ns[-1]
    assert n == pytest.approx((demo.hand.t_ns[-1] - traj.t_ns[0]) * 30e-9, abs=1.01)
    assert traj.tcp.shape == (n, 3) and traj.rotation.shape == (n, 3, 3)
    assert traj.euler.shape == (n, 3) and traj.opening.shape == (n,)
    assert traj.keypoints.shape == (n, 21, 3)
    assert traj.object_names == ["cube0", "cube1"]
    assert traj.object_position.shape == (2, n, 3) and traj.object_quaternion.shape == (2, n, 4)
    assert traj.object_size.shape == (2, 3)
    assert traj.hand_valid.all() and traj.object_valid.all()  # the 4-sample occlusion is filled
    assert np.isfinite(traj.tcp).all()
    # slow smooth motion: the filtered positions stay close to the truth
    from _synthetic import hand_keypoints

    truth = hand_keypoints(traj.t_s + (traj.t_ns[0] - T0) * 1e-9)
    assert np.abs(traj.keypoints - truth)[30:-30].max() < 3e-3
    np.testing.assert_allclose(
        traj.opening, np.linalg.norm(truth[:, 8] - truth[:, 4], axis=1), atol=3e-3
    )
    # euler angles are unwrapped and the rotation matrices agree with them
    assert np.abs(np.diff(traj.euler, axis=0)).max() < 0.1
    back = Rotation.from_matrix(traj.rotation).as_euler("xyz")
    np.testing.assert_allclose(np.angle(np.exp(1j * (back - traj.euler))), 0, atol=1e-9)
    assert traj.meta["labels"][0][0] == "pick_up"
    assert traj.meta["gaps"]["hand"] == [] and traj.meta["gaps"]["carried"] == {}
    assert traj.meta["gaps"]["objects"] == {"cube0": [], "cube1": []}


def test_preprocess_long_hand_gap_is_reported() -> None:
    demo = make_demo(duration_s=10.0)
    h = demo.hand
    kp = h.keypoints.copy()
    kp[20:28] = np.nan  # 1.8 s without the hand
    kp[10, :, :] = np.nan  # one missing sample: 0.4 s gap, filled
    demo.hand = HandTrack(h.t_ns, kp, h.confidence)
    traj = preprocess(demo)
    ((g0, g1),) = traj.meta["gaps"]["hand"]
    assert (g0, g1) == (int(h.t_ns[19]), int(h.t_ns[28]))
    inside = (traj.t_ns > g0) & (traj.t_ns < g1)
    assert not traj.hand_valid[inside].any() and traj.hand_valid[~inside].all()
    assert np.isnan(traj.tcp[inside]).all() and np.isnan(traj.euler[inside]).all()
    assert np.isfinite(traj.tcp[~inside]).all()


def test_preprocess_object_gap_and_errors() -> None:
    demo = make_demo(duration_s=10.0)
    obj = demo.objects["cube1"]
    obj.visible[100:160] = False  # 2 s occlusion
    traj = preprocess(demo, max_gap_s=0.5, fill_hidden=False)
    assert not traj.object_valid[1].all() and traj.object_valid[0].all()
    assert len(traj.meta["gaps"]["objects"]["cube1"]) == 1
    assert np.isnan(traj.object_position[1][~traj.object_valid[1]]).all()
    # an object that is never seen is kept, invalid everywhere
    from lfd.demo import ObjectTrack

    empty = np.zeros((0, 3))
    demo.objects["ghost"] = ObjectTrack("ghost", 9, (0.1,) * 3, [], empty, np.zeros((0, 4)), [])
    traj = preprocess(demo)
    assert traj.object_names[-1] == "ghost" and not traj.object_valid[-1].any()
    assert np.isnan(traj.object_position[-1]).all() and traj.object_valid[0].all()
    raw = preprocess(demo, filter=False)
    assert raw.meta["filtered"] is False
    with pytest.raises(DemonstrationError, match="too short to filter"):
        preprocess(make_demo(duration_s=0.35, hand_hz=10.0))  # 10 samples on the clock
    short = preprocess(make_demo(duration_s=0.35, hand_hz=10.0), filter=False)
    assert len(short) > 0


def test_hidden_object_is_carried_with_the_hand_and_held_at_rest() -> None:
    """A tag hidden from the approach to the release: at rest, then with the TCP, then at rest."""
    from lfd.preprocessing.carry import fill_carried_gaps, hold_ends

    n = 100
    tcp = np.zeros((n, 3))
    tcp[:, 0] = np.linspace(-0.2, 0.4, n)  # the hand sweeps along x ...
    tcp[:, 2] = 0.05
    grasp, release = 30, 70  # ... reaching the object at 30, letting go at 70
    truth = np.empty((n, 3))
    below = np.array([0.0, 0.0, -0.02])  # the object centre under the TCP while held
    truth[:grasp] = tcp[grasp] + below
    truth[grasp : release + 1] = tcp[grasp : release + 1] + below
    truth[release + 1 :] = tcp[release] + below
    pos = truth.copy()
    quat = np.tile([0.0, 0.0, 0.0, 1.0], (n, 1))
    valid = np.ones(n, dtype=bool)
    valid[10:85] = False  # hidden from well before the grasp to after the release
    pos[~valid] = np.nan
    quat[~valid] = np.nan
    filled = fill_carried_gaps(pos, quat, valid, tcp, np.ones(n, dtype=bool), grasp_radius=0.021)
    assert filled == [(10, 85)] and valid.all()
    np.testing.assert_allclose(pos, truth, atol=0.012)  # radius reached a bit before the grasp
    np.testing.assert_allclose(pos[:20], truth[:20], atol=1e-12)  # at rest before the grasp
    np.testing.assert_allclose(pos[-10:], truth[-10:], atol=1e-12)  # at rest after the release
    np.testing.assert_allclose(np.linalg.norm(quat, axis=1), 1.0)

    # a moved object the hand never came near keeps its gap
    far = truth + np.array([0.0, 1.0, 0.0])
    far[40:60] += [0.1, 0, 0]
    v = np.ones(n, dtype=bool)
    v[35:65] = False
    p2, q2 = np.where(v[:, None], far, np.nan), np.tile([0.0, 0, 0, 1], (n, 1))
    assert fill_carried_gaps(p2, q2, v, tcp, np.ones(n, dtype=bool), 0.05) == []
    assert not v[35:65].any()

    # outside its sightings an object is held at its first / last pose
    p3 = np.where(np.arange(n)[:, None] < 5, np.nan, truth)
    p3[95:] = np.nan
    v3 = np.isfinite(p3).all(axis=1)
    q3 = np.tile([0.0, 0, 0, 1], (n, 1))
    assert hold_ends(p3, q3, v3) == [(0, 5), (95, n)]
    assert v3.all() and (p3[:5] == truth[5]).all() and (p3[95:] == truth[94]).all()


def test_carried_object_leaves_when_the_hand_lifts_it() -> None:
    """The hand hovers and descends over the hidden object before lifting it: the object must
    stay put until the grasp (not sink with the descending hand) and rest after the release."""
    from lfd.preprocessing.carry import fill_carried_gaps

    n = 150
    s = np.linspace(0.0, 1.0, n)
    p0, p1 = np.array([0.0, 0.3, 0.02]), np.array([0.2, 0.3, 0.02])
    grip = np.array([0.0, 0.0, 0.015])  # TCP above the object centre while holding it
    above, away = np.array([0.0, 0.0, 0.06]), np.array([0.0, -0.1, 0.15])
    tcp = np.empty((n, 3))
    approach, grasp, release, leave = 20, 50, 100, 130
    tcp[:approach] = p0 + away
    tcp[approach:grasp] = np.linspace(p0 + above, p0 + grip, grasp - approach)
    lift = np.linspace(0.0, 1.0, release - grasp)[:, None]
    arc = np.sin(np.pi * lift) * [0, 0, 0.12]
    tcp[grasp:release] = (1 - lift) * (p0 + grip) + lift * (p1 + grip) + arc
    tcp[release:leave] = np.linspace(p1 + grip, p1 + above, leave - release)
    tcp[leave:] = p1 + away
    truth = np.where(s[:, None] < s[grasp], p0, p1)
    truth[grasp:release] = tcp[grasp:release] - grip
    pos = truth.copy()
    quat = np.tile([0.0, 0.0, 0.0, 1.0], (n, 1))
    valid = np.ones(n, dtype=bool)
    valid[15:140] = False
    pos[~valid], quat[~valid] = np.nan, np.nan
    assert fill_carried_gaps(pos, quat, valid, tcp, np.ones(n, dtype=bool), 0.055) == [(15, 140)]
    np.testing.assert_allclose(pos[:grasp], truth[:grasp], atol=1e-9)  # still while hovered
    np.testing.assert_allclose(pos[release:], truth[release:], atol=1e-9)
    np.testing.assert_allclose(pos, truth, atol=0.002)
    assert pos[:, 2].min() > 0.02 - 1e-9  # never pushed into the table


def test_a_hidden_carry_with_the_hand_out_of_view() -> None:
    """A hand unseen for part of the gap (it lifted the object out of the camera's view) still
    carries the hidden object there (its TCP bridged); one seen in less than half of it does
    not."""
    from lfd.preprocessing.carry import fill_carried_gaps

    n = 200
    p0, p1 = np.array([0.0, 0.3, 0.02]), np.array([0.2, 0.3, 0.02])
    grip = np.array([0.0, 0.0, 0.015])
    tcp = np.empty((n, 3))
    away = p0 + np.array([0.0, -0.1, 0.15])
    tcp[:20] = away
    tcp[20:40] = np.linspace(away, p0 + grip, 20)
    k = np.linspace(0.0, 1.0, 110)[:, None]
    tcp[40:150] = (1 - k) * (p0 + grip) + k * (p1 + grip) + np.sin(np.pi * k) * [0, 0, 0.3]
    tcp[150:] = p1 + grip
    truth = np.where(np.arange(n)[:, None] < 40, p0, p1)
    truth[40:150] = tcp[40:150] - grip
    valid = np.ones(n, dtype=bool)
    valid[15:170] = False
    hand = np.ones(n, dtype=bool)
    hand[80:110] = False  # out of view at the top of the carry
    seen_tcp = np.where(hand[:, None], tcp, np.nan)
    pos, quat = truth.copy(), np.tile([0.0, 0.0, 0.0, 1.0], (n, 1))
    pos[~valid], quat[~valid] = np.nan, np.nan
    assert fill_carried_gaps(pos, quat, valid, seen_tcp, hand, 0.06) == [(15, 170)]
    assert np.isfinite(pos).all() and valid.all()
    np.testing.assert_allclose(pos[~hand[:n]][:, :2], truth[~hand[:n]][:, :2], atol=0.005)
    assert pos[95, 2] > p0[2] + 0.2  # carried high while the hand was out of view
    np.testing.assert_allclose(pos[:20], truth[:20], atol=1e-12)
    np.testing.assert_allclose(pos[160:], truth[160:], atol=1e-12)
    # the hand seen in less than half of the gap: no evidence, the gap stays
    rare = np.zeros(n, dtype=bool)
    rare[:16], rare[160:], rare[60:65] = True, True, True
    pos2, quat2 = truth.copy(), np.tile([0.0, 0.0, 0.0, 1.0], (n, 1))
    v2 = valid.copy()
    v2[15:170] = False
    pos2[~v2], quat2[~v2] = np.nan, np.nan
    assert (
        fill_carried_gaps(pos2, quat2, v2, np.where(rare[:, None], tcp, np.nan), rare, 0.06) == []
    )


# --- hand confidence ----------------------------------------------------------------------
GRIPPER = [THUMB_TIP, INDEX_MCP, INDEX_TIP]


def _with_confidence(demo, conf: np.ndarray, keypoints: np.ndarray | None = None, **kw):
    h = demo.hand
    demo.hand = HandTrack(h.t_ns, h.keypoints if keypoints is None else keypoints, conf, **kw)
    return demo


def _outlier_demo(confidence: float) -> tuple:
    """A clean demo (confidence 1) and a copy in which every 4th hand sample has its gripper
    keypoints thrown 10 cm off, with ``confidence``."""
    clean = make_demo(duration_s=10.0)
    observed = np.isfinite(clean.hand.keypoints).all(axis=2)
    clean = _with_confidence(clean, observed.astype(float))
    rng = np.random.default_rng(1)
    kp = clean.hand.keypoints.copy()
    conf = clean.hand.confidence.copy()
    bad = np.arange(3, len(clean.hand) - 3, 4)
    offset = rng.normal(size=(bad.size, 3, 3))
    kp[np.ix_(bad, GRIPPER)] += 0.10 * offset / np.linalg.norm(offset, axis=2, keepdims=True)
    conf[np.ix_(bad, GRIPPER)] = confidence
    return clean, _with_confidence(make_demo(duration_s=10.0), conf, kp), bad


def _tcp_error_mm(traj, ref) -> np.ndarray:
    assert np.array_equal(traj.t_ns, ref.t_ns)
    return np.linalg.norm(traj.tcp - ref.tcp, axis=1) * 1e3


def test_low_confidence_outliers_are_dropped() -> None:
    clean, noisy, bad = _outlier_demo(confidence=0.1)
    ref = preprocess(clean)
    used = preprocess(noisy)  # default: min_keypoint_confidence 0.3
    ignored = preprocess(noisy, min_keypoint_confidence=0)
    err_used, err_ignored = _tcp_error_mm(used, ref), _tcp_error_mm(ignored, ref)
    assert err_used.max() < 0.5, err_used.max()  # measured 0.002 mm
    assert err_ignored.max() > 20 and np.sqrt(np.mean(err_ignored**2)) > 10  # 25.5, 15.9 mm
    assert used.meta["min_keypoint_confidence"] == 0.3
    assert ignored.meta["min_keypoint_confidence"] == 0
    assert used.meta["low_confidence"] == {
        "keypoints": 3 * bad.size,
        "samples": bad.size,
        "gripper_samples": bad.size,
    }
    assert ignored.meta["low_confidence"] == {"keypoints": 0, "samples": 0, "gripper_samples": 0}
    assert used.hand_valid.all()  # the dropped samples are short gaps, interpolated


def test_confident_enough_samples_are_weighted() -> None:
    """Above the threshold, a less confident sample is pulled towards its neighbours."""
    clean, noisy, _ = _outlier_demo(confidence=0.4)
    ref = preprocess(clean)
    used, ignored = preprocess(noisy), preprocess(noisy, min_keypoint_confidence=0)
    assert used.meta["low_confidence"]["keypoints"] == 0
    err_used, err_ignored = _tcp_error_mm(used, ref), _tcp_error_mm(ignored, ref)
    # about 0.4 x the unweighted error (10.2 vs 25.5 mm)
    assert err_used.max() < 0.5 * err_ignored.max()


def test_all_ones_confidence_is_bit_identical_to_ignoring_it() -> None:
    """Confidence 1 everywhere: the same bits as the pipeline without confidence."""
    demo = make_demo(duration_s=10.0)
    demo = _with_confidence(demo, np.isfinite(demo.hand.keypoints).all(axis=2).astype(float))
    a, b = preprocess(demo), preprocess(demo, min_keypoint_confidence=0.0)
    for field in ("t_ns", "tcp", "rotation", "euler", "opening", "keypoints", "object_position"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field), err_msg=field)
    assert a.meta["low_confidence"]["keypoints"] == 0


def test_not_visible_but_confident_keypoints_are_kept() -> None:
    demo = make_demo(duration_s=10.0)
    seen = preprocess(demo)
    hidden = demo.hand.visible.copy()
    hidden[::3, INDEX_TIP] = False  # occluded, estimated (confidence 0.5-1)
    demo = _with_confidence(demo, demo.hand.confidence, visible=hidden)
    traj = preprocess(demo)
    np.testing.assert_array_equal(traj.tcp, seen.tcp)
    assert traj.meta["low_confidence"]["keypoints"] == 0


def test_confidence_threshold_is_checked() -> None:
    with pytest.raises(DemonstrationError, match=r"min_keypoint_confidence must be in \[0, 1\]"):
        preprocess(make_demo(), min_keypoint_confidence=1.5)


def test_weighted_nodes() -> None:
    from lfd.preprocessing.resample import weighted_nodes

    t = np.arange(6) * 0.2
    x = np.array([0.0, 1, 2, 30, 4, 5])[:, None]
    w = np.array([1, 1, 1, 0.1, 1, 1])
    y = weighted_nodes(t, x, w, max_gap_s=0.5)
    np.testing.assert_array_equal(y[w == 1], x[w == 1])  # weight 1: kept exactly
    assert y[3, 0] == pytest.approx(0.1 * 30 + 0.9 * 3)  # pulled towards its neighbours
    # a long gap cuts the pull: the sample after it is pulled towards its other neighbour only
    t2 = np.array([0, 0.2, 0.4, 2.0, 2.2])
    y2 = weighted_nodes(t2, np.array([0.0, 1, 2, 3, 10])[:, None], np.full(5, 0.5), 0.5)
    assert np.all(np.isfinite(y2))
    assert y2[3, 0] == pytest.approx(0.5 * 3 + 0.5 * y2[4, 0])
    # through resample_positions: all-ones weights change nothing, bad weights are refused
    td = np.linspace(0, 1, 31)
    plain, _ = resample_positions(t, x, td, max_gap_s=0.5)
    ones, _ = resample_positions(t, x, td, max_gap_s=0.5, weights=np.ones(6)[:, None])
    np.testing.assert_array_equal(plain, ones)
    weighted, _ = resample_positions(t, x, td, max_gap_s=0.5, weights=w[:, None])
    assert np.abs(weighted).max() < 10 < np.abs(plain).max()
    with pytest.raises(DemonstrationError, match=r"in \(0, 1\]"):
        resample_positions(t, x, td, max_gap_s=0.5, weights=np.zeros((6, 1)))
