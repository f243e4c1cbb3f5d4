"""MediaPipe Hands on colour images: palm detection -> rotated hand crop -> 21 landmarks.

The two networks are MediaPipe's own "full" models (Apache-2.0, shipped in ``lfd/data/mediapipe``
with their licence and a NOTICE saying where they come from), run with ``ai-edge-litert`` (the
``perception`` extra). The pre- and post-processing follows MediaPipe's published graphs
(``palm_detection_cpu``, ``hand_landmark_cpu``, ``hand_landmark_tracking_cpu``):

1. **palm detection** on the whole image, letterboxed to 192 x 192 (values in [0, 1], zero
   border): 2016 SSD anchors, box + 7 palm keypoints per anchor, sigmoid scores, weighted
   non-maximum suppression;
2. **hand rectangle**: the palm box turned so that wrist -> middle-finger base points up, shifted
   half a box towards the fingers and scaled 2.6x, square;
3. **landmarks** on the 224 x 224 rotated crop: 21 keypoints (x, y in crop pixels, z relative
   depth on the same scale), a hand-presence score, a handedness score and metric "world"
   landmarks around the hand's centre;
4. **tracking**: the next frame's rectangle comes from this frame's landmarks (scale 2.0), so the
   palm detector only runs when a hand is lost or, while fewer hands than wanted are tracked,
   every ``redetect_every`` frames; new detections overlapping a tracked hand are dropped, so
   tracked hands keep their identity and two hands in view do not swap.

Handedness: MediaPipe's handedness output assumes a mirrored (selfie) image. lfd's images come
from a camera looking at a workspace, not mirrored, so the label is swapped by default
(``mirrored=False``); a track's handedness is the running mean of its per-frame scores, stable
over time.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from importlib import resources
from typing import Any

import numpy as np

from ...demo import HAND_BONES
from ...demo import KEYPOINT_NAMES as _KEYPOINT_NAMES
from ...errors import LfdError
from ..stderr import quiet_stderr

PALM_MODEL = "palm_detection_full.tflite"
LANDMARK_MODEL = "hand_landmark_full.tflite"
PALM_INPUT = 192
LANDMARK_INPUT = 224
N_KEYPOINTS = 21

# palm detection (palm_detection_cpu.pbtxt)
ANCHOR_STRIDES = (8, 16, 16, 16)
ANCHOR_OFFSET = 0.5
SCORE_CLIP = 100.0
MIN_DETECTION_SCORE = 0.5
NMS_IOU = 0.3
# detection -> hand rectangle (palm_detection_detection_to_roi.pbtxt)
PALM_ROT_FROM, PALM_ROT_TO = 0, 2  # wrist centre -> middle finger base, among the 7 palm keypoints
PALM_SCALE, PALM_SHIFT_Y = 2.6, -0.5
# landmarks -> next frame's rectangle (hand_landmark_landmarks_to_roi.pbtxt)
TRACK_KEYPOINTS = (0, 1, 2, 3, 5, 6, 9, 10, 13, 14, 17, 18)
TRACK_SCALE, TRACK_SHIFT_Y = 2.0, -0.1
MIN_PRESENCE = 0.5
TRACK_IOU = 0.5
"""A new palm detection overlapping a tracked hand by more than this is the same hand."""

KEYPOINT_NAMES = _KEYPOINT_NAMES
"""MediaPipe-21 keypoint order: lfd's hand keypoint order (:data:`lfd.demo.KEYPOINT_NAMES`)."""
SKELETON = HAND_BONES
"""Bones between the keypoints (for drawing; :data:`lfd.demo.HAND_BONES`)."""
HANDS = ("left", "right")


def model_dir() -> str:
    """Folder of the shipped MediaPipe models (with LICENSE and NOTICE)."""
    return str(resources.files("lfd.data") / "mediapipe")


def _interpreter(path: str, threads: int) -> Any:
    try:
        from ai_edge_litert.interpreter import Interpreter
    except ImportError as err:
        from ...errors import MissingExtraError

        raise MissingExtraError(
            "the MediaPipe hand model needs ai-edge-litert: pip install 'lfd[perception]'",
            extra="perception",
        ) from err
    if not os.path.exists(path):
        raise LfdError(f"hand model file {path} not found (reinstall lfd)")
    try:
        with quiet_stderr():  # TFLite prints "INFO: Created ... XNNPACK delegate" on fd 2
            it = Interpreter(model_path=path, num_threads=threads)
            it.allocate_tensors()
    except (ValueError, RuntimeError) as err:
        raise LfdError(f"{path}: not a TFLite model ({err})") from err
    return it


@dataclass(frozen=True)
class Rect:
    """A rotated square in image pixels: centre, side, rotation (rad, counter-clockwise on screen
    is negative: MediaPipe's convention, y pointing down)."""

    cx: float
    cy: float
    size: float
    rotation: float

    def corners(self) -> np.ndarray:
        """(4, 2) pixels: top-left, top-right, bottom-right, bottom-left of the crop."""
        c, s = math.cos(self.rotation), math.sin(self.rotation)
        h = self.size / 2
        local = np.array([[-h, -h], [h, -h], [h, h], [-h, h]])
        return local @ np.array([[c, s], [-s, c]]) + [self.cx, self.cy]

    def to_image(self, xy_unit: np.ndarray) -> np.ndarray:
        """Points in crop units ([0, 1]^2, (n, 2)) -> image pixels."""
        c, s = math.cos(self.rotation), math.sin(self.rotation)
        d = (np.asarray(xy_unit, float) - 0.5) * self.size
        return np.stack(
            [self.cx + c * d[:, 0] - s * d[:, 1], self.cy + s * d[:, 0] + c * d[:, 1]], axis=1
        )

    def iou(self, other: Rect) -> float:
        """Intersection over union of the axis-aligned bounds of the two rotated squares."""
        a, b = self.corners(), other.corners()
        lo = np.maximum(a.min(0), b.min(0))
        hi = np.minimum(a.max(0), b.max(0))
        inter = float(np.prod(np.clip(hi - lo, 0, None)))
        area = float(np.prod(a.max(0) - a.min(0)) + np.prod(b.max(0) - b.min(0)))
        return inter / (area - inter) if area > inter else 0.0


@dataclass
class PalmDetection:
    """One palm: box (x0, y0, x1, y1) and 7 keypoints (7, 2) in image pixels, score in [0, 1]."""

    box: np.ndarray
    keypoints: np.ndarray
    score: float


@dataclass
class Hand:
    """One hand found in an image.

    keypoints_2d : (21, 2) pixels from the top-left corner, MediaPipe-21 order.
    relative_z : (21,) relative depth in pixels (same scale as u, v; larger is farther from the
        camera), about 0 at the wrist.
    world : (21, 3) metres, MediaPipe's metric landmarks around the hand's centre (camera axes).
    handedness : "left" or "right" (of the person; see the module notes on mirroring).
    handedness_score : probability of that label (running mean over a track).
    score : hand presence score of the landmark model, in [0, 1].
    rect : the crop the landmarks were read from.
    track_id : identity kept over frames by :class:`HandTracker` (-1 for still images).
    """

    keypoints_2d: np.ndarray
    relative_z: np.ndarray
    world: np.ndarray
    handedness: str
    handedness_score: float
    score: float
    rect: Rect
    track_id: int = -1

    def to_json(self) -> dict[str, Any]:
        return {
            "handedness": self.handedness,
            "handedness_score": round(float(self.handedness_score), 4),
            "score": round(float(self.score), 4),
            "keypoints_2d": np.round(self.keypoints_2d, 2).tolist(),
        }


def ssd_anchors(size: int = PALM_INPUT, strides: tuple[int, ...] = ANCHOR_STRIDES) -> np.ndarray:
    """Anchor centres (n, 2) in [0, 1] of MediaPipe's palm detector (fixed size 1, two anchors per
    layer and cell; consecutive layers with the same stride share the grid)."""
    out = []
    i = 0
    while i < len(strides):
        j = i
        while j < len(strides) and strides[j] == strides[i]:
            j += 1
        per_cell = 2 * (j - i)
        n = math.ceil(size / strides[i])
        ys, xs = np.meshgrid(
            (np.arange(n) + ANCHOR_OFFSET) / n, (np.arange(n) + ANCHOR_OFFSET) / n, indexing="ij"
        )
        cells = np.stack([xs.ravel(), ys.ravel()], axis=1)
        out.append(np.repeat(cells, per_cell, axis=0))
        i = j
    return np.concatenate(out)


def _sigmoid(x: np.ndarray) -> np.ndarray:
    return np.asarray(1.0 / (1.0 + np.exp(-np.clip(x, -SCORE_CLIP, SCORE_CLIP))))


def decode_palms(
    raw_boxes: np.ndarray,
    raw_scores: np.ndarray,
    anchors: np.ndarray,
    *,
    min_score: float = MIN_DETECTION_SCORE,
    input_size: int = PALM_INPUT,
) -> list[tuple[np.ndarray, np.ndarray, float]]:
    """Raw detector outputs (n, 18), (n,) -> (box (4,), keypoints (7, 2), score), all in the
    detector's unit square, after weighted non-maximum suppression."""
    scores = _sigmoid(np.asarray(raw_scores, float).reshape(-1))
    keep = np.flatnonzero(scores >= min_score)
    if keep.size == 0:
        return []
    raw = np.asarray(raw_boxes, float).reshape(-1, 18)[keep] / input_size
    a = anchors[keep]
    cx, cy = raw[:, 0] + a[:, 0], raw[:, 1] + a[:, 1]
    w, h = raw[:, 2], raw[:, 3]
    boxes = np.stack([cx - w / 2, cy - h / 2, cx + w / 2, cy + h / 2], axis=1)
    kps = raw[:, 4:].reshape(-1, 7, 2) + a[:, None, :]
    return _weighted_nms(boxes, kps, scores[keep])


def _iou(box: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    lo = np.maximum(box[:2], boxes[:, :2])
    hi = np.minimum(box[2:], boxes[:, 2:])
    inter = np.prod(np.clip(hi - lo, 0, None), axis=1)
    area = lambda b: np.prod(np.clip(b[..., 2:] - b[..., :2], 0, None), axis=-1)  # noqa: E731
    union = area(box) + area(boxes) - inter
    return np.where(union > 0, inter / np.where(union > 0, union, 1), 0.0)


def _weighted_nms(
    boxes: np.ndarray, kps: np.ndarray, scores: np.ndarray
) -> list[tuple[np.ndarray, np.ndarray, float]]:
    """MediaPipe's WEIGHTED non-maximum suppression: each cluster (IoU > NMS_IOU with its best
    box) is replaced by the score-weighted mean of its boxes and keypoints, with the best score."""
    order = np.argsort(-scores, kind="stable")
    out = []
    while order.size:
        best = order[0]
        overlap = _iou(boxes[best], boxes[order]) > NMS_IOU
        cluster = order[overlap]
        w = scores[cluster][:, None]
        box = (boxes[cluster] * w).sum(0) / w.sum()
        kp = (kps[cluster] * w[:, :, None]).sum(0) / w.sum()
        out.append((box, kp, float(scores[best])))
        order = order[~overlap]
    return out


def _rotation(p0: np.ndarray, p1: np.ndarray) -> float:
    """Rotation that turns p0 -> p1 (pixels) to point up (MediaPipe's target angle 90 deg)."""
    angle = math.pi / 2 - math.atan2(-(p1[1] - p0[1]), p1[0] - p0[0])
    return angle - 2 * math.pi * math.floor((angle + math.pi) / (2 * math.pi))


def _transform(
    cx: float, cy: float, w: float, h: float, rotation: float, scale: float, shift_y: float
) -> Rect:
    """MediaPipe's RectTransformationCalculator in pixels: shift along the rotated y axis, make
    square on the long side, scale."""
    cx += -h * shift_y * math.sin(rotation)
    cy += h * shift_y * math.cos(rotation)
    return Rect(cx, cy, max(w, h) * scale, rotation)


def palm_rect(palm: PalmDetection) -> Rect:
    """The landmark crop of a palm detection."""
    x0, y0, x1, y1 = palm.box
    rot = _rotation(palm.keypoints[PALM_ROT_FROM], palm.keypoints[PALM_ROT_TO])
    return _transform((x0 + x1) / 2, (y0 + y1) / 2, x1 - x0, y1 - y0, rot, PALM_SCALE, PALM_SHIFT_Y)


def landmarks_rect(keypoints_2d: np.ndarray) -> Rect:
    """The next frame's landmark crop from this frame's keypoints (pixels)."""
    kp = np.asarray(keypoints_2d, float)[list(TRACK_KEYPOINTS)]
    # among TRACK_KEYPOINTS: 0 wrist, 4 index MCP, 6 middle MCP, 8 ring MCP
    p1 = 0.25 * (kp[4] + kp[8]) + 0.5 * kp[6]
    rot = _rotation(kp[0], p1)
    centre = (kp.min(0) + kp.max(0)) / 2
    c, s = math.cos(-rot), math.sin(-rot)
    d = kp - centre
    proj = np.stack([d[:, 0] * c - d[:, 1] * s, d[:, 0] * s + d[:, 1] * c], axis=1)
    pc = (proj.min(0) + proj.max(0)) / 2
    cr, sr = math.cos(rot), math.sin(rot)
    cx = pc[0] * cr - pc[1] * sr + centre[0]
    cy = pc[0] * sr + pc[1] * cr + centre[1]
    w, h = proj.max(0) - proj.min(0)
    return _transform(cx, cy, float(w), float(h), rot, TRACK_SCALE, TRACK_SHIFT_Y)


def crop(image: np.ndarray, rect: Rect, size: int, *, border_zero: bool = False) -> np.ndarray:
    """The rotated square ``rect`` of ``image`` resampled to (size, size, 3) float32 in [0, 1].

    Bilinear, without anti-aliasing, like MediaPipe's OpenCV converter (the models' reference
    outputs are reproduced that way; pre-shrinking large images moved them by 2-4 px)."""
    import cv2

    src = rect.corners()[[0, 1, 3]].astype(np.float32)
    dst = np.array([[0, 0], [size, 0], [0, size]], np.float32)
    m = cv2.getAffineTransform(src, dst)
    border = cv2.BORDER_CONSTANT if border_zero else cv2.BORDER_REPLICATE
    out = cv2.warpAffine(image, m, (size, size), flags=cv2.INTER_LINEAR, borderMode=border)
    return np.asarray(out, np.float32) / 255.0


MIN_IMAGE_SIDE = 2
"""Smallest width and height (px) of an image the hand model is given."""


def as_rgb(image: np.ndarray, where: str = "image") -> np.ndarray:
    """Validate an image: (H, W, 3) uint8 RGB (grey (H, W) and RGBA are converted), at least
    :data:`MIN_IMAGE_SIDE` pixels wide and high."""
    img = np.asarray(image)
    if img.dtype != np.uint8:
        raise LfdError(f"{where}: expected 8-bit colour, got dtype {img.dtype}")
    if img.ndim == 2:
        img = np.repeat(img[:, :, None], 3, axis=2)
    if img.ndim != 3 or img.shape[2] not in (3, 4):
        raise LfdError(f"{where}: expected an (H, W, 3) colour image, got shape {img.shape}")
    if min(img.shape[:2]) < MIN_IMAGE_SIDE:
        raise LfdError(
            f"{where}: the image is {img.shape[1]}x{img.shape[0]} pixels, too small to find a "
            f"hand in (at least {MIN_IMAGE_SIDE}x{MIN_IMAGE_SIDE})"
        )
    return np.ascontiguousarray(img[:, :, :3])


class MediaPipeHands:
    """MediaPipe Hands (full) on still images.

    Parameters
    ----------
    threads : int
        CPU threads of each TFLite interpreter (1 is enough for 30 fps at 640 x 480).
    mirrored : bool
        Whether images are mirrored (selfie view). MediaPipe's handedness assumes they are; lfd's
        cameras look at a workspace, so by default the label is swapped to the person's hand.
    min_detection_score, min_presence : float
        Palm detector and hand-presence thresholds (MediaPipe's defaults, 0.5).
    """

    def __init__(
        self,
        *,
        threads: int = 1,
        mirrored: bool = False,
        min_detection_score: float = MIN_DETECTION_SCORE,
        min_presence: float = MIN_PRESENCE,
        model_path: str | os.PathLike[str] | None = None,
    ) -> None:
        folder = os.fspath(model_path) if model_path is not None else model_dir()
        self._palm = _interpreter(os.path.join(folder, PALM_MODEL), threads)
        self._lm = _interpreter(os.path.join(folder, LANDMARK_MODEL), threads)
        self._palm_in = self._palm.get_input_details()[0]["index"]
        out = sorted(self._palm.get_output_details(), key=lambda d: int(d["shape"][-1]))
        self._palm_scores, self._palm_boxes = out[0]["index"], out[1]["index"]
        self._lm_in = self._lm.get_input_details()[0]["index"]
        lm_out = {d["name"]: d["index"] for d in self._lm.get_output_details()}
        # Identity: 63 screen landmarks, Identity_1: presence, Identity_2: handedness,
        # Identity_3: 63 world landmarks (the order of MediaPipe's hand_landmark graph)
        self._lm_out = [lm_out[n] for n in ("Identity", "Identity_1", "Identity_2", "Identity_3")]
        self._anchors = ssd_anchors()
        self.mirrored = mirrored
        self.min_detection_score = min_detection_score
        self.min_presence = min_presence
        self.info = {
            "model": "mediapipe-hands-full",
            "palm": PALM_MODEL,
            "landmark": LANDMARK_MODEL,
            "mirrored": mirrored,
        }

    def detect_palms(self, image: np.ndarray) -> list[PalmDetection]:
        """Palms in an RGB image, best first (pixels)."""
        img = as_rgb(image)
        h, w = img.shape[:2]
        side = float(max(w, h))  # letterbox: the square around the image, zero border
        rect = Rect(w / 2, h / 2, side, 0.0)
        x = crop(img, rect, PALM_INPUT, border_zero=True)
        self._palm.set_tensor(self._palm_in, x[None])
        self._palm.invoke()
        found = decode_palms(
            self._palm.get_tensor(self._palm_boxes)[0],
            self._palm.get_tensor(self._palm_scores)[0],
            self._anchors,
            min_score=self.min_detection_score,
        )
        out = []
        for box, kp, score in found:
            to_px = lambda p: rect.to_image(np.asarray(p).reshape(-1, 2))  # noqa: E731
            out.append(PalmDetection(to_px(box).reshape(4), to_px(kp), score))
        return out

    def landmarks(self, image: np.ndarray, rect: Rect) -> Hand | None:
        """The hand in ``rect`` of an RGB image, or None when the presence score is too low."""
        img = as_rgb(image)
        x = crop(img, rect, LANDMARK_INPUT)
        self._lm.set_tensor(self._lm_in, x[None])
        self._lm.invoke()
        screen, presence, handed, world = (self._lm.get_tensor(i)[0] for i in self._lm_out)
        score = float(np.asarray(presence).reshape(-1)[0])
        if score < self.min_presence:
            return None
        pts = np.asarray(screen, float).reshape(N_KEYPOINTS, 3) / LANDMARK_INPUT
        kp = rect.to_image(pts[:, :2])
        rel_z = pts[:, 2] * rect.size
        c, s = math.cos(rect.rotation), math.sin(rect.rotation)
        wl = np.asarray(world, float).reshape(N_KEYPOINTS, 3)
        world_pts = np.stack(
            [c * wl[:, 0] - s * wl[:, 1], s * wl[:, 0] + c * wl[:, 1], wl[:, 2]], axis=1
        )
        # the graph's binary classifier gives P(label 0) = P("Left") of a mirrored image, which
        # is P(right hand) in the unmirrored image
        right = float(np.asarray(handed).reshape(-1)[0])
        if self.mirrored:
            right = 1.0 - right
        label = "right" if right >= 0.5 else "left"
        return Hand(
            keypoints_2d=kp,
            relative_z=rel_z,
            world=world_pts,
            handedness=label,
            handedness_score=right if label == "right" else 1.0 - right,
            score=score,
            rect=rect,
        )

    def detect(self, image: np.ndarray, *, max_hands: int = 2) -> list[Hand]:
        """All hands in a still image (palm detection + landmarks), at most ``max_hands``."""
        img = as_rgb(image)
        hands: list[Hand] = []
        for palm in self.detect_palms(img):
            if len(hands) >= max_hands:
                break
            rect = palm_rect(palm)
            if any(rect.iou(h.rect) > TRACK_IOU for h in hands):
                continue
            hand = self.landmarks(img, rect)
            if hand is not None:
                hands.append(hand)
        return hands


@dataclass
class _Track:
    id: int
    rect: Rect
    right_sum: float = 0.0
    frames: int = 0
    last: Hand | None = None


class HandTracker:
    """Hands over a video: landmarks from the previous frame's keypoints, palm detection only to
    find new hands.

    Parameters
    ----------
    model : MediaPipeHands, optional
    max_hands : int
        Hands tracked at once (2: the demonstrator's hands).
    redetect_every : int
        While fewer than ``max_hands`` are tracked, run the palm detector every this many frames
        (a lost hand is searched for at once, on the next frame).
    """

    def __init__(
        self,
        model: MediaPipeHands | None = None,
        *,
        max_hands: int = 2,
        redetect_every: int = 10,
    ) -> None:
        if max_hands < 1:
            raise LfdError(f"max_hands must be at least 1, got {max_hands}")
        if redetect_every < 1:
            raise LfdError(f"redetect_every must be at least 1, got {redetect_every}")
        self.model = model if model is not None else MediaPipeHands()
        self.max_hands = max_hands
        self.redetect_every = redetect_every
        self._tracks: list[_Track] = []
        self._next_id = 0
        self._since_detect = 0
        self._lost = False
        self.palm_runs = 0
        self.frames = 0

    def reset(self) -> None:
        self._tracks = []
        self._since_detect = 0

    def update(self, image: np.ndarray) -> list[Hand]:
        """Hands in the next frame (RGB), each with its ``track_id`` and running handedness."""
        img = as_rgb(image)
        self.frames += 1
        kept: list[_Track] = []
        for tr in self._tracks:
            hand = self.model.landmarks(img, tr.rect)
            if hand is None:
                self._lost = True
                continue
            rect = landmarks_rect(hand.keypoints_2d)
            if any(rect.iou(k.rect) > TRACK_IOU for k in kept):
                continue  # two crops converged on one hand: the older track keeps it
            self._accept(tr, hand, rect)
            kept.append(tr)
        self._tracks = kept
        self._since_detect += 1
        want = len(self._tracks) < self.max_hands
        if want and (self._lost or not self._tracks or self._since_detect >= self.redetect_every):
            self._detect(img)
        return [tr.last for tr in self._tracks if tr.last is not None]

    def _detect(self, img: np.ndarray) -> None:
        self.palm_runs += 1
        self._since_detect = 0
        self._lost = False
        for palm in self.model.detect_palms(img):
            if len(self._tracks) >= self.max_hands:
                break
            rect = palm_rect(palm)
            if any(rect.iou(tr.rect) > TRACK_IOU or _covers(tr, rect) for tr in self._tracks):
                continue
            hand = self.model.landmarks(img, rect)
            if hand is None:
                continue
            tr = _Track(self._next_id, rect)
            self._accept(tr, hand, landmarks_rect(hand.keypoints_2d))
            if any(_same_hand(tr, other) for other in self._tracks):
                continue
            self._next_id += 1
            self._tracks.append(tr)

    def _accept(self, tr: _Track, hand: Hand, rect: Rect) -> None:
        right = hand.handedness_score if hand.handedness == "right" else 1 - hand.handedness_score
        tr.right_sum += right
        tr.frames += 1
        mean = tr.right_sum / tr.frames
        hand.handedness = "right" if mean >= 0.5 else "left"
        hand.handedness_score = mean if hand.handedness == "right" else 1 - mean
        hand.track_id = tr.id
        tr.last = hand
        tr.rect = rect


def _covers(tr: _Track, rect: Rect) -> bool:
    """A detection whose centre lies on a tracked hand's keypoints' bounds is that hand."""
    if tr.last is None:
        return False
    kp = tr.last.keypoints_2d
    lo, hi = kp.min(0), kp.max(0)
    return bool(lo[0] <= rect.cx <= hi[0] and lo[1] <= rect.cy <= hi[1])


def _same_hand(new: _Track, old: _Track) -> bool:
    if new.last is None or old.last is None:
        return False
    d = np.linalg.norm(new.last.keypoints_2d - old.last.keypoints_2d, axis=1).mean()
    return bool(d < 0.1 * max(old.rect.size, 1.0))


def select_hand(hands: list[Hand], side: str, locked: int | None = None) -> Hand | None:
    """The demonstrator's ``side`` hand among ``hands``: the locked track while it is seen and
    still has that handedness, else the most confident hand of that side (None if there is none)."""
    if side not in HANDS:
        raise LfdError(f"hand must be one of {', '.join(HANDS)}, got {side!r}")
    mine = [h for h in hands if h.handedness == side]
    for h in mine:
        if locked is not None and h.track_id == locked:
            return h
    return max(mine, key=lambda h: (h.handedness_score, h.score), default=None)
