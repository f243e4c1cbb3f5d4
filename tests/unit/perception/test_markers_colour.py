"""Box tags from colour alone: the table and the other boxes bound a tag's distance, and the
upright one of two ambiguous PnP solutions is kept (``lfd.perception.markers``)."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("cv2")

from lfd.perception.markers import MarkerConfig, MarkerTracker, TaggedBox, _square

K = np.array([[615.0, 0.0, 319.5], [0.0, 615.0, 239.5], [0.0, 0.0, 1.0]])
BOX = TaggedBox("box_1", 1, (0.05, 0.05, 0.05))
BASE = TaggedBox("box_2", 2, (0.06, 0.06, 0.07))


def _world_T_camera() -> np.ndarray:
    """A camera 0.62 m behind and 0.64 m above the origin, looking down at it (OpenCV axes)."""
    eye, target = np.array([0.0, 0.62, 0.64]), np.array([0.0, 0.2, 0.0])
    z = (target - eye) / np.linalg.norm(target - eye)
    x = np.cross(z, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    T = np.eye(4)
    T[:3, :3] = np.column_stack([x, np.cross(z, x), z])
    T[:3, 3] = eye
    return T


def _tracker() -> MarkerTracker:
    cfg = MarkerConfig(boxes=(BOX, BASE), use_depth=False)
    return MarkerTracker(cfg, K, world_T_camera=_world_T_camera())


def _camera_T_tag(centre: np.ndarray, height: float, yaw: float = 0.3) -> np.ndarray:
    """The tag on the top face of an upright box centred at ``centre`` (world)."""
    c, s = np.cos(yaw), np.sin(yaw)
    W = np.eye(4)
    W[:3, :3] = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
    W[:3, 3] = centre + np.array([0.0, 0.0, height / 2.0])
    return np.linalg.inv(_world_T_camera()) @ W


def _too_far(T: np.ndarray, factor: float) -> np.ndarray:
    """``T`` moved along its viewing ray (as PnP does with a partly covered tag)."""
    out = T.copy()
    out[:3, 3] *= factor
    return out


def _pixel(T: np.ndarray) -> np.ndarray:
    p = T[:3, 3]
    return np.asarray(p[:2] / p[2] * [K[0, 0], K[1, 1]] + K[:2, 2])


def test_a_box_sunk_into_the_table_is_raised_along_its_ray() -> None:
    trk = _tracker()
    truth = _camera_T_tag(np.array([0.05, 0.2, 0.025]), 0.05)
    seen = _too_far(truth, 1.08)  # 6 cm farther: the box 4 cm into the table
    out = trk._supported(BOX, seen)
    assert np.linalg.norm(out[:3, 3] - truth[:3, 3]) < 0.002
    assert np.allclose(_pixel(out), _pixel(seen))  # the tag still projects where it was seen


def test_a_lifted_box_and_a_box_within_tolerance_are_left_alone() -> None:
    trk = _tracker()
    lifted = _camera_T_tag(np.array([0.05, 0.2, 0.06]), 0.05)
    assert np.array_equal(trk._supported(BOX, lifted), lifted)
    resting = _camera_T_tag(np.array([0.05, 0.2, 0.025]), 0.05)
    slightly = _too_far(resting, 1.004)  # 2 mm into the table: PnP's own error
    assert np.array_equal(trk._supported(BOX, slightly), slightly)


def test_a_box_sunk_into_the_box_under_it_is_put_on_top() -> None:
    trk = _tracker()
    base = np.array([0.1, 0.25, 0.035])
    trk._last_box["box_2"] = (base, np.eye(3))
    truth = _camera_T_tag(base + np.array([0.0, 0.0, 0.06]), 0.05)  # stacked on box_2
    out = trk._supported(BOX, _too_far(truth, 1.12))
    assert np.linalg.norm(out[:3, 3] - truth[:3, 3]) < 0.003
    # without box_2 known, only the table bounds it: it would stand beside box_2, inside it
    alone = _tracker()._supported(BOX, _too_far(truth, 1.12))
    assert np.linalg.norm(alone[:3, 3] - truth[:3, 3]) > 0.03


def test_a_box_standing_behind_another_stays_there() -> None:
    trk = _tracker()
    trk._last_box["box_2"] = (np.array([0.05, 0.3, 0.035]), np.eye(3))
    behind = _camera_T_tag(np.array([0.05, 0.2, 0.025]), 0.05)  # on the table, farther away
    assert np.array_equal(trk._supported(BOX, behind), behind)


def test_the_upright_one_of_two_ambiguous_pnp_solutions_is_kept() -> None:
    import cv2

    trk = _tracker()
    side = 0.042
    obj = _square(side)
    truth = _camera_T_tag(np.array([0.12, 0.15, 0.025]), 0.05)
    corners = obj @ truth[:3, :3].T + truth[:3, 3]
    px = corners[:, :2] / corners[:, 2:] * [K[0, 0], K[1, 1]] + K[:2, 2]
    px = px + np.random.default_rng(0).normal(0.0, 0.3, px.shape)  # detector noise
    n, rvecs, tvecs, errs = cv2.solvePnPGeneric(obj, px, K, None, flags=cv2.SOLVEPNP_IPPE_SQUARE)
    errs = np.ravel(errs)
    assert n == 2 and abs(errs[0] - errs[1]) < 1.0  # ambiguous
    up = _world_T_camera()[2, :3]
    tilts = []
    for rvec, tvec in zip(rvecs, tvecs, strict=True):
        S = np.eye(4)
        S[:3, :3] = cv2.Rodrigues(rvec)[0]
        S[:3, 3] = tvec.ravel()
        tilts.append((float(np.degrees(np.arccos(np.clip(S[:3, 2] @ up, -1, 1)))), S))
    (_, upright), (tilt, mirror) = sorted(tilts, key=lambda x: x[0])
    assert tilt > 20.0  # the mirror solution is far from upright
    out = trk._upright(obj, px, mirror)  # PnP handed the mirror
    assert np.allclose(out, upright)
    assert np.degrees(np.arccos(out[:3, 2] @ up)) < 5.0
