"""Perception: tag poses on rendered frames, ``lfd record`` sources, the hand network."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("mujoco")
pytest.importorskip("cv2")

from lfd.errors import LfdError
from lfd.perception.markers import MarkerConfig, MarkerTracker, TaggedBox


@pytest.fixture(scope="module")
def rendered():  # type: ignore[no-untyped-def]
    from lfd.sim import simulate
    from lfd.sim.render import render_frames

    r = simulate("exp1", seed=0)
    frames = np.linspace(0, r.truth.t_ns.size - 1, 8).astype(int)
    color, depth = render_frames(r.scene, r.truth, frames)
    return r, frames, color, depth


def _errors(r, frames, color, depth, use_depth):  # type: ignore[no-untyped-def]
    from scipy.spatial.transform import Rotation

    cfg = MarkerConfig.from_objects(r.scene.objects, use_depth=use_depth)
    trk = MarkerTracker(cfg, r.demo.camera.K)
    pos, ang = [], []
    for k, i in enumerate(frames):
        seen = trk.process(color.frames[k], None if depth is None else depth.frames[k])
        for name, (p, q) in seen.poses.items():
            pos.append(np.linalg.norm(p - r.truth.object_pos[name][i]))
            rt = Rotation.from_euler("z", r.truth.object_yaw[name][i])
            ang.append(np.rad2deg((rt.inv() * Rotation.from_quat(q)).magnitude()))
    return np.array(pos), np.array(ang)


def test_marker_pose_error_on_rendered_frames(rendered) -> None:  # type: ignore[no-untyped-def]
    pos, ang = _errors(*rendered, use_depth=True)
    assert pos.size >= 6  # boxes seen once the reference marker was seen
    assert pos.max() < 0.005
    assert ang.max() < 2.5
    assert np.mean(ang) < 2.0


def test_depth_refinement_beats_pnp_alone(rendered) -> None:  # type: ignore[no-untyped-def]
    pos_d, _ = _errors(*rendered, use_depth=True)
    pos_c, _ = _errors(*rendered, use_depth=False)
    assert np.mean(pos_d) < 0.5 * np.mean(pos_c)


def test_missing_tags_are_not_invented(rendered) -> None:  # type: ignore[no-untyped-def]
    r, _, color, depth = rendered
    trk = MarkerTracker(MarkerConfig.from_objects(r.scene.objects), r.demo.camera.K)
    blank = np.full_like(color.frames[0], 200)
    seen = trk.process(blank, depth.frames[0])
    assert seen.poses == {} and not seen.reference_seen


def test_marker_config_rejects_bad_input() -> None:
    with pytest.raises(LfdError):
        MarkerConfig(boxes=(TaggedBox("a", 0, (0.05, 0.05, 0.05)),))
    with pytest.raises(LfdError):
        MarkerTracker(MarkerConfig(boxes=(), dictionary="DICT_NOPE"), np.eye(3))
