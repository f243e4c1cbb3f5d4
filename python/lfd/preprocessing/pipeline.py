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

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from ..demo import (
    INDEX_MCP,
    INDEX_TIP,
    THUMB_TIP,
    CameraInfo,
    Demonstration,
    HandTrack,
    ObjectTrack,
)
from ..errors import DemonstrationError
from ..trajectory import Trajectory
from .carry import (
    EMPTY_S,
    REST_TOLERANCE,
    SIGHT_MARGIN_M,
    carry_open_end,
    covered,
    fill_carried_gaps,
    hold_ends,
    in_clear_view,
    occluders,
    seen_empty,
)
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
"""...and at most at this frequency (hand motion has no skill information above it)..."""
COLOUR_CUTOFF_HZ = 2.0
"""...and at most at this frequency for a hand placed from colour alone (the recording's
metadata says ``"depth": false``: a webcam or a video, ``lfd record --source video:``). Its
distance along the viewing ray comes from its size in the image and jitters by about a
centimetre from frame to frame however often it is sampled, like the 5 Hz estimator's hand
(docs/perception.md measures the choice)."""


def auto_cutoff(hand_rate_hz: float, colour_only: bool = False) -> float:
    """The hand's low-pass cut-off for ``feature_cutoff_hz="auto"``: a noisy 5 Hz estimator is
    smoothed at 2 Hz, smooth 30 Hz motion capture kept up to 6 Hz, so a fast grasp or lift keeps
    its shape (docs/segmentation.md measures the choice); a hand placed from colour alone
    (``colour_only``) at most :data:`COLOUR_CUTOFF_HZ` whatever its rate."""
    fc = min(AUTO_CUTOFF_MAX_HZ, AUTO_CUTOFF_RATIO * hand_rate_hz)
    return float(min(fc, COLOUR_CUTOFF_HZ) if colour_only else fc)


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
    complete: bool = True,
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
    complete : bool
        The recording is complete (default). False for a recording still being made (the live
        segmentation's runs): with ``fill_hidden``, an object hidden since the hand reached it
        follows the TCP (:func:`~lfd.preprocessing.carry.carry_open_end`) instead of being held
        where it was last seen, unless another object now rests on that place (the covered
        base of a stack: :func:`~lfd.preprocessing.carry.covered`).
        A complete recording holds an object never seen again at rest where it was last seen,
        unless the camera (``demo.camera``) saw that place empty: its tag not there while
        nothing hid it (:func:`~lfd.preprocessing.carry.in_clear_view`); then the hand that
        reached it carried it on.

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
    _check_options(demo, aperture, min_keypoint_confidence)
    hand_fc = _hand_cutoff(demo, feature_cutoff_hz)
    obj_fc = hand_fc if object_cutoff_hz is None else float(object_cutoff_hz)
    hand = _hand_samples(demo.hand, min_keypoint_confidence)
    objs = _object_samples(demo)
    start, end = _overlap(demo, hand, objs, fill_hidden)
    t_ns = clock(start, end, rate_hz)
    if filter:
        _check_filterable(t_ns.size, rate_hz, (hand_fc, obj_fc, euler_cutoff_hz), end - start)
    smooth = _Smoother(t_ns, rate_hz, filter)
    t_s = (t_ns - start) * 1e-9
    g = _gripper_track(
        hand, demo.hand.side, start, t_s, max_gap_s, hand_fc, euler_cutoff_hz, smooth
    )
    others = [_other_hand(h, start, t_s, max_gap_s) for h in demo.occluders]
    open_end = _OpenEnd("evident" if complete else "carried", demo.camera, rate_hz, others)
    o = _object_tracks(objs, hand, g, start, t_ns, max_gap_s, obj_fc, fill_hidden, smooth, open_end)
    opening = g.opening
    if aperture == "grasp":
        opening = grasp_aperture(g.keypoints, o.position, o.quaternion, o.size)
        opening[~g.valid] = np.nan
    options = {  # the meta's first keys: the options, with the filters chosen
        "rate_hz": rate_hz,
        "euler_cutoff_hz": euler_cutoff_hz,
        "feature_cutoff_hz": feature_cutoff_hz,
        "object_cutoff_hz": object_cutoff_hz,
        "hand_filter_hz": hand_fc,
        "object_filter_hz": obj_fc,
        "aperture": aperture,
        "max_gap_s": max_gap_s,
        "min_keypoint_confidence": min_keypoint_confidence,
    }
    meta = _meta(demo, options, hand, o, smooth, filter)
    return _trajectory(t_ns, g, o, objs, opening, meta)


def _meta(
    demo: Demonstration,
    options: dict[str, Any],
    hand: _HandSamples,
    o: _ObjectTracks,
    smooth: _Smoother,
    filtered: bool,
) -> dict[str, Any]:
    """The trajectory's ``meta``: the ``options`` of :func:`preprocess` and the filters it
    chose, then what was dropped, filled and left unfiltered, and the demonstration's labels
    and metadata."""
    return {
        **options,
        "low_confidence": hand.low_confidence,
        "filtered": filtered,
        "filter": "butter(4) + filtfilt, MATLAB padding; keypoints at hand_filter_hz, "
        "object positions at object_filter_hz",
        "euler_seq": EULER_SEQ,
        "gaps": o.gaps,
        "unfiltered_runs": smooth.unfiltered,
        "labels": [(lab.skill, lab.start_ns, lab.end_ns, lab.object) for lab in demo.labels],
        "demo_metadata": {k: v for k, v in demo.metadata.items() if k != "load_report"},
    }


def _trajectory(
    t_ns: np.ndarray,
    g: _GripperTrack,
    o: _ObjectTracks,
    objs: list[_ObjectSamples],
    opening: np.ndarray,
    meta: dict[str, Any],
) -> Trajectory:
    return Trajectory(
        t_ns=t_ns,
        tcp=g.tcp,
        rotation=g.rotation,
        euler=g.euler,
        opening=opening,
        keypoints=g.keypoints,
        object_names=[ob.name for ob in objs],
        object_position=o.position,
        object_quaternion=o.quaternion,
        object_size=o.size,
        hand_valid=g.valid,
        object_valid=o.valid,
        meta=meta,
    )


# --- the steps of preprocess -------------------------------------------------------------
def _check_options(demo: Demonstration, aperture: str, min_keypoint_confidence: float) -> None:
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


def _hand_cutoff(demo: Demonstration, feature_cutoff_hz: float | Literal["auto"]) -> float:
    """The hand's low-pass cut-off: ``feature_cutoff_hz`` or :func:`auto_cutoff` of its rate
    (and of whether it was placed from colour alone: metadata ``"depth": false``)."""
    if feature_cutoff_hz != "auto":
        return float(feature_cutoff_hz)
    steps = np.diff(np.unique(demo.hand.t_ns)) * 1e-9
    rate = 1.0 / float(np.median(steps)) if steps.size else np.inf
    return auto_cutoff(rate, colour_only=demo.metadata.get("depth") is False)


@dataclass
class _HandSamples:
    """The hand's samples in time order, low-confidence keypoints dropped (step 0)."""

    t_ns: np.ndarray
    keypoints: np.ndarray
    weights: np.ndarray | None
    """Resampling weights (n, 21, 1), None when confidence is ignored."""
    ok: np.ndarray
    """Samples with the three gripper keypoints."""
    low_confidence: dict[str, int]

    @property
    def span(self) -> tuple[int, int] | None:
        return _span(self.t_ns, self.ok)

    def take_points(self) -> tuple[np.ndarray, np.ndarray | None]:
        """The keypoints and the weights, dropped from here (once resampled they are not
        needed: an hour of a 30 Hz hand holds 73 MB in them)."""
        kp, w = self.keypoints, self.weights
        self.keypoints, self.weights = kp[:0], None
        return kp, w


def _hand_samples(hand: HandTrack, min_keypoint_confidence: float) -> _HandSamples:
    hi = _sorted_unique(hand.t_ns)
    h_t, h_kp = hand.t_ns[hi], hand.keypoints[hi]
    h_weights: np.ndarray | None = None
    low = np.zeros(h_kp.shape[:2], dtype=bool)
    if min_keypoint_confidence > 0:
        h_conf = hand.confidence[hi]
        low = np.isfinite(h_kp).all(axis=2) & (h_conf < min_keypoint_confidence)
        h_kp = h_kp.copy()  # (np.where over the broadcast mask is ten times slower)
        np.copyto(h_kp, np.nan, where=low[:, :, None])
        h_weights = np.where(low, 1.0, h_conf)[:, :, None]  # dropped samples carry no weight
    low_confidence = {
        "keypoints": int(low.sum()),
        "samples": int(low.any(axis=1).sum()),
        "gripper_samples": int(low[:, list(GRIPPER_KEYPOINTS)].any(axis=1).sum()),
    }
    h_ok = np.isfinite(h_kp[:, list(GRIPPER_KEYPOINTS)]).all(axis=(1, 2))
    return _HandSamples(h_t, h_kp, h_weights, h_ok, low_confidence)


@dataclass
class _ObjectSamples:
    """One object's samples: ``order`` sorts them in time, ``ok`` marks the seen ones."""

    name: str
    track: ObjectTrack
    order: np.ndarray
    ok: np.ndarray

    @property
    def span(self) -> tuple[int, int] | None:
        return _span(self.track.t_ns[self.order], self.ok) if self.ok.any() else None


def _object_samples(demo: Demonstration) -> list[_ObjectSamples]:
    objs = []
    for name, obj in demo.objects.items():
        oi = _sorted_unique(obj.t_ns)
        ok = obj.visible[oi] & np.isfinite(obj.position[oi]).all(axis=1)
        objs.append(_ObjectSamples(name, obj, oi, ok))
    return objs


def _overlap(
    demo: Demonstration, hand: _HandSamples, objs: list[_ObjectSamples], fill_hidden: bool
) -> tuple[int, int]:
    """The span of the clock (step 1): the hand and the objects, ns."""
    spans = [("hand", hand.span)] + [(ob.name, ob.span) for ob in objs if ob.span is not None]
    hand_span = spans[0][1]
    if hand_span is None:
        raise DemonstrationError("the hand has no sample with index tip, thumb tip and index base")
    if len(spans) == 1:
        raise DemonstrationError("no object was ever visible")
    if fill_hidden:  # objects are held at rest before they are first / after they are last seen
        obj_spans = [s[1] for s in spans[1:] if s[1] is not None]
        start = max(hand_span[0], min(s[0] for s in obj_spans))
        end = min(hand_span[1], max(s[1] for s in obj_spans))
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
    return start, end


def _check_filterable(
    n: int, rate_hz: float, cutoffs_hz: tuple[float, ...], overlap_ns: int
) -> None:
    pad = max(matlab_padlen(*butter_ba(fc, rate_hz)) for fc in cutoffs_hz)
    if n <= pad:
        raise DemonstrationError(
            f"demonstration too short to filter: {n} samples at {rate_hz} Hz over the "
            f"hand/object overlap ({overlap_ns * 1e-9:.2f} s); needs more than {pad}"
        )


class _Smoother:
    """The low-pass filter of step 3 (or none), recording the runs too short to filter."""

    def __init__(self, t_ns: np.ndarray, rate_hz: float, enabled: bool) -> None:
        self.t_ns, self.rate_hz, self.enabled = t_ns, rate_hz, enabled
        self.unfiltered: dict[str, list[tuple[int, int]]] = {}

    def __call__(self, x: np.ndarray, fc: float, what: str) -> np.ndarray:
        if not self.enabled:
            return x
        report: list[tuple[int, int]] = []
        y = lowpass(x, fc, self.rate_hz, report=report)
        if report:
            self.unfiltered[what] = [(int(self.t_ns[a]), int(self.t_ns[b - 1])) for a, b in report]
        return y


@dataclass
class _GripperTrack:
    """The hand on the clock, mapped to a gripper (steps 2-4); NaN where ``valid`` is False."""

    keypoints: np.ndarray
    tcp: np.ndarray
    rotation: np.ndarray
    euler: np.ndarray
    opening: np.ndarray
    """Thumb-index opening (the grasp aperture needs the objects)."""
    valid: np.ndarray


def _gripper_track(
    hand: _HandSamples,
    side: str,
    start: int,
    t_s: np.ndarray,
    max_gap_s: float,
    hand_fc: float,
    euler_fc: float,
    smooth: _Smoother,
) -> _GripperTrack:
    h_rel = (hand.t_ns - start) * 1e-9
    points, weights = hand.take_points()
    kp, kp_valid = resample_positions(h_rel, points, t_s, max_gap_s=max_gap_s, weights=weights)
    del points, weights
    hand_valid = kp_valid[:, list(GRIPPER_KEYPOINTS)].all(axis=(1, 2))
    kp = smooth(kp, hand_fc, "keypoints")
    tcp, rot_raw, opening = gripper_frame(kp, side=side)
    hand_valid &= np.isfinite(rot_raw).all(axis=(1, 2))
    euler = unwrap_runs(euler_from_rotation(rot_raw))
    euler[~hand_valid] = np.nan
    euler = smooth(euler, euler_fc, "euler")
    rotation = rotation_from_euler(euler)
    tcp[~hand_valid] = np.nan
    opening[~hand_valid] = np.nan
    return _GripperTrack(kp, tcp, rotation, euler, opening, hand_valid)


@dataclass
class _ObjectTracks:
    """Every object on the clock (steps 2-3), with the gaps report of ``meta["gaps"]``."""

    position: np.ndarray
    quaternion: np.ndarray
    valid: np.ndarray
    size: np.ndarray
    gaps: dict[str, Any]


CARRY_RADIUS_MARGIN = 0.03
"""An object gap is filled from the hand when the TCP stays within half the object's largest
side plus this much (m) of it (:func:`~lfd.preprocessing.carry.fill_carried_gaps`)."""


@dataclass(frozen=True)
class _OpenEnd:
    """What is done with an object unseen from some time to the end of the recording: of a
    complete recording (``"evident"``) the hand that reached it carries it on only where the
    camera saw its place empty, else it rests; of one still being made (``"carried"``) it
    follows the hand once the hand reached it."""

    hidden: str
    camera: CameraInfo | None
    rate_hz: float
    hands: list[np.ndarray]
    """The keypoints of the hands not segmented here on the clock (they may hide a tag too)."""


def _other_hand(hand: HandTrack, start: int, t_s: np.ndarray, max_gap_s: float) -> np.ndarray:
    """A hand not segmented here, its keypoints on the clock (NaN where it is unknown)."""
    order = _sorted_unique(hand.t_ns)
    rel = (hand.t_ns[order] - start) * 1e-9
    return resample_positions(rel, hand.keypoints[order], t_s, max_gap_s=max_gap_s)[0]


@dataclass
class _Filled:
    """One object's pose on the clock with its gaps filled, and the filled ranges."""

    p: np.ndarray
    q: np.ndarray
    valid: np.ndarray
    carried: list[tuple[int, int]]
    held: list[tuple[int, int]]
    last_seen: int


def _fill(
    p: np.ndarray, q: np.ndarray, valid: np.ndarray, gripper: _GripperTrack, radius: float
) -> _Filled:
    """The pose with its gaps filled (:mod:`~lfd.preprocessing.carry`): held at rest before the
    first and after the last sighting, carried through the gaps the hand moved it in."""
    p, q, valid = p.copy(), q.copy(), valid.copy()
    last_seen = int(np.flatnonzero(valid)[-1])
    held = hold_ends(p, q, valid)
    carried = fill_carried_gaps(p, q, valid, gripper.tcp, gripper.valid, radius)
    return _Filled(p, q, valid, carried, held, last_seen)


def _carried_on(
    p: np.ndarray,
    q: np.ndarray,
    valid: np.ndarray,
    gripper: _GripperTrack,
    radius: float,
    rate_hz: float,
) -> _Filled | None:
    """:func:`_fill` where an unseen end the hand reached follows the hand
    (:func:`~lfd.preprocessing.carry.carry_open_end`; None if there is none such)."""
    p, q, valid = p.copy(), q.copy(), valid.copy()
    last_seen = int(np.flatnonzero(valid)[-1])
    ends = carry_open_end(p, q, valid, gripper.tcp, gripper.valid, radius, rate_hz)
    if ends is None:
        return None
    f = _fill(p, q, valid, gripper, radius)
    return _Filled(f.p, f.q, f.valid, [*f.carried, ends], f.held, last_seen)


def _evident(
    open_end: _OpenEnd,
    gripper: _GripperTrack,
    rest: dict[str, _Filled],
    moved: dict[str, _Filled | None],
    sizes: dict[str, float],
    seen_there: dict[str, float],
) -> dict[str, _Filled]:
    """Each object's filled pose: of a recording still being made, carried on by the hand that
    reached it; of a complete one, only where the camera saw its last seen place empty for
    :data:`~lfd.preprocessing.carry.EMPTY_S` (nothing near the line of sight: the hand, the
    forearm, or another object where it rests or where the hand may be carrying it), when it
    had been seen there for as long (``seen_there``, s: a tag that is detected there)."""
    samples = max(1, round(EMPTY_S * open_end.rate_hz))
    if open_end.hidden == "carried":  # unless something now rests on where it was last seen
        now = {name: moved[name] or f for name, f in rest.items()}
        return {
            name: rest[name]
            if moved[name] is not None
            and covered(
                f.p[f.last_seen],
                sizes[name] / 2,
                [g.p for k, g in now.items() if k != name],
                samples,
            )
            else now[name]
            for name, f in rest.items()
        }
    out = dict(rest)
    if open_end.camera is None:
        return out
    hand, hand_radii = occluders(gripper.keypoints)
    for kp in open_end.hands:  # another hand is no occluder where it is unknown
        more, radii = occluders(kp)
        hand = np.concatenate([hand, np.where(np.isfinite(more), more, _FAR)], axis=1)
        hand_radii = np.concatenate([hand_radii, radii])
    camera = open_end.camera.world_T_camera[:3, 3]
    for name, carried in moved.items():
        if carried is None or seen_there[name] < EMPTY_S:
            continue
        # the others where they rest, and where the hand may be carrying them
        others = [(k, f) for k, f in rest.items() if k != name]
        others += [(k, f) for k, f in moved.items() if k != name and f is not None]
        points = np.concatenate(
            [hand, *(np.where(np.isfinite(f.p), f.p, _FAR)[:, None] for _, f in others)], axis=1
        )
        radii = np.concatenate([hand_radii, [sizes[k] / 2 for k, _ in others]])
        f = rest[name]
        view = in_clear_view(
            f.p[f.last_seen], camera, points, radii + sizes[name] / 2 + SIGHT_MARGIN_M
        )
        if seen_empty(view[f.last_seen + 1 :], samples):
            out[name] = carried
    return out


_FAR = np.array([1e6, 1e6, 1e6])


def _seen_there(objs: list[_ObjectSamples]) -> dict[str, float]:
    """How long (s) each object was seen where it was last seen: from its first sighting
    within :data:`~lfd.preprocessing.carry.REST_TOLERANCE` of its last one, after which every
    sighting was, to that last one."""
    out = {}
    for ob in objs:
        t = ob.track.t_ns[ob.order][ob.ok]
        p = ob.track.position[ob.order][ob.ok]
        if not t.size:
            out[ob.name] = 0.0
            continue
        away = np.flatnonzero(np.linalg.norm(p - p[-1], axis=1) >= REST_TOLERANCE)
        first = int(away[-1]) + 1 if away.size else 0
        out[ob.name] = float(t[-1] - t[first]) * 1e-9
    return out


def _object_tracks(
    objs: list[_ObjectSamples],
    hand: _HandSamples,
    gripper: _GripperTrack,
    start: int,
    t_ns: np.ndarray,
    max_gap_s: float,
    obj_fc: float,
    fill_hidden: bool,
    smooth: _Smoother,
    open_end: _OpenEnd,
) -> _ObjectTracks:
    k, n = len(objs), t_ns.size
    t_s = (t_ns - start) * 1e-9
    positions = np.full((k, n, 3), np.nan)
    quats = np.full((k, n, 4), np.nan)
    obj_valid = np.zeros((k, n), dtype=bool)
    gaps: dict[str, Any] = {
        "hand": find_gaps(hand.t_ns, hand.ok, max_gap_s),
        "objects": {},
        "carried": {},  # object gaps filled because the hand carried the object
        "held": {},  # before the first / after the last sighting: held at rest
    }
    raw: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
    rest: dict[str, _Filled] = {}
    moved: dict[str, _Filled | None] = {}
    for ob in objs:
        obj, oi, ok = ob.track, ob.order, ob.ok
        rel = (obj.t_ns[oi] - start) * 1e-9
        p, pv = resample_positions(
            rel, np.where(ok[:, None], obj.position[oi], np.nan), t_s, max_gap_s=max_gap_s
        )
        q, qv = resample_quaternions(
            rel, np.where(ok[:, None], obj.quaternion[oi], np.nan), t_s, max_gap_s=max_gap_s
        )
        valid = pv.all(axis=1) & qv
        raw[ob.name] = (p, q, valid)
        if fill_hidden and valid.any():
            p = np.where(valid[:, None], p, np.nan)
            q = np.where(valid[:, None], q, np.nan)
            radius = float(np.max(obj.size)) / 2 + CARRY_RADIUS_MARGIN
            rest[ob.name] = _fill(p, q, valid, gripper, radius)
            if open_end.hidden == "carried" or open_end.camera is not None:  # else unused
                moved[ob.name] = _carried_on(p, q, valid, gripper, radius, open_end.rate_hz)
    sizes = {ob.name: float(np.max(ob.track.size)) for ob in objs}
    filled = _evident(open_end, gripper, rest, moved, sizes, _seen_there(objs))
    for j, ob in enumerate(objs):
        name = ob.name
        p, q, valid = raw[name]
        if name in filled:
            f = filled[name]
            p, q, valid = f.p, f.q, f.valid
            if f.held:
                gaps["held"][name] = [(int(t_ns[a]), int(t_ns[b - 1])) for a, b in f.held]
            if f.carried:
                gaps["carried"][name] = [(int(t_ns[a]), int(t_ns[b - 1])) for a, b in f.carried]
        positions[j] = smooth(np.where(valid[:, None], p, np.nan), obj_fc, name)
        quats[j] = np.where(valid[:, None], q, np.nan)
        obj_valid[j] = valid
        gaps["objects"][name] = find_gaps(ob.track.t_ns[ob.order], ob.ok, max_gap_s)
    dims = np.array([ob.track.size for ob in objs], dtype=np.float64).reshape(k, 3)
    return _ObjectTracks(positions, quats, obj_valid, dims, gaps)
