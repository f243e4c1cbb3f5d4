"""Hands in still images, for checking a camera setup (``lfd perception hands``).

:func:`hands_in_images` runs MediaPipe Hands on each image and, given an aligned depth image and
the intrinsics, lifts the keypoints to metres in the camera frame. The result is a JSON-ready
document::

    {"images": [{"image": PATH, "width": W, "height": H,
                 "hands": [{"handedness": "right", "handedness_score": s, "score": s,
                            "keypoints_2d": [[u, v] x 21],        pixels from the top-left corner
                            "keypoints_3d": [[x, y, z] x 21] or null,   metres, camera frame
                            "visible": [21 bools] or null, "confidence": [21] or null}]}],
     "keypoint_order": "mediapipe21", "keypoint_names": [...], "frame": "camera (x right,
     y down, z forward)", "model": "mediapipe-hands-full"}

A photo without a hand gives ``"hands": []``, not an error.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ...demo import k_problem
from ...errors import LfdError
from ...inputs import parse_json, read_text
from ..image_header import decode as _decode
from .mediapipe import KEYPOINT_NAMES, Hand, MediaPipeHands, as_rgb

PathLike = str | os.PathLike[str]


def read_image(path: PathLike) -> np.ndarray:
    """An image file as (H, W, 3) uint8 RGB the hand model takes (:func:`as_rgb`); one-line
    error naming the file otherwise."""
    import cv2

    rgb = cv2.cvtColor(_decode(path, "image", cv2.IMREAD_COLOR), cv2.COLOR_BGR2RGB)
    return as_rgb(rgb, os.fspath(path))


def read_depth(path: PathLike, shape: tuple[int, int]) -> np.ndarray:
    """A 16-bit depth PNG in millimetres of the given (H, W); one-line error otherwise."""
    import cv2

    p = Path(path)
    d = _decode(p, "depth image", cv2.IMREAD_UNCHANGED)
    if d.ndim != 2 or d.dtype != np.uint16:
        raise LfdError(
            f"{p}: depth must be a single-channel 16-bit image in mm, got {d.dtype} {d.shape}"
        )
    if d.shape != shape:
        raise LfdError(
            f"{p}: depth image is {d.shape[1]}x{d.shape[0]}, its colour image {shape[1]}x{shape[0]}"
            " (they must be aligned, the same size)"
        )
    return d


def read_intrinsics(path: PathLike) -> np.ndarray:
    """K (3, 3) from a JSON file: a ``camera.json`` (``{"K": [[...]], ...}``) or a bare 3x3 list."""
    p = Path(path)
    if not p.is_file():
        raise LfdError(f"{p}: intrinsics file not found")
    doc = parse_json(read_text(p, "intrinsics file", LfdError), str(p), LfdError)
    try:
        K = np.asarray(doc["K"] if isinstance(doc, dict) else doc, float)
    except (KeyError, TypeError, ValueError) as err:
        detail = str(err)[:200]
        raise LfdError(
            f'{p}: expected JSON {{"K": [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]}} ({detail})'
        ) from None
    problem = k_problem(K)
    if problem is not None:
        raise LfdError(f"{p}: {problem}")
    return K


def _hand_doc(hand: Hand, lifted: Any) -> dict[str, Any]:
    doc = hand.to_json()
    doc["keypoints_3d"] = None if lifted is None else np.round(lifted.points, 5).tolist()
    doc["visible"] = None if lifted is None else [bool(v) for v in lifted.visible]
    doc["confidence"] = None if lifted is None else np.round(lifted.confidence, 4).tolist()
    return doc


@dataclass
class StillInputs:
    """Decoded colour images, their aligned depth images (or None) and K (or None)."""

    paths: list[str]
    rgb: list[np.ndarray]
    depth: list[np.ndarray | None]
    K: np.ndarray | None


def read_inputs(
    images: Sequence[PathLike],
    depth: Sequence[PathLike] | None = None,
    intrinsics: PathLike | None = None,
) -> StillInputs:
    """Read and check every input file (one-line :class:`LfdError` naming a bad one)."""
    if depth is not None and len(depth) != len(images):
        raise LfdError(f"--depth: {len(depth)} depth images for {len(images)} colour images")
    if depth is not None and intrinsics is None:
        raise LfdError("depth images need --intrinsics K.json (the colour camera's K)")
    K = read_intrinsics(intrinsics) if intrinsics is not None else None
    rgbs = [read_image(p) for p in images]
    depths: list[np.ndarray | None] = (
        [read_depth(d, rgb.shape[:2]) for d, rgb in zip(depth, rgbs, strict=True)]
        if depth is not None
        else [None] * len(rgbs)
    )
    return StillInputs([os.fspath(p) for p in images], rgbs, depths, K)


def hands_in_images(
    images: Sequence[PathLike] | StillInputs,
    *,
    depth: Sequence[PathLike] | None = None,
    intrinsics: PathLike | None = None,
    model: MediaPipeHands | None = None,
    max_hands: int = 2,
    progress: Callable[[int], None] | None = None,
) -> dict[str, Any]:
    """Hands in each image (see the module docstring for the document).

    ``depth`` (one 16-bit mm PNG per image, aligned) needs ``intrinsics``; every file is read
    and checked (:func:`read_inputs`, or pass its result as ``images``) before the model runs,
    so a bad input fails fast and names the file."""
    from .lift import lift_keypoints

    inputs = images if isinstance(images, StillInputs) else read_inputs(images, depth, intrinsics)
    K = inputs.K
    model = model if model is not None else MediaPipeHands()
    out = []
    for i, (path, rgb, d) in enumerate(zip(inputs.paths, inputs.rgb, inputs.depth, strict=True)):
        hands = model.detect(rgb, max_hands=max_hands)
        docs = []
        for hand in hands:
            lifted = None
            if d is not None and K is not None:
                lifted = lift_keypoints(hand.keypoints_2d, hand.relative_z, d, K, score=hand.score)
            docs.append(_hand_doc(hand, lifted))
        out.append({"image": path, "width": rgb.shape[1], "height": rgb.shape[0], "hands": docs})
        if progress is not None:
            progress(i + 1)
    return {
        "images": out,
        "keypoint_order": "mediapipe21",
        "keypoint_names": list(KEYPOINT_NAMES),
        "frame": "camera (x right, y down, z forward), metres",
        "model": model.info["model"],
        "mirrored": model.mirrored,
    }
