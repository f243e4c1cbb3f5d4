"""lfd.geometry.box_distance, the one distance of a point from an object's box, against brute
force: the nearest of a dense grid of points on the box's surface (rotated by scipy's matrix of
the quaternion, not lfd's formula), and the closest point of the box by clamping."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from lfd.geometry import box_distance, outside_distance
from scipy.spatial.transform import Rotation

coord = st.floats(-0.3, 0.3, allow_nan=False)
edge = st.floats(0.01, 0.2, allow_nan=False)
quat = st.tuples(*[st.floats(-1.0, 1.0, allow_nan=False)] * 4).filter(
    lambda q: np.linalg.norm(q) > 0.1
)
vec = st.tuples(coord, coord, coord)


def surface_grid(size: np.ndarray, k: int = 41) -> np.ndarray:
    """Points ``(m, 3)`` on the faces of an axis-aligned box of ``size`` centred at 0."""
    h = size / 2
    u = np.linspace(-1.0, 1.0, k)
    a, b = np.meshgrid(u, u)
    faces = []
    for axis in range(3):
        i, j = [x for x in range(3) if x != axis]
        for sign in (-1.0, 1.0):
            f = np.empty((a.size, 3))
            f[:, axis] = sign * h[axis]
            f[:, i], f[:, j] = a.ravel() * h[i], b.ravel() * h[j]
            faces.append(f)
    return np.concatenate(faces)


@settings(max_examples=150, deadline=None)
@given(point=vec, centre=vec, q=quat, size=st.tuples(edge, edge, edge))
def test_box_distance_is_the_brute_force_distance(point, centre, q, size) -> None:
    p, c, s = np.array(point), np.array(centre), np.array(size)
    rot = Rotation.from_quat(np.array(q)).as_matrix()  # box -> world
    got = float(box_distance(p[None], c[None], np.array(q)[None], s)[0])

    # exact: the box's closest point to p, found by clamping in the box's frame
    local = rot.T @ (p - c)
    inside = np.all(np.abs(local) <= s / 2)
    closest = np.clip(local, -s / 2, s / 2)
    assert got == (0.0 if inside else got)
    np.testing.assert_allclose(got, np.linalg.norm(local - closest), rtol=1e-9, atol=1e-12)

    # brute force: outside the box, the nearest surface point of a dense grid is at most half
    # a grid cell's diagonal farther than the box
    if not inside:
        world = surface_grid(s) @ rot.T + c
        brute = float(np.min(np.linalg.norm(world - p, axis=1)))
        cell = float(np.linalg.norm(s / 40))
        assert got <= brute + 1e-12
        assert brute <= got + cell / 2 + 1e-12


@settings(max_examples=50, deadline=None)
@given(
    points=st.lists(vec, min_size=1, max_size=6),
    centre=vec,
    q=quat,
    size=st.tuples(edge, edge, edge),
)
def test_box_distance_broadcasts_as_one_point_at_a_time(points, centre, q, size) -> None:
    p = np.array(points)  # (k, 3) against one pose: the (n, k, 3) x (n, 1, 4) of the aperture
    many = box_distance(p[None], np.array(centre)[None, None], np.array(q)[None, None], size)
    one = [box_distance(x[None], np.array(centre)[None], np.array(q)[None], size)[0] for x in p]
    np.testing.assert_array_equal(many[0], one)


def test_a_bad_pose_or_point_gives_nan_without_a_warning() -> None:
    size = np.array([0.04, 0.04, 0.04])
    p = np.array([[0.1, 0.0, 0.0], [0.1, 0.0, 0.0], [np.nan, 0.0, 0.0], [0.1, 0.0, 0.0]])
    c = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [np.nan, 0.0, 0.0]])
    q = np.array([[0, 0, 0, 0], [np.nan, 0, 0, 1], [0, 0, 0, 1], [0, 0, 0, 1]], dtype=float)
    assert np.isnan(box_distance(p, c, q, size)).all()
    ok = box_distance(p[:1], c[:1], np.array([[0.0, 0.0, 0.0, 2.0]]), size)  # not unit: normalised
    np.testing.assert_allclose(ok, [0.08])


@settings(max_examples=100, deadline=None)
@given(x=coord, y=coord, w=edge, d=edge)
def test_outside_distance_of_a_footprint_is_the_2d_distance(x, y, w, d) -> None:
    dx, dy = max(abs(x) - w / 2, 0.0), max(abs(y) - d / 2, 0.0)
    np.testing.assert_allclose(outside_distance([x, y], [w, d]), np.hypot(dx, dy), rtol=1e-12)
