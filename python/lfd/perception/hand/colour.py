"""The hand in metres from colour alone (a webcam or a video file, no depth).

:func:`~lfd.perception.hand.lift.lift_from_colour` places MediaPipe's metric landmarks so that
they project onto the image landmarks (PnP). Two things make that usable frame after frame:

1. **A skeleton fixed from the first frame** (:class:`BoneLengths`). The landmark model's
   metric hand changes size and proportions from frame to frame (its bones vary 35 % at the
   95th percentile on a real phone video, ``benches/colour_hand.py``, and so do its
   proportions, each bone over the hand's length: 29 %), and the distance PnP finds follows
   that size. The skeleton is the hand's length times proportions. The length is fixed at the
   first confident hand (presence >= :data:`MEASURE_MIN_SCORE`): ``hand_size`` (``lfd record
   --hand-size``, the user's hand length, wrist to the middle fingertip), else that hand's
   length in the landmark model (wrist to the middle MCP plus the middle finger's three
   bones). The proportions start as that hand's and follow the median of the first
   :data:`MEASURE_FRAMES` confident hands' proportions, each bone held within
   :data:`PROPORTION_BOUND` of its first value, then stay fixed. So every frame's bones are
   within about twice that bound of the final ones from the first frame on (measuring the
   median of the bone lengths first, as before, moved them up to 37 % over the first nine
   frames of the video). (Proportions of a standard adult hand, e.g. the simulator's,
   :mod:`lfd.sim.hand`, do not fit the landmark model's keypoints: on the real video the fit
   with them jumped up to 30 cm between frames, 13 cm with these.)
2. **Causal smoothing of the distance** (:class:`DepthSmoother`). Along each viewing ray the
   hand's distance is the weak direction of a monocular fit: it is smoothed, the image
   position is not (the hand is moved along the wrist's viewing ray, so the wrist still
   projects where the landmark model saw it, the bones keep their lengths, and the other
   keypoints move in the image by the change of distance over the distance times their
   distance from the wrist: well under a pixel for a correction of a few centimetres). The
   filter is the median of the last
   :data:`MEDIAN_SAMPLES` wrist depths followed by exponential smoothing with
   :data:`DEPTH_ALPHA`: it lags a steady approach or retreat by about two hand samples (one
   from the median, ``(1 - alpha) / alpha`` = one from the exponential), 80 ms at 25 fps,
   and removes one-frame outliers. It restarts when the hand is lost.

Without a known hand size the scale is the landmark model's idea of the first confident hand
(its hand length varies 17 % around its median at the 95th percentile on the real video), so
the distance of an unusually large or small hand, or of a first hand the model saw too large or
too small, is off in proportion (a 10 % larger hand is placed 10 %
nearer); ``--hand-size`` removes that error.
"""

from __future__ import annotations

from collections import deque

import numpy as np

from ...demo import HAND_BONES
from ...errors import LfdError
from .lift import LiftedHand, lift_from_colour
from .mediapipe import Hand

MEASURE_FRAMES = 15
"""Confident hands whose proportions are measured (their running median) before they are fixed."""
MEASURE_MIN_SCORE = 0.8
"""Only hands with at least this presence score are measured (a doubtful detection before the
first confident one is placed with its own bones)."""
PROPORTION_BOUND = 0.05
"""The measured proportions stay within this fraction of the first confident hand's, bone by
bone (a bounded update: the first hand's proportions, corrected by at most 5 %)."""
MEDIAN_SAMPLES = 3
"""The hand's distance is first the median of this many latest samples."""
DEPTH_ALPHA = 0.5
"""Weight of the newest (median) distance in the exponential smoothing."""
HAND_SIZE_RANGE = (0.10, 0.30)
"""Plausible hand lengths (m): adults' range from about 0.16 to 0.22 m; children's are shorter."""
MIDDLE_CHAIN = ((9, 10), (10, 11), (11, 12))
"""The middle finger's bones (MCP to tip), part of the hand length."""


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


class BoneLengths:
    """The user's bone lengths: a hand length fixed at the first confident hand times
    proportions measured over the first confident hands, bounded, then fixed (see the module
    notes).

    Parameters
    ----------
    hand_size : float, optional
        The user's hand length (m, wrist to the middle fingertip) within
        :data:`HAND_SIZE_RANGE`; else the first confident hand's in the landmark model.
    frames : int
        Confident hands measured before the proportions are fixed (:data:`MEASURE_FRAMES`).
    bound : float
        How far (a fraction) a bone's proportion may move from the first confident hand's
        (:data:`PROPORTION_BOUND`).
    """

    def __init__(
        self,
        hand_size: float | None = None,
        *,
        frames: int = MEASURE_FRAMES,
        bound: float = PROPORTION_BOUND,
    ) -> None:
        if hand_size is not None and not HAND_SIZE_RANGE[0] <= hand_size <= HAND_SIZE_RANGE[1]:
            lo, hi = HAND_SIZE_RANGE
            raise LfdError(f"hand size must be in [{lo}, {hi}] m (wrist to middle fingertip)")
        if frames < 1:
            raise LfdError(f"frames must be at least 1, got {frames}")
        if not 0.0 <= bound < 1.0:
            raise LfdError(f"the proportion bound must be in [0, 1), got {bound}")
        self.hand_size = hand_size
        self.frames = frames
        self.bound = bound
        self.length: float | None = None
        """The hand length (m) the skeleton has, fixed at the first confident hand."""
        self._first: np.ndarray | None = None
        self._proportions: list[np.ndarray] = []
        self.fixed: np.ndarray | None = None

    def update(self, world: np.ndarray, score: float = 1.0) -> np.ndarray:
        """The bone lengths (21,) to place this frame's hand with, given its landmark-model
        hand ``world`` (21, 3) and presence ``score``: the fixed hand length times the running
        median of the confident hands' (:data:`MEASURE_MIN_SCORE`) proportions, each within
        :attr:`bound` of the first's, until :attr:`frames` of them are measured; then fixed.
        Before the first confident hand, this hand's own proportions (scaled to ``hand_size``
        when given)."""
        if self.fixed is not None:
            return self.fixed
        own = hand_length(world)
        proportions = bone_lengths(world) / own
        if score < MEASURE_MIN_SCORE and self.length is None:
            return np.asarray(proportions * (self.hand_size or own))
        if score >= MEASURE_MIN_SCORE:
            if self.length is None:
                self.length = self.hand_size or own
                self._first = proportions
            self._proportions.append(proportions)
        assert self._first is not None and self.length is not None
        median = np.median(np.array(self._proportions), axis=0)
        lo, hi = self._first * (1.0 - self.bound), self._first * (1.0 + self.bound)
        lengths = np.clip(median, lo, hi) * self.length
        if len(self._proportions) >= self.frames:
            self.fixed = lengths
        return np.asarray(lengths)


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

    Parameters
    ----------
    hand_size : float, optional
        The user's hand length (m), see :class:`BoneLengths`.
    """

    def __init__(self, hand_size: float | None = None) -> None:
        self.bones = BoneLengths(hand_size)
        self.depth = DepthSmoother()

    def lost(self) -> None:
        """No hand in this frame: the distance filter restarts with the next one."""
        self.depth.reset()

    def place(self, hand: Hand, K: np.ndarray) -> LiftedHand | None:
        """The hand in metres, camera frame (OpenCV axes), or None when the fit fails."""
        lengths = self.bones.update(hand.world, hand.score)
        lifted = lift_from_colour(
            hand.keypoints_2d, hand.world, K, score=hand.score, lengths=lengths
        )
        if lifted is None:
            self.lost()
            return None
        wrist = lifted.points[0]
        shift = wrist * (self.depth.update(float(wrist[2])) / float(wrist[2]) - 1.0)
        return LiftedHand(lifted.points + shift, lifted.visible, lifted.confidence)
