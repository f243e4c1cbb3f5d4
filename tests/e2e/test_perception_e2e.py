"""End to end: simulate -> render -> perceive -> segment equals segmenting the true keypoints.

Each case renders a whole simulated demonstration, perceives it like ``lfd record --source sim:``
(tags from the colour image + depth, the hand from the shipped depth network at 5 Hz) and
segments the recording. The cases are fixed seeds chosen before measuring (one per experiment);
``benches/perception_e2e.py`` runs the same comparison on more seeds.
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("mujoco")
pytest.importorskip("cv2")
pytest.importorskip("torch")

# renders and perceives four whole demonstrations (~40 s each)
pytestmark = pytest.mark.slow

CASES = [("exp1", 11), ("exp2", 11), ("exp3", 11), ("exp4", 11)]
SEGMENT = {"search": "dp", "grammar": "enforce"}


@pytest.fixture(scope="module")
def estimator():  # type: ignore[no-untyped-def]
    from lfd.perception.hand.infer import HandEstimator

    return HandEstimator(threads=2)


@pytest.mark.parametrize(("task", "seed"), CASES)
def test_perceived_recording_segments_like_the_true_keypoints(  # type: ignore[no-untyped-def]
    task, seed, tmp_path, estimator
) -> None:
    import lfd
    from lfd.io import load
    from lfd.perception.record import record
    from lfd.perception.sources import SimSource
    from lfd.segmentation.metrics import boundary_error
    from lfd.sim import truth_demonstration

    src = SimSource(task, seed=seed)
    result = src.result
    out = tmp_path / "perceived.mcap"
    stats = record(src, out, estimator=estimator)
    assert stats.frames == result.truth.t_ns.size and not stats.interrupted
    demo = load(out)

    # the perceived hand is close to the truth at its own (5 Hz) times
    idx = np.searchsorted(result.truth.t_ns, demo.hand.t_ns)
    found = np.all(np.isfinite(demo.hand.keypoints), axis=(1, 2))
    assert found.mean() > 0.9
    err = np.linalg.norm(demo.hand.keypoints[found] - result.truth.keypoints[idx[found]], axis=2)
    assert np.median(err.mean(axis=1)) < 0.015

    truth = lfd.segment(truth_demonstration(result, demo.hand.t_ns), **SEGMENT)
    assert truth.skill_sequence == result.demo.skill_sequence  # the truth itself segments right
    perceived = lfd.segment(demo, **SEGMENT)
    assert perceived.skill_sequence == truth.skill_sequence
    assert boundary_error(perceived.segments, result.demo.labels) < 0.5
