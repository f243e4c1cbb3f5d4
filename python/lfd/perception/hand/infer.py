"""Run the hand keypoint network on depth frames (needs torch: the ``perception`` extra)."""

from __future__ import annotations

import os
from collections.abc import Sequence
from importlib import resources
from typing import Any

import numpy as np

from ...errors import LfdError
from .dataset import CROP_RADIUS, backproject, crop_centre, hand_points, normalised_crop

SHIPPED_WEIGHTS = "hand_depth.pt"
"""File name of the shipped weights in ``lfd/data``."""


def shipped_weights() -> str:
    """Path of the weights installed with the package."""
    return str(resources.files("lfd.data") / SHIPPED_WEIGHTS)


def _torch() -> Any:
    try:
        import torch
    except ImportError as err:
        raise LfdError("the hand estimator needs torch: pip install 'lfd[perception]'") from err
    return torch


class HandEstimator:
    """21 hand keypoints (world frame) from a depth image.

    Parameters
    ----------
    weights : path, optional
        A model saved by ``lfd perception train`` (default: the shipped weights).
    threads : int, optional
        Torch CPU threads.
    """

    def __init__(
        self, weights: str | os.PathLike[str] | None = None, *, threads: int | None = None
    ):
        torch = _torch()
        from .model import load_model

        path = os.fspath(weights) if weights is not None else shipped_weights()
        if not os.path.exists(path):
            raise LfdError(f"hand model {path} not found (train one: lfd perception train)")
        if threads:
            torch.set_num_threads(threads)
        self.model, self.info = load_model(path)
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
        d = np.asarray(depth_mm)
        if d.ndim != 2:
            raise LfdError(f"depth image must be (H, W), got shape {d.shape}")
        pts = hand_points(backproject(d, np.asarray(K), np.asarray(world_T_camera)), boxes)
        centre = crop_centre(pts)
        if centre is None:
            return None
        crop = normalised_crop(pts, centre, self._rng)
        return self.predict(crop[None])[0] * CROP_RADIUS + centre

    def predict(self, crops: np.ndarray) -> np.ndarray:
        """Normalised crops (b, n, 3) -> normalised keypoints (b, 21, 3)."""
        torch = _torch()
        with torch.no_grad():
            out = self.model(torch.from_numpy(np.ascontiguousarray(crops, np.float32)))
        return np.asarray(out.numpy(), np.float64)
