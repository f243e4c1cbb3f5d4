"""Log hands found in still images (``lfd perception hands --rerun``) to Rerun."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from ..demo import HAND_BONES
from .recording import import_rerun

__all__ = ["log_still_hands"]


def log_still_hands(doc: dict[str, Any], images: Sequence[np.ndarray]) -> None:
    """Each image with its hands' skeletons (and 3-D keypoints when lifted) to the open Rerun
    recording, one step of the ``image`` timeline per image.

    ``doc`` is :func:`lfd.perception.hand.stills.hands_in_images`'s document, ``images`` its
    images as (H, W, 3) RGB arrays, in order (:attr:`~lfd.perception.hand.stills.StillInputs.rgb`).
    """
    rr = import_rerun()
    for i, entry in enumerate(doc["images"]):
        rr.set_time("image", sequence=i)
        rr.log("/image", rr.Image(images[i]))
        rr.log("/image/hands", rr.Clear(recursive=True))
        rr.log("/hands3d", rr.Clear(recursive=True))
        for j, hand in enumerate(entry["hands"]):
            kp = np.asarray(hand["keypoints_2d"], float)
            colour = (230, 80, 60) if hand["handedness"] == "right" else (60, 120, 230)
            rr.log(
                f"/image/hands/{j}",
                rr.LineStrips2D([kp[[a, b]] for a, b in HAND_BONES], colors=colour),
                rr.Points2D(kp, colors=colour, radii=3.0),
            )
            if hand.get("keypoints_3d") is not None:
                rr.log(
                    f"/hands3d/{j}",
                    rr.LineStrips3D(
                        [np.asarray(hand["keypoints_3d"])[[a, b]] for a, b in HAND_BONES],
                        colors=colour,
                    ),
                )
