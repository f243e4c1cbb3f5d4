"""The engine's signal processing and rotations (``lfd._hmmseg`` / ``lfd.rotations``) against
scipy, which preprocessing no longer imports.

Bounds: the tridiagonal solve and the cubic splines of 2 or at least 4 knots follow scipy's (and
numpy's) operations in the same order and agree bit for bit. The Butterworth design follows
scipy's operations too, but ``np.poly`` convolves through numpy's BLAS dot, whose kernel depends
on the CPU (an AVX-512 kernel sums in another order): it agrees to 16 units in the last place
(8 seen). ``lfilter_zi`` and the 3-knot spline solve small dense systems, which LAPACK's blocked
LU sums in another order, and the rotations and slerp are scipy's formulas, which its compiled
Cython orders a little differently: these agree to a few units in the last place (1e-14
relative here), and ``filtfilt`` to the conditioning of its initial-state solve
(:func:`_zi_tolerance`: a 0.0625 Hz filter at 30 Hz solves a system of condition 2e9, and the two
agree to 7e-9 there, 2e-14 at 2 Hz).
"""

from __future__ import annotations

import _paths
import numpy as np
import pytest
from lfd import _hmmseg, rotations
from lfd.errors import EngineError, InvalidParameterError
from lfd.preprocessing.filters import lowpass
from lfd.preprocessing.resample import resample_positions, weighted_nodes

signal = pytest.importorskip("scipy.signal")
interpolate = pytest.importorskip("scipy.interpolate")
linalg = pytest.importorskip("scipy.linalg")
transform = pytest.importorskip("scipy.spatial.transform")

RNG = np.random.default_rng(20261202)


def _zi_tolerance(a: np.ndarray) -> float:
    """Relative agreement expected of two ``filtfilt``s with the filter ``a``: 1e-15 times the
    condition number of ``lfilter_zi``'s system ``I - A`` (at least 1e-14); the measured
    disagreement is at most 0.2e-16 times it."""
    n = len(a) - 1
    return 1e-15 * max(float(np.linalg.cond(np.eye(n) - linalg.companion(a).T)), 10.0)


def _close(a: np.ndarray, b: np.ndarray, rel: float) -> None:
    scale = max(1.0, float(np.max(np.abs(b), initial=0.0)))
    np.testing.assert_allclose(a, b, rtol=0, atol=rel * scale)


@pytest.mark.parametrize("order", [1, 2, 3, 4, 5, 6, 8])
@pytest.mark.parametrize("fs", [5.0, 29.97, 30.0, 100.0])
def test_butter_is_scipys_design(order: int, fs: float) -> None:
    for fc in [*(RNG.uniform(0.001, 0.499, 12) * fs), 0.0625, 0.625, 2.0]:
        if fc >= fs / 2:
            continue
        b, a = signal.butter(order, fc, fs=fs)
        b2, a2 = _hmmseg.butter_lowpass(order, fc, fs)
        np.testing.assert_array_max_ulp(b2, b, maxulp=16)
        np.testing.assert_array_max_ulp(a2, a, maxulp=16)
        # a small dense solve: LAPACK sums in another order, so agreement is to the
        # conditioning of I - A (exact for the 4th-order filters preprocessing uses)
        n = len(a) - 1
        cond = np.linalg.cond(np.eye(n) - linalg.companion(a).T)
        try:
            zi = _hmmseg.lfilter_zi(b, a)
        except InvalidParameterError:  # numerically singular (8th order at 1/500 of fs)
            assert cond > 1e12
            continue
        _close(zi, signal.lfilter_zi(b, a), 1e-15 * max(cond, 10.0))


def test_butter_refuses_bad_parameters() -> None:
    for args in [(4, 15.0, 30.0), (4, 0.0, 30.0), (0, 1.0, 30.0), (4, 1.0, float("nan"))]:
        with pytest.raises(InvalidParameterError):
            _hmmseg.butter_lowpass(*args)


@pytest.mark.parametrize("fc", [0.0625, 0.625, 2.0, 6.0])
@pytest.mark.parametrize("n", [13, 14, 40, 3000])
def test_filtfilt_matches_scipy(fc: float, n: int) -> None:
    """Shortest allowed signal (padlen + 1 = 13 samples) up to long ones, many columns."""
    b, a = signal.butter(4, fc, fs=30.0)
    x = RNG.normal(size=(n, 7)).cumsum(axis=0) + 3.0
    want = signal.filtfilt(b, a, x, axis=0, padlen=12)
    got = _hmmseg.filtfilt(b, a, x, 12)
    _close(got, want, _zi_tolerance(a))
    np.testing.assert_array_equal(_hmmseg.filtfilt(b, a, x[:, :1], 12)[:, 0], got[:, 0])
    with pytest.raises(InvalidParameterError):
        _hmmseg.filtfilt(b, a, x[:12], 12)


def test_lowpass_with_gaps_matches_scipy_per_run() -> None:
    b, a = signal.butter(4, 0.625, fs=30.0)
    x = RNG.normal(size=(200, 3)).cumsum(axis=0)
    x[50:53, 0] = np.nan  # splits column 0 into runs of 50 and 147 samples
    x[:190, 2] = np.nan  # column 2: one run of 10 samples, too short to filter
    report: list[tuple[int, int]] = []
    y = lowpass(x, 0.625, 30.0, report=report)
    np.testing.assert_array_equal(np.isnan(y), np.isnan(x))
    tol = _zi_tolerance(a)
    _close(y[:50, 0], signal.filtfilt(b, a, x[:50, 0], padlen=12), tol)
    _close(y[53:, 0], signal.filtfilt(b, a, x[53:, 0], padlen=12), tol)
    _close(y[:, 1], signal.filtfilt(b, a, x[:, 1], padlen=12), tol)
    np.testing.assert_array_equal(y[190:, 2], x[190:, 2])  # left unfiltered
    assert report == [(190, 200)]


@pytest.mark.parametrize("m", [2, 3, 4, 5, 17, 2000])
def test_cubic_spline_matches_scipy(m: int) -> None:
    t = np.sort(RNG.uniform(0.0, 10.0, m))
    y = RNG.normal(size=(m, 4))
    at = np.concatenate([np.linspace(t[0], t[-1], 501), t])
    want = interpolate.CubicSpline(t, y, axis=0)(at)
    got = _hmmseg.cubic_spline(t, y, at)
    if m == 3:  # a dense 3 x 3 solve (LAPACK's blocked LU) orders its sums differently
        _close(got, want, 1e-14)
    else:
        np.testing.assert_array_equal(got, want)


def test_cubic_spline_refuses_bad_knots() -> None:
    with pytest.raises(InvalidParameterError):
        _hmmseg.cubic_spline(np.array([0.0]), np.zeros((1, 1)), np.array([0.0]))
    with pytest.raises(InvalidParameterError):
        _hmmseg.cubic_spline(np.array([0.0, 0.0, 1.0]), np.zeros((3, 1)), np.array([0.0]))
    with pytest.raises(EngineError):
        _hmmseg.cubic_spline(np.array([0.0, 1.0]), np.array([[0.0], [np.nan]]), np.array([0.5]))


@pytest.mark.parametrize("m", [1, 2, 3, 50])
def test_tridiagonal_matches_solve_banded(m: int) -> None:
    ab = RNG.normal(size=(3, m))
    ab[1] += 4.0 * np.sign(ab[1])
    ab[0, 0] = ab[2, -1] = 0.0
    rhs = RNG.normal(size=(m, 3))
    want = linalg.solve_banded((1, 1), ab, rhs)
    got = _hmmseg.solve_tridiagonal(ab[2, :-1], ab[1], ab[0, 1:], rhs)
    np.testing.assert_array_equal(got, want)
    # row interchanges (a small diagonal)
    ab[1, :] = 1e-3
    np.testing.assert_array_equal(
        _hmmseg.solve_tridiagonal(ab[2, :-1], ab[1], ab[0, 1:], rhs),
        linalg.solve_banded((1, 1), ab, rhs),
    )


def test_weighted_nodes_matches_the_scipy_formulation() -> None:
    t = np.cumsum(RNG.uniform(0.05, 0.3, 80))
    x = RNG.normal(size=(80, 3))
    w = RNG.uniform(0.3, 1.0, 80)
    step = np.diff(t)
    near = step <= 0.25
    has_left, has_right = np.r_[False, near], np.r_[near, False]
    left, right = np.r_[np.inf, step], np.r_[step, np.inf]
    both = has_left & has_right
    alpha = np.where(both, right / np.where(both, left + right, 1.0), has_left.astype(float))
    beta = np.where(both, 1.0 - alpha, has_right.astype(float))
    ab = np.zeros((3, 80))
    ab[0, 1:] = -(1.0 - w[:-1]) * beta[:-1]
    ab[1] = 1.0
    ab[2, :-1] = -(1.0 - w[1:]) * alpha[1:]
    want = linalg.solve_banded((1, 1), ab, w[:, None] * x)
    np.testing.assert_array_equal(weighted_nodes(t, x, w, 0.25), want)


def _old_resample_positions(ts, x, td, max_gap_s, weights=None):  # type: ignore[no-untyped-def]
    """The scipy implementation preprocessing used before the engine (per column)."""
    from lfd.preprocessing.resample import gap_mask

    flat = x.reshape(len(ts), -1)
    wflat = None if weights is None else np.broadcast_to(weights, x.shape).reshape(flat.shape)
    out = np.full((td.size, flat.shape[1]), np.nan)
    valid = np.zeros(out.shape, dtype=bool)
    for j in range(flat.shape[1]):
        keep = np.isfinite(flat[:, j])
        tk = ts[keep]
        ok = gap_mask(tk, td, max_gap_s)
        if tk.size == 0 or not ok.any():
            continue
        nodes = flat[keep, j][:, None]
        if wflat is not None:
            w = wflat[keep, j]
            if tk.size >= 2 and not np.all(w == 1.0):
                nodes = _weighted_scipy(tk, nodes, w, max_gap_s)
        if tk.size == 1:
            out[ok, j] = nodes[0, 0]
        else:
            out[ok, j] = interpolate.CubicSpline(tk, nodes[:, 0])(td[ok])
        valid[ok, j] = True
    return out.reshape((td.size, *x.shape[1:])), valid.reshape((td.size, *x.shape[1:]))


def _weighted_scipy(t, x, w, max_gap):  # type: ignore[no-untyped-def]
    m = t.size
    step = np.diff(t)
    near = step <= max_gap
    has_left, has_right = np.r_[False, near], np.r_[near, False]
    left, right = np.r_[np.inf, step], np.r_[step, np.inf]
    both = has_left & has_right
    alpha = np.where(both, right / np.where(both, left + right, 1.0), has_left.astype(float))
    beta = np.where(both, 1.0 - alpha, has_right.astype(float))
    ab = np.zeros((3, m))
    ab[0, 1:] = -(1.0 - w[:-1]) * beta[:-1]
    ab[1] = 1.0
    ab[2, :-1] = -(1.0 - w[1:]) * alpha[1:]
    return linalg.solve_banded((1, 1), ab, w[:, None] * x)


@pytest.mark.parametrize("weighted", [False, True])
def test_resample_positions_matches_scipy(weighted: bool) -> None:
    ts = np.cumsum(RNG.uniform(0.1, 0.3, 400))
    x = RNG.normal(size=(400, 5, 3)).cumsum(axis=0)
    x[100:110, 1] = np.nan  # a long gap of one keypoint
    x[200, 2] = np.nan  # a short one
    x[:395, 4] = np.nan  # a keypoint seen 5 times at the end
    x[:, 3, 0] = np.nan  # one column never seen
    x[7, 3, 1] = np.nan
    w = RNG.uniform(0.3, 1.0, size=(400, 5, 1)) if weighted else None
    td = np.arange(ts[0] - 1.0, ts[-1] + 1.0, 1 / 30)
    got = resample_positions(ts, x, td, max_gap_s=0.5, weights=w)
    want = _old_resample_positions(ts, x, td, 0.5, w)
    np.testing.assert_array_equal(got[1], want[1])
    np.testing.assert_array_equal(got[0], want[0])


def _quats(n: int) -> np.ndarray:
    return RNG.normal(size=(n, 4))


def test_rotations_match_scipy() -> None:
    r = transform.Rotation
    q = _quats(500)
    p = _quats(500)
    _close(rotations.normalize(q), r.from_quat(q).as_quat(), 1e-15)
    _close(rotations.as_matrix(q), r.from_quat(q).as_matrix(), 1e-15)
    m = r.from_quat(q).as_matrix()
    _close(rotations.from_matrix(m), r.from_matrix(m).as_quat(), 1e-15)
    _close(rotations.euler_from_matrix(m), r.from_matrix(m).as_euler("xyz"), 1e-14)
    _close(rotations.euler_from_quat(q), r.from_quat(q).as_euler("xyz"), 1e-14)
    e = RNG.uniform(-3.0, 3.0, size=(500, 3))
    _close(rotations.quat_from_euler(e), r.from_euler("xyz", e).as_quat(), 1e-15)
    _close(rotations.matrix_from_euler(e), r.from_euler("xyz", e).as_matrix(), 1e-15)
    _close(rotations.multiply(p, q), (r.from_quat(p) * r.from_quat(q)).as_quat(), 1e-15)
    _close(rotations.multiply(p[0], q), (r.from_quat(p[0]) * r.from_quat(q)).as_quat(), 1e-15)
    _close(rotations.inverse(rotations.normalize(q)), r.from_quat(q).inv().as_quat(), 1e-15)
    v = RNG.normal(size=(500, 3))
    _close(rotations.apply(q, v), r.from_quat(q).apply(v), 1e-14)
    _close(rotations.apply(q, v, inverse=True), r.from_quat(q).apply(v, inverse=True), 1e-14)
    # one rotation in, one out
    assert rotations.as_matrix(q[0]).shape == (3, 3)
    _close(rotations.euler_from_matrix(m[0]), r.from_matrix(m[0]).as_euler("xyz"), 1e-14)


def test_from_matrix_orthogonalises_and_refuses_reflections() -> None:
    r = transform.Rotation
    m = r.from_quat(_quats(20)).as_matrix() + RNG.normal(scale=1e-6, size=(20, 3, 3))
    _close(rotations.from_matrix(m), r.from_matrix(m).as_quat(), 1e-12)
    with pytest.raises(InvalidParameterError):
        rotations.from_matrix(np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(InvalidParameterError):
        rotations.normalize(np.zeros(4))


def test_nan_rows_stay_nan() -> None:
    q = _quats(6)
    q[2, 1] = np.nan
    out = rotations.as_matrix(q)
    assert np.isnan(out[2]).all() and np.isfinite(out[[0, 1, 3, 4, 5]]).all()
    e = rotations.euler_from_matrix(out)
    assert np.isnan(e[2]).all() and np.isfinite(e[[0, 1, 3, 4, 5]]).all()


@pytest.mark.parametrize("m", [2, 3, 40])
def test_slerp_matches_scipy(m: int) -> None:
    times = np.cumsum(RNG.uniform(0.1, 1.0, m))
    q = _quats(m)
    at = np.concatenate([[times[0], times[-1]], RNG.uniform(times[0], times[-1], 300)])
    want = transform.Slerp(times, transform.Rotation.from_quat(q))(at).as_quat()
    _close(rotations.slerp(times, q, at), want, 1e-14)
    with pytest.raises(InvalidParameterError):
        rotations.slerp(times, q, [times[-1] + 1.0])


def test_make_continuous() -> None:
    q = rotations.normalize(_quats(300))
    q[100] = np.nan
    out = rotations.make_continuous(q)
    dots = np.einsum("ij,ij->i", out[1:], out[:-1])
    assert np.all((dots >= 0) | np.isnan(dots))
    np.testing.assert_array_equal(np.abs(out), np.abs(q))
    np.testing.assert_array_equal(out[[0, 101]], q[[0, 101]])  # runs start unflipped


def test_preprocessing_imports_no_scipy() -> None:
    """``lfd.load`` -> ``lfd.preprocess`` of a shipped recording with scipy blocked."""
    import subprocess
    import sys

    rec = _paths.RECORDINGS / "exp1.mcap"
    code = (
        "import sys\n"
        "class Block:\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name.split('.')[0] == 'scipy':\n"
        "            raise ModuleNotFoundError(f'blocked: {name}', name=name)\n"
        "sys.meta_path.insert(0, Block())\n"
        "import lfd\n"
        f"traj = lfd.preprocess(lfd.load({str(rec)!r}, images=False))\n"
        "assert traj.hand_valid.any()\n"
        "assert not [m for m in sys.modules if m.startswith('scipy')]\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr[-2000:]


@pytest.mark.parametrize("n", [2, 3, 4, 5, 6, 40])
def test_running_median_is_scipy_median_filter(n: int) -> None:
    from lfd.io.checks import running_median

    ndimage = pytest.importorskip("scipy.ndimage")
    x = RNG.normal(size=(n, 3))
    x[n // 2] = 9.0  # a misdetection
    size = min(5, n)
    want = ndimage.median_filter(x, size=(size, 1), mode="nearest")
    np.testing.assert_array_equal(running_median(x, size), want)
