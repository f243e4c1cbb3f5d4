"""The demonstration data model: what a recording holds, independent of the file format.

A :class:`Demonstration` is what every later stage consumes. Each stream has its own integer
nanosecond timestamps (``t_ns``, int64, capture time). Positions are in metres in the world
frame, which is the frame of the reference marker (AR tag id 0), Z up. Quaternions are
``(x, y, z, w)`` as in foxglove's schemas.

Hand keypoints follow the MediaPipe / OpenPose order of 21 joints (:data:`KEYPOINT_NAMES`).
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from .errors import DemonstrationError
from .inputs import shown
from .skills import check_skill

KEYPOINT_NAMES: tuple[str, ...] = (
    "wrist",
    "thumb_cmc", "thumb_mcp", "thumb_ip", "thumb_tip",
    "index_mcp", "index_pip", "index_dip", "index_tip",
    "middle_mcp", "middle_pip", "middle_dip", "middle_tip",
    "ring_mcp", "ring_pip", "ring_dip", "ring_tip",
    "pinky_mcp", "pinky_pip", "pinky_dip", "pinky_tip",
)  # fmt: skip
"""The 21 hand keypoints, MediaPipe order: wrist, then 4 joints per finger from base to tip."""

KEYPOINT_LAYOUT = "mediapipe-21"
"""Name of the keypoint layout, written to the MCAP channel metadata."""

HAND_SIDES: tuple[str, ...] = ("right", "left")
"""The sides a hand can have, in the order a demonstration lists its hands."""

THUMB_TIP = 4
"""Index of the thumb tip ``T`` (paper Fig. 2)."""
INDEX_MCP = 5
"""Index of the index finger base ("ankle") ``B`` (paper Fig. 2)."""
INDEX_TIP = 8
"""Index of the index fingertip ``I`` (paper Fig. 2)."""

HAND_BONES: tuple[tuple[int, int], ...] = (
    (0, 1), (1, 2), (2, 3), (3, 4),
    (0, 5), (5, 6), (6, 7), (7, 8),
    (5, 9), (9, 10), (10, 11), (11, 12),
    (9, 13), (13, 14), (14, 15), (15, 16),
    (13, 17), (0, 17), (17, 18), (18, 19), (19, 20),
)  # fmt: skip
"""Skeleton edges between keypoints (for drawing)."""


def _timestamps(t_ns: npt.ArrayLike, what: str) -> np.ndarray:
    t = np.asarray(t_ns)
    if t.ndim != 1:
        raise DemonstrationError(f"{what}: timestamps must be 1-D, got shape {t.shape}")
    if t.size and not np.issubdtype(t.dtype, np.integer):
        raise DemonstrationError(f"{what}: timestamps must be integer nanoseconds, got {t.dtype}")
    return t.astype(np.int64, copy=False)


@dataclass
class HandTrack:
    """Hand keypoints over time.

    Attributes
    ----------
    t_ns : array, shape (n,)
        Capture times, int64 nanoseconds.
    keypoints : array, shape (n, 21, 3)
        Keypoint positions in metres (world frame), NaN where not observed.
    confidence : array, shape (n, 21)
        Per-keypoint confidence in [0, 1] (0 where not observed).
    side : str
        ``"right"`` or ``"left"``.
    visible : array, shape (n, 21), bool
        True where the keypoint was seen (e.g. its depth measured on the hand); False where it
        was estimated (occluded, filled from the model) or not observed. Estimated keypoints
        are kept as data, weighted by their confidence. Default (and for recordings without
        the field): finite keypoints with confidence > 0.
    """

    t_ns: np.ndarray
    keypoints: np.ndarray
    confidence: np.ndarray
    side: str = "right"
    visible: np.ndarray = None  # type: ignore[assignment]  # None -> the default above

    def __post_init__(self) -> None:
        self.t_ns = _timestamps(self.t_ns, "hand")
        self.keypoints = np.asarray(self.keypoints, dtype=np.float64)
        n = self.t_ns.shape[0]
        if self.keypoints.shape != (n, 21, 3):
            raise DemonstrationError(
                f"hand keypoints must have shape ({n}, 21, 3), got {self.keypoints.shape}"
            )
        self.confidence = np.asarray(self.confidence, dtype=np.float64)
        if self.confidence.shape != (n, 21):
            raise DemonstrationError(
                f"hand confidence must have shape ({n}, 21), got {self.confidence.shape}"
            )
        if self.visible is None:
            self.visible = np.isfinite(self.keypoints).all(axis=2) & (self.confidence > 0)
        else:
            self.visible = np.asarray(self.visible)
            if self.visible.shape != (n, 21) or self.visible.dtype != np.bool_:
                raise DemonstrationError(
                    f"hand visible must be booleans of shape ({n}, 21), got "
                    f"{self.visible.dtype} {self.visible.shape}"
                )

    def __len__(self) -> int:
        return int(self.t_ns.shape[0])


@dataclass
class ObjectTrack:
    """The 6-D pose of one AR-tagged cuboid over time.

    Attributes
    ----------
    name : str
        Object name (used in topics: ``/objects/<name>/pose``).
    tag_id : int
        ArUco tag id (the reference marker is id 0 and is not an object).
    size : array, shape (3,)
        Box dimensions (x, y, z) in metres, ``d_i`` of the paper.
    t_ns : array, shape (m,)
        Capture times, int64 nanoseconds.
    position : array, shape (m, 3)
        Box centre in metres, world frame. NaN where not visible.
    quaternion : array, shape (m, 4)
        Orientation (x, y, z, w). NaN where not visible.
    visible : array, shape (m,)
        True where the tag was observed.
    """

    name: str
    tag_id: int
    size: np.ndarray
    t_ns: np.ndarray
    position: np.ndarray
    quaternion: np.ndarray
    visible: np.ndarray

    def __post_init__(self) -> None:
        self.t_ns = _timestamps(self.t_ns, f"object {self.name!r}")
        m = self.t_ns.shape[0]
        self.size = np.asarray(self.size, dtype=np.float64)
        if self.size.shape != (3,) or not np.all(self.size > 0):
            raise DemonstrationError(
                f"object {self.name!r}: size must be 3 positive lengths, got {self.size}"
            )
        self.position = np.asarray(self.position, dtype=np.float64)
        self.quaternion = np.asarray(self.quaternion, dtype=np.float64)
        self.visible = np.asarray(self.visible, dtype=bool)
        for what, arr, shape in (
            ("position", self.position, (m, 3)),
            ("quaternion", self.quaternion, (m, 4)),
            ("visible", self.visible, (m,)),
        ):
            if arr.shape != shape:
                raise DemonstrationError(
                    f"object {self.name!r}: {what} must have shape {shape}, got {arr.shape}"
                )

    def __len__(self) -> int:
        return int(self.t_ns.shape[0])


@dataclass
class SkillLabel:
    """One labelled skill segment (ground truth or a result)."""

    skill: str
    start_ns: int
    end_ns: int
    object: str | None = None
    hand: str | None = None
    """The side of the hand whose lane the label is in: ``"right"`` or ``"left"``; None for the
    only hand of a one-hand demonstration."""

    def __post_init__(self) -> None:
        check_skill(self.skill)
        check_side(self.hand, "label", none_ok=True)
        self.start_ns = int(self.start_ns)
        self.end_ns = int(self.end_ns)
        if self.end_ns < self.start_ns:
            raise DemonstrationError(
                f"label {self.skill!r}: end {self.end_ns} before start {self.start_ns}"
            )


def check_side(side: str | None, what: str, none_ok: bool = False) -> None:
    """Raise DemonstrationError unless ``side`` is one of :data:`HAND_SIDES` (or None, if
    ``none_ok``)."""
    if side is None and none_ok:
        return
    if side not in HAND_SIDES:
        raise DemonstrationError(f"{what}: hand side must be one of {HAND_SIDES}, got {side!r}")


@dataclass
class Handover:
    """An object passed from one hand to the other, one event that both hands' lanes share
    (docs/skills.md): from ``start_ns``, when the taking hand has grasped it (both hold it),
    to ``end_ns``, when the giving hand has let go of it."""

    start_ns: int
    end_ns: int
    giver: str
    taker: str
    object: str | None = None

    def __post_init__(self) -> None:
        self.start_ns = int(self.start_ns)
        self.end_ns = int(self.end_ns)
        check_side(self.giver, "handover giver")
        check_side(self.taker, "handover taker")
        if self.giver == self.taker:
            raise DemonstrationError(f"handover: the {self.giver} hand cannot give to itself")
        if self.end_ns < self.start_ns:
            raise DemonstrationError(f"handover: end {self.end_ns} before start {self.start_ns}")


MAX_IMAGE_SIDE = 16384
"""Largest image width or height (px)."""
FOCAL_RANGE_PX = (1.0, 1e5)
"""Plausible focal lengths ``fx``, ``fy`` (px): a 640-px-wide image with f = 1 px sees 180
degrees, one with f = 1e5 px a hundredth of a degree."""
MAX_SKEW = 0.01
"""Largest ``|K[0, 1]|`` as a fraction of ``fx`` (cameras have none; calibrations fix it to 0)."""
ROTATION_TOLERANCE = 1e-3
"""How far ``R^T R`` may be from the identity, and ``det R`` from 1, in ``world_T_camera``."""
MAX_TRANSLATION_M = 100.0
"""Largest distance of the camera from the world origin (m)."""
MAX_TAG_ID = 1023
"""Largest ArUco id of any predefined dictionary (``DICT_ARUCO_ORIGINAL`` has 1024)."""
NO_TAG = -1
"""The tag id of an object without a tag (``ObjectTrack.tag_id`` of an imported recording)."""


def is_number(value: Any) -> bool:
    """A real number (Python's or numpy's), not a bool nor a string."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool | np.bool_)


def all_numbers(value: Any) -> bool:
    """Whether ``value`` is a (nested) list or array of real numbers, no strings or bools."""
    if isinstance(value, np.ndarray):
        return value.dtype.kind in "iuf"
    if isinstance(value, list | tuple):
        return all(all_numbers(v) for v in value)
    return is_number(value)


def whole_number(value: Any, lo: int, hi: int) -> int | None:
    """``value`` as an int when it is a whole number in [lo, hi] (a JSON or TOML 3, or 3.0; an
    integer of any length), else None."""
    if not is_number(value):
        return None
    if not isinstance(value, numbers.Integral):
        if not math.isfinite(value) or value != int(value):
            return None
    return int(value) if lo <= value <= hi else None


def tag_id_problem(value: Any, untagged: bool = False) -> str | None:
    """What is wrong with an object's tag id (None: a whole number in [0, :data:`MAX_TAG_ID`],
    or :data:`NO_TAG` when ``untagged`` objects are allowed)."""
    if whole_number(value, NO_TAG if untagged else 0, MAX_TAG_ID) is not None:
        return None
    allowed = f"an integer in [0, {MAX_TAG_ID}]"
    if untagged:
        allowed = f"{allowed} or {NO_TAG} (no tag)"
    return f"must be {allowed}, got {shown(value)}"


def shared_tag_problem(tags: dict[str, int]) -> str | None:
    """What is wrong with the tag ids of objects, name -> id (None: no tag is on two objects;
    :data:`NO_TAG` may be on any number)."""
    owner: dict[int, str] = {}
    for name, tag in tags.items():
        if tag != NO_TAG and tag in owner:
            return f"objects {owner[tag]!r} and {name!r} have the same tag_id {tag}"
        owner[tag] = name
    return None


def _rows(a: np.ndarray) -> str:
    return "; ".join(" ".join(f"{v:g}" for v in row) for row in a)


def _matrix(value: Any, shape: tuple[int, int]) -> np.ndarray | None:
    """``value`` as a finite float matrix of ``shape``; None when it is not one (strings, bools,
    rows of different lengths, another shape, NaN or infinity)."""
    if not all_numbers(value):
        return None
    try:
        a = np.asarray(value, dtype=float)
    except ValueError:  # ragged rows: numpy's "inhomogeneous shape"
        return None
    return a if a.shape == shape and np.isfinite(a).all() else None


def k_problem(K: Any, width: int | None = None, height: int | None = None) -> str | None:
    """What is wrong with a pinhole matrix ``K`` (None: usable); with the image size, the
    principal point must be inside the image."""
    K = _matrix(K, (3, 3))
    if K is None:
        return "K must be a finite 3x3 matrix [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]"
    if K[1, 0] != 0 or K[2, 0] != 0 or K[2, 1] != 0 or K[2, 2] != 1:
        return f"K must be upper triangular with last row 0 0 1, got {_rows(K)}"
    lo, hi = FOCAL_RANGE_PX
    for name, f in (("fx", K[0, 0]), ("fy", K[1, 1])):
        if not lo <= f <= hi:
            return f"K: focal length {name} must be in [{lo:g}, {hi:g}] px, got {f:g}"
    if abs(K[0, 1]) > MAX_SKEW * K[0, 0]:
        return f"K: skew K[0][1] = {K[0, 1]:g} px, at most {MAX_SKEW:g} fx"
    for name, c, side in (("cx", K[0, 2], width), ("cy", K[1, 2], height)):
        bound = MAX_IMAGE_SIDE if side is None else side
        if not 0 <= c <= bound:
            return f"K: principal point {name} = {c:g} px is outside the image (0..{bound})"
    return None


def pose_problem(T: Any) -> str | None:
    """What is wrong with a rigid transform (None: a rotation and a plausible translation)."""
    T = _matrix(T, (4, 4))
    if T is None:
        return "must be a finite 4x4 matrix"
    if not np.array_equal(T[3], [0.0, 0.0, 0.0, 1.0]):
        return f"last row must be 0 0 0 1, got {_rows(T[3:])}"
    R = T[:3, :3]
    off = float(np.abs(R.T @ R - np.eye(3)).max())
    if off > ROTATION_TOLERANCE or abs(np.linalg.det(R) - 1.0) > ROTATION_TOLERANCE:
        return (
            "rotation block must be orthonormal with determinant +1 (a rigid transform, metres), "
            f"got det {np.linalg.det(R):.6g}"
        )
    distance = math.hypot(*(float(v) for v in T[:3, 3]))  # no overflow in a square
    if distance > MAX_TRANSLATION_M:
        return f"translation is {distance:g} m from the origin, at most {MAX_TRANSLATION_M:g} m"
    return None


@dataclass
class CameraInfo:
    """Pinhole intrinsics and the camera pose in the world frame.

    Attributes
    ----------
    width, height : int
        Image size in pixels.
    K : array, shape (3, 3)
        Intrinsic matrix (OpenCV convention: x right, y down, z forward).
    world_T_camera : array, shape (4, 4)
        Homogeneous pose of the (OpenCV) camera frame in the world frame.
    frame_id : str
        Name of the camera frame.
    """

    width: int
    height: int
    K: np.ndarray
    world_T_camera: np.ndarray
    frame_id: str = "camera"

    def __post_init__(self) -> None:
        self.K = np.asarray(self.K, dtype=np.float64).reshape(3, 3)
        self.world_T_camera = np.asarray(self.world_T_camera, dtype=np.float64).reshape(4, 4)


class ImageStream:
    """A sequence of images: colour (n, H, W, 3) uint8 RGB or depth (n, H, W) uint16 millimetres.

    ``frames`` is an array, or a function returning it, called the first time :attr:`frames` is
    read (how :func:`lfd.load` keeps a recording's images encoded until they are used).
    """

    def __init__(
        self, t_ns: npt.ArrayLike, frames: npt.ArrayLike | Callable[[], np.ndarray]
    ) -> None:
        self.t_ns = _timestamps(t_ns, "images")
        self._decode: Callable[[], np.ndarray] | None = None
        self._frames: np.ndarray | None = None
        if callable(frames):
            self._decode = frames
        else:
            self._frames = self._checked(np.asarray(frames))

    def _checked(self, frames: np.ndarray) -> np.ndarray:
        if frames.shape[0] != self.t_ns.shape[0]:
            raise DemonstrationError(
                f"{frames.shape[0]} images but {self.t_ns.shape[0]} timestamps"
            )
        return frames

    @property
    def frames(self) -> np.ndarray:
        """The images, decoded on first use."""
        if self._frames is None:
            assert self._decode is not None
            self._frames = self._checked(np.asarray(self._decode()))
            self._decode = None
        return self._frames

    @frames.setter
    def frames(self, value: npt.ArrayLike) -> None:
        self._frames, self._decode = self._checked(np.asarray(value)), None

    @property
    def decoded(self) -> bool:
        """Whether the frames have been decoded (or were given as an array)."""
        return self._frames is not None

    def __len__(self) -> int:
        return int(self.t_ns.shape[0])

    def __repr__(self) -> str:
        state = "decoded" if self.decoded else "encoded"
        return f"ImageStream({len(self)} frames, {state})"


@dataclass
class Demonstration:
    """One recorded demonstration.

    Attributes
    ----------
    hand : HandTrack
        The demonstrator's hand keypoints (about 5 Hz from a hand-pose estimator): the only
        hand, or the right hand of two.
    objects : dict[str, ObjectTrack]
        Object poses by name (about 30 Hz), relative to the reference marker.
    labels : list[SkillLabel]
        Ground-truth skill segments, in time order (empty when unknown).
    camera : CameraInfo or None
        Camera calibration, when known.
    color, depth : ImageStream or None
        Optional rendered or captured images.
    metadata : dict
        Free metadata: task, demonstrator, seed, units, ...
    live_segments : list[SkillLabel]
        Skills a live segmenter settled while the demonstration was recorded
        (``/lfd/live/segments``), kept apart from the ground truth.
    other_hand : HandTrack or None
        The second hand of a two-hand demonstration (the left hand; given either way round,
        ``hand`` becomes the right one). :attr:`hands` holds both by side.
    handovers : list[Handover]
        Ground-truth handovers between the two hands, in time order.
    occluders : list[HandTrack]
        Hands in view that are not segmented here (the other hand of a two-hand demonstration
        seen alone, :meth:`one_hand`): they may hide an object's tag from the camera
        (:mod:`lfd.preprocessing.carry`).

    In a two-hand demonstration each label names its hand (``SkillLabel.hand``); in a one-hand
    demonstration a label's hand is None or the hand's side.
    """

    hand: HandTrack
    objects: dict[str, ObjectTrack]
    labels: list[SkillLabel] = field(default_factory=list)
    camera: CameraInfo | None = None
    color: ImageStream | None = None
    depth: ImageStream | None = None
    metadata: dict[str, Any] = field(default_factory=dict)
    live_segments: list[SkillLabel] = field(default_factory=list)
    other_hand: HandTrack | None = None
    handovers: list[Handover] = field(default_factory=list)
    occluders: list[HandTrack] = field(default_factory=list)

    def __post_init__(self) -> None:
        check_side(self.hand.side, "hand")
        if self.other_hand is not None:
            check_side(self.other_hand.side, "other hand")
            if self.other_hand.side == self.hand.side:
                raise DemonstrationError(
                    f"two hands must have different sides, got two {self.hand.side} hands"
                )
            if self.hand.side != HAND_SIDES[0]:
                self.hand, self.other_hand = self.other_hand, self.hand
        self.check_hands()

    def check_hands(self) -> None:
        """Raise DemonstrationError if a label, live segment or handover names a hand the
        demonstration lacks, or a label of a two-hand demonstration names none."""
        sides = self.sides
        for what, labels in (("label", self.labels), ("live segment", self.live_segments)):
            for lab in labels:
                if lab.hand is None and len(sides) > 1:
                    raise DemonstrationError(
                        f"{what} {lab.skill!r} at {lab.start_ns} ns names no hand, and the "
                        f"demonstration has two ({' and '.join(sides)})"
                    )
                if lab.hand is not None and lab.hand not in sides:
                    raise DemonstrationError(
                        f"{what} {lab.skill!r} at {lab.start_ns} ns is for the {lab.hand} hand, "
                        f"which the demonstration lacks (it has the {' and '.join(sides)})"
                    )
        for h in self.handovers:
            if len(sides) < 2:
                raise DemonstrationError(
                    f"a handover at {h.start_ns} ns needs two hands; the demonstration has one"
                )

    @property
    def hands(self) -> dict[str, HandTrack]:
        """The hands by side, the right hand first."""
        hands = {self.hand.side: self.hand}
        if self.other_hand is not None:
            hands[self.other_hand.side] = self.other_hand
        return hands

    @property
    def sides(self) -> tuple[str, ...]:
        """The sides of the hands, the right first: ``("right",)``, ``("left",)`` or
        ``("right", "left")``."""
        return tuple(self.hands)

    def labels_of(self, side: str, live: bool = False) -> list[SkillLabel]:
        """The labels (or live segments) in the lane of the ``side`` hand."""
        if side not in self.sides:
            raise DemonstrationError(f"the demonstration has no {side} hand (it has {self.sides})")
        labels = self.live_segments if live else self.labels
        return [lab for lab in labels if lab.hand in (side, None)]

    def one_hand(self, side: str) -> Demonstration:
        """The demonstration as the ``side`` hand alone saw it: that hand, every object, the
        labels of its lane; the same images and metadata (no copy of the arrays)."""
        labels = self.labels_of(side)
        return dataclasses.replace(
            self,
            hand=self.hands[side],
            other_hand=None,
            labels=labels,
            live_segments=self.labels_of(side, live=True),
            handovers=[],
            occluders=[h for s, h in self.hands.items() if s != side],
        )

    @property
    def start_ns(self) -> int:
        """Earliest timestamp of any stream."""
        starts = [int(h.t_ns[0]) for h in self.hands.values() if len(h)]
        starts += [int(o.t_ns[0]) for o in self.objects.values() if len(o)]
        if not starts:
            raise DemonstrationError("demonstration has no samples")
        return min(starts)

    @property
    def end_ns(self) -> int:
        """Latest timestamp of any stream."""
        ends = [int(h.t_ns[-1]) for h in self.hands.values() if len(h)]
        ends += [int(o.t_ns[-1]) for o in self.objects.values() if len(o)]
        if not ends:
            raise DemonstrationError("demonstration has no samples")
        return max(ends)

    @property
    def duration_s(self) -> float:
        """Duration in seconds from the first to the last sample."""
        return (self.end_ns - self.start_ns) * 1e-9

    @property
    def skill_sequence(self) -> list[str]:
        """The ground-truth skill names in order."""
        return [label.skill for label in self.labels]
