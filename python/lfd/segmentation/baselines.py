"""The paper's two baselines (Sec. IV-B, Fig. 9-10), each watching a single feature.

**Proximity-area based** (:func:`proximity_segmentation`): a boundary wherever the set of objects
whose proximity region (``|TCP - p_i| < d_i / 2 + gamma``, Table I) contains the TCP changes.
Labelling, the best a proximity signal plus the grasp/release alternation of the grammar allows:
a segment outside every region is ``move`` (``move_with`` while holding); entering a region while
not holding is a ``pick_up`` (then holding); entering one while holding is a ``place``, or a
``stack`` when the TCP is in the regions of two objects at once (then not holding). A ``push``
or ``locate`` cannot be told from a ``pick_up`` by proximity alone.

**Gripper-distance based** (:func:`gripper_segmentation`): a boundary wherever the fingertip
distance crosses ``d_i + gamma`` of the target object. A closed segment is ``move_with`` (the
hand holds the object); an open segment followed by a closed one is a ``pick_up`` (it ends in a
grasp), any other open segment a ``move``. Place, stack, push and locate leave no trace.

Both use the same hysteresis and minimum section length as stage 1.
"""

from __future__ import annotations

import itertools

import numpy as np

from ..demo import Demonstration
from ..trajectory import Trajectory
from .drafts import _make_segment
from .gaps import fill_gaps
from .pipeline import as_trajectory
from .result import Segmentation
from .stage1 import Stage1Params

GAMMA = 0.02
"""The offset ``gamma`` of Table I (metres), as in :mod:`lfd.features`."""


def _runs(state: np.ndarray, min_len: int) -> list[tuple[int, int]]:
    """Runs of equal ``state`` with runs shorter than ``min_len`` merged into the previous one."""
    n = state.shape[0]
    cuts = [0] + [t for t in range(1, n) if state[t] != state[t - 1]]
    kept = [0]
    for c in cuts[1:]:
        if c - kept[-1] >= min_len and n - c >= min_len:
            kept.append(c)
    kept.append(n)
    return list(itertools.pairwise(kept))


def _majority(state: np.ndarray, a: int, b: int) -> int:
    vals, counts = np.unique(state[a:b], return_counts=True)
    return int(vals[np.argmax(counts)])


def proximity_segmentation(
    demo_or_traj: Demonstration | Trajectory, *, stage1: Stage1Params | None = None
) -> Segmentation:
    """Segment where the TCP enters or leaves an object's proximity region (see module docs)."""
    from ..features import compute_features

    traj, warnings = fill_gaps(as_trajectory(demo_or_traj))
    p = stage1 or Stage1Params()
    feats = compute_features(traj)
    d = np.maximum(traj.object_size[:, 0], traj.object_size[:, 1])
    dist = np.linalg.norm(traj.object_position - traj.tcp[None, :, :], axis=2)  # (k, n)
    inside = dist < (0.5 * d + GAMMA)[:, None]
    code = np.zeros(len(traj), dtype=np.int64)
    for k in range(inside.shape[0]):
        code |= inside[k].astype(np.int64) << k
    min_len = max(1, round(p.min_section_s / traj.dt))
    segments = []
    holding = False
    for a, b in _runs(code, min_len):
        c = _majority(code, a, b)
        n_in = bin(c).count("1")
        if n_in == 0:
            skill = "move_with" if holding else "move"
        elif not holding:
            skill, holding = "pick_up", True
        else:
            skill, holding = ("stack" if n_in >= 2 else "place"), False
        segments.append(_make_segment(traj, skill, a, b, feats.target))
    return Segmentation(segments, warnings, "proximity", [], list(traj.object_names))


def gripper_segmentation(
    demo_or_traj: Demonstration | Trajectory, *, stage1: Stage1Params | None = None
) -> Segmentation:
    """Segment where the fingertip distance crosses ``d_i + gamma`` (see module docs)."""
    from ..features import compute_features

    traj, warnings = fill_gaps(as_trajectory(demo_or_traj))
    p = stage1 or Stage1Params()
    feats = compute_features(traj)
    opening = np.asarray(feats.values[:, 0], dtype=np.float64)
    thr = np.asarray(feats.thresholds[:, 0], dtype=np.float64)
    # hysteresis: the state flips only outside the band thr +- h
    closed = np.zeros(len(traj), dtype=bool)
    state = bool(opening[0] < thr[0])
    for t in range(len(traj)):
        if state and opening[t] > thr[t] + p.opening_hysteresis:
            state = False
        elif not state and opening[t] < thr[t] - p.opening_hysteresis:
            state = True
        closed[t] = state
    min_len = max(1, round(p.min_section_s / traj.dt))
    runs = _runs(closed.astype(np.int64), min_len)
    is_closed = [bool(_majority(closed.astype(np.int64), a, b)) for a, b in runs]
    segments = []
    for n, (a, b) in enumerate(runs):
        if is_closed[n]:
            skill = "move_with"
        elif n + 1 < len(runs) and is_closed[n + 1]:
            skill = "pick_up"
        else:
            skill = "move"
        segments.append(_make_segment(traj, skill, a, b, feats.target))
    return Segmentation(segments, warnings, "gripper", [], list(traj.object_names))
