"""DTW and normalisation: parity with dtaidistance and a few-line numpy DTW, properties, errors."""

from __future__ import annotations

import hypothesis.extra.numpy as hnp
import hypothesis.strategies as st
import numpy as np
import pytest
from hypothesis import given, settings
from lfd.dtw import align_to_reference, dtw, dtw_distance, normalize
from lfd.errors import (
    EmptySequenceError,
    InvalidParameterError,
    NonFiniteError,
    ShapeMismatchError,
)


def numpy_dtw(a: np.ndarray, b: np.ndarray, band: int | None = None) -> float:
    """Textbook DTW: full (n+1) x (m+1) matrix, squared Euclidean cost, sqrt at the end."""
    a, b = np.atleast_2d(a.T).T, np.atleast_2d(b.T).T
    n, m = len(a), len(b)
    acc = np.full((n + 1, m + 1), np.inf)
    acc[0, 0] = 0.0
    for i in range(1, n + 1):
        for j in range(1, m + 1):
            if band is None or abs(i - j) <= band:
                cost = np.sum((a[i - 1] - b[j - 1]) ** 2)
                acc[i, j] = cost + min(acc[i - 1, j - 1], acc[i - 1, j], acc[i, j - 1])
    return float(np.sqrt(acc[n, m]))


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(7)


def test_parity_with_dtaidistance(rng: np.random.Generator) -> None:
    from dtaidistance import dtw as dd

    for _ in range(20):
        n, m = rng.integers(1, 60, size=2)
        a, b = rng.normal(size=n).cumsum(), rng.normal(size=m).cumsum()
        assert dtw_distance(a, b) == pytest.approx(dd.distance_fast(a, b), rel=1e-12)
        assert dtw(a, b)[0] == pytest.approx(dd.distance_fast(a, b), rel=1e-12)
    # Equal lengths: our radius r is dtaidistance's window r + 1.
    a, b = rng.normal(size=80), rng.normal(size=80)
    for r in (0, 1, 5, 20):
        want = dd.distance_fast(a, b, window=r + 1)
        assert dtw_distance(a, b, band=r) == pytest.approx(want, rel=1e-12)
        assert dtw(a, b, band=r)[0] == pytest.approx(want, rel=1e-12)


def test_parity_with_dtaidistance_ndim(rng: np.random.Generator) -> None:
    from dtaidistance import dtw_ndim

    a, b = rng.normal(size=(30, 3)), rng.normal(size=(41, 3))
    assert dtw_distance(a, b) == pytest.approx(dtw_ndim.distance_fast(a, b), rel=1e-12)


def test_parity_with_numpy_reference(rng: np.random.Generator) -> None:
    for _ in range(15):
        d = int(rng.integers(1, 4))
        n, m = rng.integers(1, 25, size=2)
        a, b = rng.normal(size=(n, d)), rng.normal(size=(m, d))
        assert dtw_distance(a, b) == pytest.approx(numpy_dtw(a, b), rel=1e-12)
        r = int(abs(n - m) + rng.integers(0, 4))
        assert dtw(a, b, band=r)[0] == pytest.approx(numpy_dtw(a, b, r), rel=1e-12)


def test_path_is_monotone_connects_corners_and_realises_the_distance(
    rng: np.random.Generator,
) -> None:
    a, b = rng.normal(size=(25, 2)), rng.normal(size=(17, 2))
    dist, path = dtw(a, b, band=10)
    assert path.dtype == np.int64 and path.shape[1] == 2
    assert tuple(path[0]) == (0, 0) and tuple(path[-1]) == (24, 16)
    steps = np.diff(path, axis=0)
    assert np.all((steps >= 0) & (steps <= 1)) and np.all(steps.sum(axis=1) >= 1)
    assert np.all(np.abs(path[:, 0] - path[:, 1]) <= 10)
    assert np.sqrt(np.sum((a[path[:, 0]] - b[path[:, 1]]) ** 2)) == pytest.approx(dist)


def test_properties(rng: np.random.Generator) -> None:
    a, b = rng.normal(size=(30, 2)), rng.normal(size=(30, 2))
    assert dtw_distance(a, a) == 0.0
    assert dtw_distance(a, b) == pytest.approx(dtw_distance(b, a))
    assert dtw_distance(a, b) <= np.linalg.norm(a - b) + 1e-12
    assert dtw_distance(a, b, band=0) == pytest.approx(np.linalg.norm(a - b))
    # 1-D input is a single column.
    assert dtw_distance(a[:, 0], b[:, 0]) == dtw_distance(a[:, :1], b[:, :1])
    # Non-contiguous and integer input are converted.
    assert dtw_distance(a[::2], b[::2]) == pytest.approx(numpy_dtw(a[::2], b[::2]))
    assert dtw_distance([0, 1, 2], [0, 2]) == pytest.approx(1.0)


def test_align_to_reference_undoes_a_time_warp() -> None:
    reference = np.sin(np.linspace(0, 3, 40))
    slow = np.repeat(reference, 2)  # every sample held twice
    out = align_to_reference(reference, [slow, reference], band=40)
    assert len(out) == 2 and out[0].shape == (40,)
    np.testing.assert_allclose(out[0], reference)
    np.testing.assert_allclose(out[1], reference)
    two = align_to_reference(np.c_[reference, -reference], [np.c_[slow, -slow]])
    assert two[0].shape == (40, 2)


def test_errors() -> None:
    with pytest.raises(EmptySequenceError):
        dtw_distance([], [1.0])
    with pytest.raises(ShapeMismatchError):
        dtw(np.zeros((3, 2)), np.zeros((3, 3)))
    with pytest.raises(ShapeMismatchError):
        dtw(np.zeros((3, 2, 1)), np.zeros((3, 2, 1)))
    with pytest.raises(NonFiniteError, match=r"b\[1, 0\]"):
        dtw_distance([0.0, 1.0], [0.0, np.nan])
    with pytest.raises(InvalidParameterError):
        dtw(np.zeros(10), np.zeros(4), band=5)
    with pytest.raises(InvalidParameterError):
        dtw_distance(np.zeros(4), np.zeros(4), band=-1)
    with pytest.raises(ShapeMismatchError):
        align_to_reference(np.zeros((5, 2)), [np.zeros((5, 3))])


def test_normalize() -> None:
    x = np.array([[0.0, 10.0, 7.0], [1.0, 20.0, 7.0], [2.0, 30.0, 7.0]])
    np.testing.assert_allclose(normalize(x), [[0.0, 0.0, 0.5], [0.5, 0.5, 0.5], [1.0, 1.0, 0.5]])
    np.testing.assert_allclose(normalize([2.0, 4.0, 3.0]), [0.0, 1.0, 0.5])
    # Fixed ranges (scalar or per column), not clipped.
    np.testing.assert_allclose(normalize([-1.0, 3.0], lo=0.0, hi=2.0), [-0.5, 1.5])
    np.testing.assert_allclose(normalize(x[:, :2], lo=[0, 10], hi=[4, 20])[:, 1], [0, 1, 2])
    with pytest.raises(InvalidParameterError):
        normalize(x, lo=0.0)
    with pytest.raises(InvalidParameterError):
        normalize(x, lo=1.0, hi=0.0)
    with pytest.raises(ShapeMismatchError):
        normalize(x, lo=[0, 0], hi=[1, 1])
    with pytest.raises(NonFiniteError):
        normalize([0.0, np.inf])
    with pytest.raises(EmptySequenceError):
        normalize(np.zeros((0, 2)))


@settings(max_examples=60, deadline=None)
@given(
    a=hnp.arrays(np.float64, st.integers(1, 12), elements=st.floats(-100, 100)),
    b=hnp.arrays(np.float64, st.integers(1, 12), elements=st.floats(-100, 100)),
    extra=st.integers(0, 3),
)
def test_matches_numpy_reference_property(a: np.ndarray, b: np.ndarray, extra: int) -> None:
    band = abs(len(a) - len(b)) + extra
    assert dtw_distance(a, b) == pytest.approx(numpy_dtw(a, b), rel=1e-9, abs=1e-9)
    dist, path = dtw(a, b, band=band)
    assert dist == pytest.approx(numpy_dtw(a, b, band), rel=1e-9, abs=1e-9)
    assert np.sqrt(np.sum((a[path[:, 0]] - b[path[:, 1]]) ** 2)) == pytest.approx(
        dist, rel=1e-9, abs=1e-9
    )
