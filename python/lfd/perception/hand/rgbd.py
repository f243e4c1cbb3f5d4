"""The real-camera hand estimator of ``lfd record``: MediaPipe on colour, lifted with depth,
or placed from colour alone when a frame has no depth.

Per frame: :class:`~lfd.perception.hand.mediapipe.HandTracker` finds and tracks the hands in the
colour image, :func:`~lfd.perception.hand.mediapipe.select_hand` keeps the demonstrator's hand
(``side``, locked to one track while it is seen, so a second hand in view never takes its
place), and :func:`~lfd.perception.hand.lift.lift_keypoints` reads metric depth at the keypoints
(pixels on the table or inside a tagged box are not the hand) before the points go to the
reference-marker (world) frame. A frame without depth (a webcam, a video file) places the hand
from colour alone (:class:`~lfd.perception.hand.colour.ColourHand`: the landmark model's metric
hand with fixed bone lengths, fitted to the image by PnP, its distance smoothed causally).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ...errors import LfdError
from .colour import ColourHand
from .lift import LiftedHand, lift_keypoints
from .mediapipe import HANDS, Hand, HandTracker, MediaPipeHands, select_hand

TABLE_MARGIN_M = 0.004
"""Depth pixels less than this above the table plane (world z = 0) are the table, not the hand."""
BOX_MARGIN_M = 0.006
"""Depth pixels within this of a tagged box's faces belong to the box."""
REGION_MARGIN = 0.25
"""The object mask is computed over the keypoints' bounds grown by this fraction on each side."""

Box = tuple[np.ndarray, np.ndarray, np.ndarray]


@dataclass
class HandEstimate:
    """One frame's hand: keypoints (21, 3) world metres, confidence (21,), visible (21,) bool,
    and the 2-D detection it came from."""

    keypoints: np.ndarray
    confidence: np.ndarray
    visible: np.ndarray
    hand: Hand | None = None


def _in_frame(
    hand: Hand | None, world_T_camera: np.ndarray | None, placed: LiftedHand | None
) -> HandEstimate | None:
    """A hand placed in the camera frame as a :class:`HandEstimate` in the world frame (camera
    frame while ``world_T_camera`` is None); None without one."""
    if hand is None or placed is None:
        return None
    pts = placed.points if world_T_camera is None else placed.to_world(world_T_camera)
    return HandEstimate(pts, placed.confidence, placed.visible, hand)


def not_hand_mask(
    depth_mm: np.ndarray,
    K: np.ndarray,
    world_T_camera: np.ndarray | None,
    boxes: Sequence[Box],
    region: tuple[int, int, int, int] | None = None,
) -> np.ndarray:
    """(H, W) bool: depth pixels that are the table (world z below :data:`TABLE_MARGIN_M`) or
    inside a box ``(centre, R, size)``; only ``region`` (u0, v0, u1, v1) is examined."""
    d = np.asarray(depth_mm)
    mask = np.zeros(d.shape, bool)
    if world_T_camera is None:
        return mask
    h, w = d.shape
    u0, v0, u1, v1 = region if region is not None else (0, 0, w, h)
    u0, v0, u1, v1 = max(0, u0), max(0, v0), min(w, u1), min(h, v1)
    if u1 <= u0 or v1 <= v0:
        return mask
    v, u = np.mgrid[v0:v1, u0:u1]
    z = d[v0:v1, u0:u1].astype(np.float64) * 1e-3
    cam = np.stack([(u - K[0, 2]) / K[0, 0] * z, (v - K[1, 2]) / K[1, 1] * z, z], axis=-1)
    R, t = np.asarray(world_T_camera)[:3, :3], np.asarray(world_T_camera)[:3, 3]
    world = cam @ R.T + t
    out = (z > 0) & (world[..., 2] < TABLE_MARGIN_M)
    for centre, Rb, size in boxes:
        local = (world - centre) @ Rb
        out |= (z > 0) & np.all(np.abs(local) < np.asarray(size) / 2 + BOX_MARGIN_M, axis=-1)
    mask[v0:v1, u0:u1] = out
    return mask


LIFTING = {True: "depth patch median", False: "colour pnp"}
"""How the hand is placed in metres, with depth or without (``lfd record``'s metadata)."""


class MediaPipeEstimator:
    """MediaPipe Hands + depth lifting, for a real RGB-D camera; colour-only placement
    (:class:`~lfd.perception.hand.colour.ColourHand`) for frames without depth.

    Parameters
    ----------
    side : "right" or "left"
        The demonstrator's hand.
    threads : int
        TFLite CPU threads.
    mirrored : bool
        Whether the colour images are mirrored (selfie view); see
        :mod:`lfd.perception.hand.mediapipe`.
    max_hands : int
        Hands tracked at once, so that another hand in view is known and never confused.
    hand_size : float, optional
        The user's hand length (m, wrist to the middle fingertip), for frames without depth
        (:class:`~lfd.perception.hand.colour.BoneLengths`); without it the bone lengths are
        the landmark model's, measured over the first frames.
    """

    needs_colour = True

    def __init__(
        self,
        side: str = "right",
        *,
        threads: int = 1,
        mirrored: bool = False,
        max_hands: int = 2,
        model: MediaPipeHands | None = None,
        hand_size: float | None = None,
    ) -> None:
        if side not in HANDS:
            raise LfdError(f"hand must be one of {', '.join(HANDS)}, got {side!r}")
        self.model = (
            model if model is not None else MediaPipeHands(threads=threads, mirrored=mirrored)
        )
        self.tracker = HandTracker(self.model, max_hands=max_hands)
        self.side = side
        self._locked: int | None = None
        self._hand_size = hand_size
        self.colour = ColourHand(hand_size)
        self.info: dict[str, Any] = {**self.model.info, "side": side}
        self._leader: MediaPipeEstimator | None = None
        self._last_hands: list[Hand] = []

    def for_side(self, side: str) -> MediaPipeEstimator:
        """The estimator of the demonstrator's other hand (``side``) from the same tracker: a
        two-hand recording uses both. It must be given each frame after this one (it takes
        the hands this one's tracker found in it); it has its own track lock and colour hand."""
        if side not in HANDS:
            raise LfdError(f"hand must be one of {', '.join(HANDS)}, got {side!r}")
        other = object.__new__(MediaPipeEstimator)
        other.model, other.tracker, other.side = self.model, self.tracker, side
        other._locked, other._hand_size = None, self._hand_size
        other.colour = ColourHand(self._hand_size)
        other.info = {**self.model.info, "side": side}
        other._leader, other._last_hands = self, []
        return other

    def lifting(self, depth: bool) -> str:
        """How the hand is placed in metres with depth images or without (:data:`LIFTING`)."""
        return LIFTING[depth]

    def estimate_frame(
        self,
        color: np.ndarray,
        depth_mm: np.ndarray | None,
        K: np.ndarray,
        world_T_camera: np.ndarray | None,
        boxes: Sequence[Box] = (),
    ) -> HandEstimate | None:
        """The demonstrator's hand in one frame (world frame), or None when it is not in view.
        With ``depth_mm`` None it is placed from colour alone, at once, with the bones measured
        so far (:meth:`feed` holds the first frames until the bones are fixed).
        ``world_T_camera`` None gives camera-frame keypoints."""
        hand, restart = self._track(color)
        if restart:
            self.colour.lost()
        if hand is None:
            return None
        if depth_mm is None:
            return _in_frame(hand, world_T_camera, self.colour.place(hand, K))
        return self._lift(hand, color, depth_mm, K, world_T_camera, boxes)

    def feed(
        self,
        color: np.ndarray,
        depth_mm: np.ndarray | None,
        K: np.ndarray,
        world_T_camera: np.ndarray | None,
        boxes: Sequence[Box] = (),
    ) -> list[HandEstimate | None]:
        """Give one frame; get the hands of the oldest frames given that are now known, in
        order: every frame gets exactly one result (None: no hand), now or later. With depth,
        this frame's at once. Without, the frames are held until the colour hand's bones are
        fixed (:meth:`ColourHand.push <lfd.perception.hand.colour.ColourHand.push>`), so that
        every hand of the recording has the same skeleton; :meth:`drain` gives the frames
        still held when the recording ends."""
        if depth_mm is not None and not self.colour.holding:
            return [self.estimate_frame(color, depth_mm, K, world_T_camera, boxes)]
        hand, restart = self._track(color)
        placed = self.colour.push((hand, world_T_camera), hand, K, restart=restart)
        return [_in_frame(key[0], key[1], lifted) for key, lifted in placed]

    def drain(self) -> list[HandEstimate | None]:
        """The hands of the frames still held (:meth:`feed`), placed with the bones measured so
        far, in order."""
        return [_in_frame(key[0], key[1], lifted) for key, lifted in self.colour.release()]

    def _track(self, color: np.ndarray) -> tuple[Hand | None, bool]:
        """This frame's hand, and whether it starts a new track (or none was found): the
        colour hand's distance filter restarts there."""
        if self._leader is None:
            hands = self._last_hands = self.tracker.update(color)
        else:  # the same frame, just tracked by the leader
            hands = self._leader._last_hands
        hand = select_hand(hands, self.side, self._locked)
        restart = hand is None or hand.track_id != self._locked
        self._locked = None if hand is None else hand.track_id
        return hand, restart

    def _lift(
        self,
        hand: Hand,
        color: np.ndarray,
        depth_mm: np.ndarray,
        K: np.ndarray,
        world_T_camera: np.ndarray | None,
        boxes: Sequence[Box],
    ) -> HandEstimate | None:
        depth = np.asarray(depth_mm)
        if depth.shape != np.asarray(color).shape[:2]:
            raise LfdError(
                f"depth image is {depth.shape[1]}x{depth.shape[0]}, the colour image "
                f"{np.asarray(color).shape[1]}x{np.asarray(color).shape[0]}: they must be aligned"
            )
        lo, hi = hand.keypoints_2d.min(0), hand.keypoints_2d.max(0)
        grow = (hi - lo) * REGION_MARGIN + 8
        region = (*np.floor(lo - grow).astype(int), *np.ceil(hi + grow).astype(int))
        exclude = not_hand_mask(depth, K, world_T_camera, boxes, region)  # type: ignore[arg-type]
        lifted = lift_keypoints(
            hand.keypoints_2d, hand.relative_z, depth, K, exclude=exclude, score=hand.score
        )
        if lifted is None:
            return None
        pts = lifted.points if world_T_camera is None else lifted.to_world(world_T_camera)
        return HandEstimate(pts, lifted.confidence, lifted.visible, hand)
