"""``preprocess``: a :class:`~lfd.demo.Demonstration` -> a :class:`~lfd.trajectory.Trajectory`.

0. Confidence: hand keypoints whose confidence is below ``min_keypoint_confidence`` are treated
   as unobserved (NaN); the others are weighted by their confidence when resampled (a keypoint
   the estimator could not see but estimated with enough confidence is kept).
1. Clock: ``rate_hz`` samples spanning the overlap of the hand and every observed object.
2. Resample: hand keypoints (~5 Hz) and object positions (~30 Hz) by cubic splines, object
   orientations by slerp; gaps up to ``max_gap_s`` are interpolated, longer ones stay NaN and
   are reported in ``meta["gaps"]`` and the ``hand_valid`` / ``object_valid`` masks. The
   keypoint spline goes through confidence-weighted nodes
   (:func:`~lfd.preprocessing.resample.weighted_nodes`: a sample of confidence 1 is kept, a
   less confident one is pulled towards its neighbours).
3. Filter (zero-phase 4th-order Butterworth, MATLAB ``filtfilt`` padding): the paper low-passes
   the *feature* signals at 0.625 Hz; the features are computed later (Rust) from positions, so
   here the position signals — keypoints and object centres — are filtered at
   ``feature_cutoff_hz`` (a linear filter commutes with the linear parts of the features; use
   :func:`lowpass` on feature arrays to filter them directly). The gripper Euler angles are
   unwrapped and filtered at ``euler_cutoff_hz``.
4. Map the hand to a gripper (:func:`~lfd.preprocessing.mapping.gripper_frame`): TCP and opening
   from the filtered keypoints, ``rotation`` rebuilt from the filtered Euler angles.
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np

from ..demo import INDEX_MCP, INDEX_TIP, THUMB_TIP, Demonstration
from ..errors import DemonstrationError
from ..trajectory import Trajectory
from .carry import fill_carried_gaps, hold_ends
from .filters import butter_ba, lowpass, matlab_padlen, unwrap_runs
from .grasp import APERTURES, Aperture, grasp_aperture
from .mapping import EULER_SEQ, euler_from_rotation, gripper_frame, rotation_from_euler
from .resample import clock, find_gaps, resample_positions, resample_quaternions

__all__ = ["preprocess"]

GRIPPER_KEYPOINTS = (THUMB_TIP, INDEX_MCP, INDEX_TIP)

MIN_KEYPOINT_CONFIDENCE = 0.3
"""Default ``min_keypoint_confidence`` of :func:`preprocess`: hand keypoints estimated with a
lower confidence are dropped."""

AUTO_CUTOFF_RATIO = 0.4
"""``feature_cutoff_hz="auto"`` filters the hand at this fraction of its sample rate..."""
AUTO_CUTOFF_MAX_HZ = 6.0
"""...and at most at this frequency (hand motion has no skill information above it)."""


def auto_cutoff(hand_rate_hz: float) -> float:
    """The hand's low-pass cut-off for ``feature_cutoff_hz="auto"``: a noisy 5 Hz estimator is
    smoothed at 2 Hz, smooth 30 Hz motion capture kept up to 6 Hz, so a fast grasp or lift keeps
    its shape (docs/segmentation.md measures the choice)."""
    return float(min(AUTO_CUTOFF_MAX_HZ, AUTO_CUTOFF_RATIO * hand_rate_hz))


def _sorted_unique(t_ns: np.ndarray) -> np.ndarray:
    """Indices of strictly increasing timestamps (first of each duplicate)."""
    _, idx = np.unique(t_ns, return_index=True)
    return idx


def _span(t_ns: np.ndarray, valid: np.ndarray) -> tuple[int, int] | None:
    t = t_ns[valid]
    return (int(t.min()), int(t.max())) if t.size else None


def preprocess(
    demo: Demonstration,
    *,
    rate_hz: float = 30.0,
    euler_cutoff_hz: float = 0.0625,
    feature_cutoff_hz: float | Literal["auto"] = 0.625,
    object_cutoff_hz: float | None = None,
    aperture: Aperture = "grasp",
    max_gap_s: float = 0.5,
    fill_hidden: bool = True,
    filter: bool = True,
    min_keypoint_confidence: float = MIN_KEYPOINT_CONFIDENCE,
) -> Trajectory:
    """Resample, filter and map a demonstration to a gripper trajectory on one clock.

    Parameters
    ----------
    demo : Demonstration
        Hand keypoints and object poses on their own timestamps.
    rate_hz : float
        Rate of the common clock.
    euler_cutoff_hz : float
        Low-pass cut-off of the gripper Euler angles (paper: 0.0625 Hz).
    feature_cutoff_hz : float or "auto"
        Low-pass cut-off of the hand keypoints the features come from (paper: 0.625 Hz);
        ``"auto"``: :func:`auto_cutoff` of the hand's median sample rate (2 Hz for a 5 Hz
        hand-pose estimator, 6 Hz for 30 Hz motion capture).
    object_cutoff_hz : float, optional
        Low-pass cut-off of the object positions; ``None``: ``feature_cutoff_hz`` (the paper
        filters every position signal alike). Tag and motion-capture poses are smooth already,
        and a hard filter lowers a fast lift and shifts a resting object's height
        (docs/segmentation.md measures both).
    aperture : {"grasp", "thumb_index"}
        What :attr:`Trajectory.opening` measures: the grasp aperture of
        :func:`~lfd.preprocessing.grasp.grasp_aperture` (the fingers that oppose the thumb on a
        box, whichever they are) or Table I's thumb-index distance.
    max_gap_s : float
        Longest gap between real samples that is interpolated.
    fill_hidden : bool
        Fill what the camera could not see of an object (see :mod:`lfd.preprocessing.carry`): held
        at rest before its first and after its last sighting (the clock then spans the hand),
        and carried with the TCP through a long gap in which the hand moved it. Otherwise the
        clock spans only the time every object was seen and long gaps stay NaN.
    filter : bool
        Apply the low-pass filters.
    min_keypoint_confidence : float
        Hand keypoints with a lower confidence (``demo.hand.confidence``) are treated as
        unobserved; the kept ones are weighted by their confidence when resampled (confidence
        1: interpolated exactly, as without weights). Keypoints the estimator marked not
        visible but estimated above the threshold are kept. ``0``: confidence is ignored.

    Returns
    -------
    Trajectory
        ``meta`` holds the parameters, ``gaps`` (``{"hand": [(t0, t1)], "objects": {name:
        [...]}, "carried": {name: [...]}}`` in ns; ``carried`` lists the object gaps filled from
        the hand, ``held`` the stretches held at rest), ``unfiltered_runs``,
        ``low_confidence`` (``keypoints`` dropped, hand ``samples`` that lost any keypoint and
        ``gripper_samples`` that lost a thumb tip, index tip or index base, so give no TCP) and
        the demonstration's labels and metadata.

    Raises
    ------
    DemonstrationError
        No overlap between the hand and the objects, no valid hand sample, or a demonstration
        too short to filter (not more than 12 samples on the clock).
    """
    if not demo.objects:
        raise DemonstrationError("demonstration has no objects")
    if aperture not in APERTURES:
        raise DemonstrationError(
            f"aperture must be one of {', '.join(APERTURES)}, got {aperture!r}"
        )
    if not (0.0 <= min_keypoint_confidence <= 1.0):
        raise DemonstrationError(
            f"min_keypoint_confidence must be in [0, 1], got {min_keypoint_confidence!r}"
        )
    hand = demo.hand
    if feature_cutoff_hz == "auto":
        steps = np.diff(np.unique(hand.t_ns)) * 1e-9
        hand_fc = auto_cutoff(1.0 / float(np.median(steps))) if steps.size else AUTO_CUTOFF_MAX_HZ
    else:
        hand_fc = float(feature_cutoff_hz)
    obj_fc = hand_fc if object_cutoff_hz is None else float(object_cutoff_hz)
    hi = _sorted_unique(hand.t_ns)
    h_t, h_kp = hand.t_ns[hi], hand.keypoints[hi]
    h_weights: np.ndarray | None = None
    low = np.zeros(h_kp.shape[:2], dtype=bool)
    if min_keypoint_confidence > 0:
        h_conf = hand.confidence[hi]
        low = np.isfinite(h_kp).all(axis=2) & (h_conf < min_keypoint_confidence)
        h_kp = np.where(low[:, :, None], np.nan, h_kp)
        h_weights = np.where(low, 1.0, h_conf)[:, :, None]  # dropped samples carry no weight
    low_confidence = {
        "keypoints": int(low.sum()),
        "samples": int(low.any(axis=1).sum()),
        "gripper_samples": int(low[:, list(GRIPPER_KEYPOINTS)].any(axis=1).sum()),
    }
    h_ok = np.isfinite(h_kp[:, list(GRIPPER_KEYPOINTS)]).all(axis=(1, 2))
    spans = [("hand", _span(h_t, h_ok))]
    objs = []
    for name, obj in demo.objects.items():
        oi = _sorted_unique(obj.t_ns)
        ok = obj.visible[oi] & np.isfinite(obj.position[oi]).all(axis=1)
        objs.append((name, obj, oi, ok))
        if ok.any():
            spans.append((name, _span(obj.t_ns[oi], ok)))
    if spans[0][1] is None:
        raise DemonstrationError("the hand has no sample with index tip, thumb tip and index base")
    if len(spans) == 1:
        raise DemonstrationError("no object was ever visible")
    if fill_hidden:  # objects are held at rest before they are first / after they are last seen
        obj_spans = [s[1] for s in spans[1:] if s[1] is not None]
        start = max(spans[0][1][0], min(s[0] for s in obj_spans))
        end = min(spans[0][1][1], max(s[1] for s in obj_spans))
    else:
        start = max(s[1][0] for s in spans if s[1] is not None)
        end = min(s[1][1] for s in spans if s[1] is not None)
    if end <= start:
        raise DemonstrationError(
            "the hand and the objects do not overlap in time: spans (s) "
            + ", ".join(
                f"{n} {(s[0] - demo.start_ns) * 1e-9:.2f}-{(s[1] - demo.start_ns) * 1e-9:.2f}"
                for n, s in spans
                if s is not None
            )
        )
    t_ns = clock(start, end, rate_hz)
    n = t_ns.size
    if filter:
        pad = max(
            matlab_padlen(*butter_ba(hand_fc, rate_hz)),
            matlab_padlen(*butter_ba(obj_fc, rate_hz)),
            matlab_padlen(*butter_ba(euler_cutoff_hz, rate_hz)),
        )
        if n <= pad:
            raise DemonstrationError(
                f"demonstration too short to filter: {n} samples at {rate_hz} Hz over the "
                f"hand/object overlap ({(end - start) * 1e-9:.2f} s); needs more than {pad}"
            )
    t_s = (t_ns - start) * 1e-9

    def rel(t: np.ndarray) -> np.ndarray:
        return (t - start) * 1e-9

    unfiltered: dict[str, list[tuple[int, int]]] = {}

    def smooth(x: np.ndarray, fc: float, what: str) -> np.ndarray:
        if not filter:
            return x
        report: list[tuple[int, int]] = []
        y = lowpass(x, fc, rate_hz, report=report)
        if report:
            unfiltered[what] = [(int(t_ns[a]), int(t_ns[b - 1])) for a, b in report]
        return y

    # hand
    kp, kp_valid = resample_positions(rel(h_t), h_kp, t_s, max_gap_s=max_gap_s, weights=h_weights)
    hand_valid = kp_valid[:, list(GRIPPER_KEYPOINTS)].all(axis=(1, 2))
    kp = smooth(kp, hand_fc, "keypoints")
    tcp, rot_raw, opening = gripper_frame(kp, side=hand.side)
    hand_valid &= np.isfinite(rot_raw).all(axis=(1, 2))
    euler = unwrap_runs(euler_from_rotation(rot_raw))
    euler[~hand_valid] = np.nan
    euler = smooth(euler, euler_cutoff_hz, "euler")
    rotation = rotation_from_euler(euler)
    tcp[~hand_valid] = np.nan
    opening[~hand_valid] = np.nan

    # objects
    k = len(objs)
    positions = np.full((k, n, 3), np.nan)
    quats = np.full((k, n, 4), np.nan)
    obj_valid = np.zeros((k, n), dtype=bool)
    gaps: dict[str, Any] = {
        "hand": find_gaps(h_t, h_ok, max_gap_s),
        "objects": {},
        "carried": {},  # object gaps filled because the hand carried the object
        "held": {},  # before the first / after the last sighting: held at rest
    }
    for j, (name, obj, oi, ok) in enumerate(objs):
        ot = obj.t_ns[oi]
        pos = np.where(ok[:, None], obj.position[oi], np.nan)
        quat = np.where(ok[:, None], obj.quaternion[oi], np.nan)
        p, pv = resample_positions(rel(ot), pos, t_s, max_gap_s=max_gap_s)
        q, qv = resample_quaternions(rel(ot), quat, t_s, max_gap_s=max_gap_s)
        valid = pv.all(axis=1) & qv
        if fill_hidden and valid.any():
            p = np.where(valid[:, None], p, np.nan)
            q = np.where(valid[:, None], q, np.nan)
            held = hold_ends(p, q, valid)
            if held:
                gaps["held"][name] = [(int(t_ns[a]), int(t_ns[b - 1])) for a, b in held]
            radius = float(np.max(obj.size)) / 2 + 0.03
            carried = fill_carried_gaps(p, q, valid, tcp, hand_valid, radius)
            if carried:
                gaps["carried"][name] = [(int(t_ns[a]), int(t_ns[b - 1])) for a, b in carried]
        positions[j] = smooth(np.where(valid[:, None], p, np.nan), obj_fc, name)
        quats[j] = np.where(valid[:, None], q, np.nan)
        obj_valid[j] = valid
        gaps["objects"][name] = find_gaps(ot, ok, max_gap_s)

    sizes = np.array([obj.size for _, obj, _, _ in objs], dtype=np.float64).reshape(k, 3)
    if aperture == "grasp":
        opening = grasp_aperture(kp, positions, quats, sizes)
        opening[~hand_valid] = np.nan

    meta: dict[str, Any] = {
        "rate_hz": rate_hz,
        "euler_cutoff_hz": euler_cutoff_hz,
        "feature_cutoff_hz": feature_cutoff_hz,
        "object_cutoff_hz": object_cutoff_hz,
        "hand_filter_hz": hand_fc,
        "object_filter_hz": obj_fc,
        "aperture": aperture,
        "max_gap_s": max_gap_s,
        "min_keypoint_confidence": min_keypoint_confidence,
        "low_confidence": low_confidence,
        "filtered": filter,
        "filter": "butter(4) + filtfilt, MATLAB padding; keypoints at hand_filter_hz, "
        "object positions at object_filter_hz",
        "euler_seq": EULER_SEQ,
        "gaps": gaps,
        "unfiltered_runs": unfiltered,
        "labels": [(lab.skill, lab.start_ns, lab.end_ns, lab.object) for lab in demo.labels],
        "demo_metadata": {k: v for k, v in demo.metadata.items() if k != "load_report"},
    }
    return Trajectory(
        t_ns=t_ns,
        tcp=tcp,
        rotation=rotation,
        euler=euler,
        opening=opening,
        keypoints=kp,
        object_names=[name for name, *_ in objs],
        object_position=positions,
        object_quaternion=quats,
        object_size=sizes,
        hand_valid=hand_valid,
        object_valid=obj_valid,
        meta=meta,
    )
