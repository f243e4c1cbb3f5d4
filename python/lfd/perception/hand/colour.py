"""The hand in metres from colour alone (a webcam or a video file, no depth).

The image landmarks are the landmark model's good output; its metric 3-D hand is not (its
bones vary 34 % around their medians at the 95th percentile on a real phone video,
``benches/colour_hand.py``). :class:`ColourHand` places a hand frame after frame:

1. **One skeleton** (:class:`BoneLengths`): the hand length, ``hand_size`` (``lfd record
   --hand-size``, wrist to the middle fingertip), else the median of the first
   :data:`MEASURE_FRAMES` confident hands' (presence >= :data:`MEASURE_MIN_SCORE`) in the
   landmark model; times the median of their proportions. :meth:`ColourHand.push`
   holds the frames until then and places them all with it, so every hand of a recording has
   the same bones.
2. **Orientation and relative depths** from the landmark model's hand with those bones, placed
   by PnP (:func:`~lfd.perception.hand.lift.lift_from_colour`), each keypoint then moved at its
   depth onto its viewing ray (:func:`on_rays`).
3. **The distance voted by the bones** (:func:`ray_scale`): the hand scaled about the camera
   centre by each bone's ``length / |bone|``, weighted by how little the vote depends on the
   landmark model's depths (a bone across the view: not at all). PnP weighs every keypoint
   alike, and slanted finger bones it got wrong move the whole hand.
4. **Causal filters** (:class:`DepthSmoother`, the median of the last :data:`MEDIAN_SAMPLES`
   relative depths): the wrist's distance, the weak direction of a monocular fit, lags about
   two frames and loses one-frame jumps; the relative depths lose a frame whose fit turned the
   hand over. They restart when the hand is lost.
5. **The bones kept** (:func:`keep_lengths`): each joint back on its ray at its bone's length
   from the joint before.

The preprocessing filters such a hand at 2 Hz whatever its rate
(:func:`lfd.preprocessing.pipeline.auto_cutoff`): its distance still jitters by about a
centimetre.

Without a known hand size the scale is the landmark model's idea of the hand (its hand length
varies 17 % around its median at the 95th percentile on the real video; the median of the first
confident hands is taken), so the distance of an unusually large or small hand is off in
proportion (a 10 % larger hand is placed 10 % nearer); ``--hand-size`` removes that error.
"""

from __future__ import annotations

from collections import deque
from typing import Any

import numpy as np

from ...demo import HAND_BONES
from ...errors import LfdError
from ..markers import pixel_rays
from .lift import LiftedHand, lift_from_colour
from .mediapipe import Hand

MEASURE_FRAMES = 30
"""Confident hands whose proportions are measured (their running median) before they are fixed."""
MEASURE_MIN_SCORE = 0.8
"""Only hands with at least this presence score are measured (a doubtful detection before the
first confident one is placed with its own bones)."""
MEDIAN_SAMPLES = 3
"""The hand's distance is first the median of this many latest samples."""
DEPTH_ALPHA = 0.5
"""Weight of the newest (median) distance in the exponential smoothing."""
HAND_SIZE_RANGE = (0.10, 0.30)
"""Plausible hand lengths (m): adults' range from about 0.16 to 0.22 m; children's are shorter."""
MIDDLE_CHAIN = ((9, 10), (10, 11), (11, 12))
"""The middle finger's bones (MCP to tip), part of the hand length."""
SHAPE_NOISE = 0.007
"""Error assumed of each of the landmark model's metric keypoints, per coordinate, as a fraction
of the sum of the hand's 21 bone lengths (5 mm on an adult hand, whose bones sum to about
0.7 m; relative, so that the fit does not depend on the hand's size): it sets how little a bone
seen at a slant is trusted for the hand's distance (:func:`ray_scale`)."""
LANDMARK_NOISE_PX = 2.0
"""Error assumed of each image landmark (pixels, per coordinate), the other term of
:func:`ray_scale`'s weights."""


def bone_lengths(points: np.ndarray) -> np.ndarray:
    """The 21 bone lengths (m) of :data:`lfd.demo.HAND_BONES` of a hand ``points`` (21, 3)."""
    p = np.asarray(points, dtype=float)
    a, b = np.array(HAND_BONES).T
    return np.asarray(np.linalg.norm(p[b] - p[a], axis=1))


def hand_length(points: np.ndarray) -> float:
    """Wrist to the middle fingertip along the hand (m): wrist to the middle MCP plus the
    middle finger's three bones, of a hand ``points`` (21, 3)."""
    p = np.asarray(points, dtype=float)
    chain = sum(float(np.linalg.norm(p[b] - p[a])) for a, b in MIDDLE_CHAIN)
    return float(np.linalg.norm(p[9] - p[0])) + chain


def on_rays(points: np.ndarray, keypoints_2d: np.ndarray, K: np.ndarray) -> np.ndarray:
    """Each keypoint of ``points`` (21, 3), camera frame, moved at its depth onto the viewing
    ray through its image landmark (``keypoints_2d``, (21, 2) pixels, through ``K``): the image
    says where a keypoint is across the view, the landmark model only how far."""
    p = np.asarray(points, dtype=np.float64)
    rays = pixel_rays(np.asarray(K, dtype=np.float64), np.asarray(keypoints_2d, dtype=np.float64))
    return np.asarray(rays * p[:, 2:3])


def ray_scale(
    points: np.ndarray,
    lengths: np.ndarray,
    K: np.ndarray,
    *,
    shape_noise: float = SHAPE_NOISE,
    px_noise: float = LANDMARK_NOISE_PX,
) -> float:
    """The factor to scale ``points`` (21, 3, on their viewing rays, :func:`on_rays`) by about
    the camera centre (which keeps every keypoint on its ray) so that the bones
    (:data:`lfd.demo.HAND_BONES`) have the user's ``lengths`` (21,): each bone votes for its own
    factor, ``length / |bone|``, and the votes are averaged in log space, weighted by the inverse
    of their expected variance (``shape_noise``: a fraction of the bones' sum, ``px_noise``:
    pixels).

    A bone across the view is measured by the image, whose landmarks are good: its vote does
    not depend on the landmark model's depths (a depth error ``e`` changes its length by
    ``e * sin``, the bone's slant out of the image plane). A bone seen at a slant depends on
    them. The relative variance of a vote is ``(2 shape_noise^2 tan^2 + 2 (px_noise z / f)^2 /
    cos^2) / length^2``, where ``shape_noise`` is in metres (the fraction times the bones' sum):
    long bones across the view count most. A perspective-n-point fit
    weighs every keypoint alike, and a few slanted finger bones whose depths the landmark model
    got wrong move the whole hand (with 5 mm per keypoint, its distance varied 30 mm from frame
    to frame on renders of the simulator's scene, ``benches/perception_e2e.py``)."""
    p = np.asarray(points, dtype=np.float64)
    a, b = np.array(HAND_BONES).T
    bone = p[b] - p[a]
    norm = np.linalg.norm(bone, axis=1)
    mid = (p[a] + p[b]) / 2.0
    view = mid / np.linalg.norm(mid, axis=1, keepdims=True)
    ok = (norm > 1e-9) & np.isfinite(norm)
    if not ok.any():
        return 1.0
    safe = np.where(ok, norm, 1.0)
    sin2 = np.clip((np.abs(np.sum(bone * view, axis=1)) / safe) ** 2, 0.0, 0.99)
    cos2 = 1.0 - sin2
    lens = np.asarray(lengths, dtype=np.float64)
    noise_m = shape_noise * float(np.sum(lens))
    var = 2.0 * noise_m**2 * sin2 / cos2 + 2.0 * (px_noise * mid[:, 2] / K[0, 0]) ** 2 / cos2
    weight = np.where(ok, lens**2 / np.maximum(var, 1e-12), 0.0)
    votes = np.where(ok, np.log(lens / safe), 0.0)
    return float(np.exp(np.sum(weight * votes) / np.sum(weight)))


def keep_lengths(points: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """``points`` (21, 3, camera frame, on their viewing rays) with the user's bone ``lengths``
    (21, :data:`lfd.demo.HAND_BONES`) restored from the wrist out along each finger: each
    joint stays on its viewing ray, at the bone's length from the joint before it, at the one of
    the two such places nearer its own distance (the landmark model's word on which way the
    bone points); when the ray passes farther than the bone's length from the joint before, the
    joint goes to the place at the bone's length nearest the ray. The wrist-pinky bone follows
    (as in :func:`~lfd.perception.hand.lift.fixed_skeleton`)."""
    p = np.asarray(points, dtype=np.float64)
    out = p.copy()
    placed = {0}
    for k, (a, b) in enumerate(HAND_BONES):
        if b in placed:
            continue
        placed.add(b)
        dist = float(np.linalg.norm(p[b]))
        if not dist > 0.0:
            continue
        ray = p[b] / dist
        parent = out[a]
        along = float(ray @ parent)  # the ray's point nearest the parent is at this distance
        gap2 = float(parent @ parent) - along * along  # squared distance of the ray from it
        length = float(lengths[k])
        if length * length >= gap2:
            half = float(np.sqrt(length * length - gap2))
            near, far = along - half, along + half
            t = near if abs(near - dist) <= abs(far - dist) else far
            if t > 0.0:
                out[b] = t * ray
                continue
        toward = along * ray - parent
        n = float(np.linalg.norm(toward))
        out[b] = parent + (toward / n * length if n > 0.0 else ray * length)
    return out


class BoneLengths:
    """The user's bone lengths: a hand length (``hand_size``, else the median of the confident
    hands' lengths in the landmark model) times the median of their proportions, fixed once
    :attr:`frames` of them are measured (see the module notes).

    Parameters
    ----------
    hand_size : float, optional
        The user's hand length (m, wrist to the middle fingertip) within
        :data:`HAND_SIZE_RANGE`; else the median of the confident hands' in the landmark model.
    frames : int
        Confident hands measured before the lengths are fixed (:data:`MEASURE_FRAMES`).
    """

    def __init__(self, hand_size: float | None = None, *, frames: int = MEASURE_FRAMES) -> None:
        if hand_size is not None and not HAND_SIZE_RANGE[0] <= hand_size <= HAND_SIZE_RANGE[1]:
            lo, hi = HAND_SIZE_RANGE
            raise LfdError(f"hand size must be in [{lo}, {hi}] m (wrist to middle fingertip)")
        if frames < 1:
            raise LfdError(f"frames must be at least 1, got {frames}")
        self.hand_size = hand_size
        self.frames = frames
        self.length: float | None = None
        """The hand length (m) the skeleton has (so far), None before any confident hand."""
        self._proportions: list[np.ndarray] = []
        self._lengths: list[float] = []
        self.fixed: np.ndarray | None = None
        """The lengths (21,) once :attr:`frames` confident hands are measured, else None."""

    def measure(self, world: np.ndarray, score: float = 1.0) -> None:
        """Measure one landmark-model hand ``world`` (21, 3) of presence ``score``: only a
        confident one (:data:`MEASURE_MIN_SCORE`) counts, and none once the lengths are fixed."""
        if self.fixed is not None or score < MEASURE_MIN_SCORE:
            return
        own = hand_length(world)
        if not own > 0.0:
            return
        self._lengths.append(own)
        self.length = self.hand_size or float(np.median(self._lengths))
        self._proportions.append(bone_lengths(world) / own)
        if len(self._proportions) >= self.frames:
            self.fixed = self.lengths(world)

    def lengths(self, world: np.ndarray) -> np.ndarray:
        """The bone lengths (21,) to place a hand with: the fixed ones, else the median of the
        proportions measured so far times the hand length so far; before any confident hand,
        the hand ``world``'s own (scaled to ``hand_size`` when given)."""
        if self.fixed is not None:
            return self.fixed
        if self.length is None:
            own = hand_length(world)
            return np.asarray(bone_lengths(world) / own * (self.hand_size or own))
        return np.asarray(np.median(np.array(self._proportions), axis=0) * self.length)


class DepthSmoother:
    """Causal smoothing of the hand's distance along the viewing rays (see the module notes)."""

    def __init__(self, samples: int = MEDIAN_SAMPLES, alpha: float = DEPTH_ALPHA) -> None:
        if samples < 1 or not 0.0 < alpha <= 1.0:
            raise LfdError("the depth smoother needs samples >= 1 and alpha in (0, 1]")
        self.alpha = alpha
        self._recent: deque[float] = deque(maxlen=samples)
        self._state: float | None = None

    def reset(self) -> None:
        """Forget the past (the hand was lost)."""
        self._recent.clear()
        self._state = None

    def update(self, depth: float) -> float:
        """The smoothed distance for the newest ``depth`` (m, > 0)."""
        self._recent.append(float(depth))
        med = float(np.median(self._recent))
        self._state = med if self._state is None else self._state + self.alpha * (med - self._state)
        return self._state


class ColourHand:
    """One hand placed in the camera frame from colour, frame after frame: fixed bones
    (:class:`BoneLengths`) and a smoothed distance (:class:`DepthSmoother`).

    :meth:`push` holds the frames until the bones are fixed (the first :data:`MEASURE_FRAMES`
    confident hands, a second at 30 frames/s) and then places them all with the fixed
    bones, so every hand of a recording has the same skeleton; :meth:`place` places one hand
    at once with the bones measured so far.

    Parameters
    ----------
    hand_size : float, optional
        The user's hand length (m), see :class:`BoneLengths`.
    """

    def __init__(self, hand_size: float | None = None) -> None:
        self.bones = BoneLengths(hand_size)
        self.depth = DepthSmoother()
        self._shape: deque[np.ndarray] = deque(maxlen=MEDIAN_SAMPLES)
        self._held: list[tuple[Any, Hand | None, np.ndarray, bool]] = []

    def lost(self) -> None:
        """No hand in this frame: the distance filter restarts with the next one."""
        self.depth.reset()
        self._shape.clear()

    @property
    def holding(self) -> int:
        """Frames pushed whose hands are not placed yet."""
        return len(self._held)

    def push(
        self, key: Any, hand: Hand | None, K: np.ndarray, *, restart: bool = False
    ) -> list[tuple[Any, LiftedHand | None]]:
        """Give one frame's hand (None: none found) and its ``key``: the frames placed now, in
        the order they were pushed, each with its key and its hand in metres (None when none
        was found or the fit failed). Nothing while the bones are being measured; then every
        frame held so far; then each frame as it comes. ``restart``: the hand is another
        than the last frame's (a new track): the distance filter restarts with it."""
        if hand is not None:
            self.bones.measure(hand.world, hand.score)
        self._held.append((key, hand, K, restart or hand is None))
        return self.release() if self.bones.fixed is not None else []

    def release(self) -> list[tuple[Any, LiftedHand | None]]:
        """Place every held frame now, with the bones measured so far (the end of a
        recording shorter than the measurement): ``(key, hand in metres or None)`` in order."""
        out: list[tuple[Any, LiftedHand | None]] = []
        for key, hand, K, restart in self._held:
            if restart:
                self.lost()
            out.append((key, None if hand is None else self._place(hand, K)))
        self._held.clear()
        return out

    def place(self, hand: Hand, K: np.ndarray) -> LiftedHand | None:
        """One hand in metres at once, camera frame (OpenCV axes), or None when the fit fails
        (the hand is measured first, as by :meth:`push`)."""
        self.bones.measure(hand.world, hand.score)
        return self._place(hand, K)

    def _place(self, hand: Hand, K: np.ndarray) -> LiftedHand | None:
        lengths = self.bones.lengths(hand.world)
        lifted = lift_from_colour(
            hand.keypoints_2d, hand.world, K, score=hand.score, lengths=lengths
        )
        if lifted is None:
            self.lost()
            return None
        rays = on_rays(lifted.points, hand.keypoints_2d, K)
        points = rays * ray_scale(rays, lengths, K)
        wrist = float(points[0, 2])
        if not (np.isfinite(points).all() and wrist > 0.0):
            self.lost()
            return None
        # the keypoints' depths relative to the wrist, like the wrist's distance, are the
        # median of the last frames': a frame whose fit turned the hand over is outvoted
        self._shape.append(points[:, 2] - wrist)
        depth = self.depth.update(wrist) + np.median(np.array(self._shape), axis=0)
        if not (depth > 0.0).all():
            self.lost()
            return None
        points = keep_lengths(points / points[:, 2:] * depth[:, None], lengths)
        if not (np.isfinite(points).all() and (points[:, 2] > 0).all()):
            self.lost()
            return None
        return LiftedHand(points, lifted.visible, lifted.confidence)
