"""Run the hand keypoint network on depth frames (needs torch: the ``perception`` extra)."""

from __future__ import annotations

import os
from collections.abc import Sequence
from importlib import resources
from typing import Any

import numpy as np

from ...errors import LfdError
from .dataset import (
    CROP_RADIUS,
    N_POINTS,
    backproject,
    crop_centre,
    hand_points,
    normalised_crop,
)

SHIPPED_WEIGHTS = "hand_depth.pt"
"""File name of the shipped weights in ``lfd/data``."""
DEFAULT_VIEWS = 4
"""Point subsets averaged per estimate."""


def shipped_weights() -> str:
    """Path of the weights installed with the package."""
    return str(resources.files("lfd.data") / SHIPPED_WEIGHTS)


def _torch() -> Any:
    try:
        import torch
    except ImportError as err:
        from ...errors import MissingExtraError

        raise MissingExtraError(
            "the hand estimator needs torch: pip install 'lfd[perception]'", extra="perception"
        ) from err
    return torch


class HandEstimator:
    """21 hand keypoints (world frame) from a depth image.

    Parameters
    ----------
    weights : path, optional
        A model saved by ``lfd perception train`` (default: the shipped weights).
    threads : int, optional
        Torch CPU threads.
    views : int
        Random point subsets of the crop the network sees per estimate; the keypoints are
        averaged over them (test-time augmentation: less variance for a few ms).
    """

    def __init__(
        self,
        weights: str | os.PathLike[str] | None = None,
        *,
        threads: int | None = None,
        views: int = DEFAULT_VIEWS,
    ):
        torch = _torch()
        from .model import load_model

        path = os.fspath(weights) if weights is not None else shipped_weights()
        if not os.path.exists(path):
            raise LfdError(f"hand model {path} not found (train one: lfd perception train)")
        if threads:
            torch.set_num_threads(threads)
        if views < 1:
            raise LfdError(f"views must be at least 1, got {views}")
        self.model, self.info = load_model(path)
        self.views = views
        self._rng = np.random.default_rng(0)

    def estimate(
        self,
        depth_mm: np.ndarray,
        K: np.ndarray,
        world_T_camera: np.ndarray,
        boxes: Sequence[tuple[np.ndarray, np.ndarray, np.ndarray]] = (),
    ) -> np.ndarray | None:
        """Keypoints (21, 3) in metres (world frame), or None when no hand is in view.

        ``depth_mm`` has shape (H, W), uint16 millimetres; ``boxes`` are the known objects as
        ``(centre (3,), R (3, 3), size (3,))`` so their points are not taken for the hand.
        """
        found = self.estimate_with_spread(depth_mm, K, world_T_camera, boxes)
        return None if found is None else found[0]

    def estimate_with_spread(
        self,
        depth_mm: np.ndarray,
        K: np.ndarray,
        world_T_camera: np.ndarray,
        boxes: Sequence[tuple[np.ndarray, np.ndarray, np.ndarray]] = (),
    ) -> tuple[np.ndarray, np.ndarray] | None:
        """Like :meth:`estimate`, with each keypoint's spread over the point subsets (21,) in
        metres: the RMS distance of the subsets' estimates from their mean (0 with one view)."""
        d = np.asarray(depth_mm)
        if d.ndim != 2:
            raise LfdError(f"depth image must be (H, W), got shape {d.shape}")
        if not np.issubdtype(d.dtype, np.integer):
            raise LfdError(f"depth image must be integer millimetres (uint16), got {d.dtype}")
        K = np.asarray(K, float)
        pose = np.asarray(world_T_camera, float)
        if K.shape != (3, 3) or pose.shape != (4, 4):
            raise LfdError(f"K must be (3, 3) and world_T_camera (4, 4): {K.shape}, {pose.shape}")
        if not (np.isfinite(K).all() and np.isfinite(pose).all()):
            raise LfdError("K and world_T_camera must be finite")
        return self.estimate_points(hand_points(backproject(d, K, pose), boxes))

    def estimate_points(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """Keypoints (21, 3) and their spread (21,) from hand points (m, POINT_DIM) in the world
        frame (as :func:`~lfd.perception.hand.dataset.hand_points` gives them), or None."""
        centre = crop_centre(points)
        if centre is None:
            return None
        crops = normalised_crop(points, centre, self._rng, N_POINTS * self.views)
        each = self.predict(crops.reshape(self.views, N_POINTS, -1)) * CROP_RADIUS
        mean = each.mean(axis=0)
        spread = np.sqrt(np.mean(np.sum((each - mean) ** 2, axis=2), axis=0))
        return mean + centre, spread

    def predict(self, crops: np.ndarray) -> np.ndarray:
        """Normalised crops (b, n, POINT_DIM) -> normalised keypoints (b, 21, 3)."""
        torch = _torch()
        with torch.no_grad():
            out = self.model(torch.from_numpy(np.ascontiguousarray(crops, np.float32)))
        return np.asarray(out.numpy(), np.float64)
