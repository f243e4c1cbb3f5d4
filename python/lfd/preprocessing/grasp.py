"""Grasp aperture: how far apart the fingers that hold an object are, whichever fingers they are.

Table I's gripper opening is the thumb-index tip distance ``|I - T|``. Real people grasp cubes
with the thumb and the middle finger as often as with the index (a third of the grasps in real
motion capture); the index then stays 12-15 cm from the thumb while the cube is held, and
``|I - T|`` says "open" through the whole carry. The *grasp aperture* fixes that with what is
known about the objects (their pose and size):

- a fingertip *touches* a box when its keypoint is within :data:`CONTACT_RADIUS` of the box's
  surface (the keypoint sits inside the finger pad, 6-8 mm from the skin, and carries noise);
- the thumb and a finger *oppose* each other on the box when both touch it and the box centre
  lies between them (each sees the centre in front of it along the line to the other);
- the aperture is the distance from the thumb tip to the closest finger that opposes it on some
  box, and ``|I - T|`` when no finger does (a hand in the air, or only brushing a box).

With a thumb-index pinch both definitions agree. A curled finger resting in the palm near the
thumb does not count (it does not touch the box on the side opposite the thumb), so an open
hand above a box still reads open.
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from ..demo import INDEX_TIP, THUMB_TIP
from ..geometry import box_distance

__all__ = [
    "APERTURES",
    "CONTACT_RADIUS",
    "OPPOSING_TIPS",
    "Aperture",
    "box_distance",
    "grasp_aperture",
]

Aperture = Literal["grasp", "thumb_index"]
APERTURES: tuple[Aperture, ...] = ("grasp", "thumb_index")
"""``grasp``: :func:`grasp_aperture` (default); ``thumb_index``: Table I's ``|I - T|``."""

CONTACT_RADIUS = 0.02
"""A fingertip keypoint this close to a box's surface (metres) touches it."""

OPPOSING_TIPS: tuple[int, ...] = (INDEX_TIP, 12, 16, 20)
"""Fingertips that can oppose the thumb: index, middle, ring, little finger."""


def grasp_aperture(
    keypoints: np.ndarray,
    object_position: np.ndarray,
    object_quaternion: np.ndarray,
    object_size: np.ndarray,
    *,
    contact_radius: float = CONTACT_RADIUS,
) -> np.ndarray:
    """The grasp aperture (n,) in metres (see the module docs).

    Parameters
    ----------
    keypoints : array, shape (n, 21, 3)
    object_position : array, shape (k, n, 3)
    object_quaternion : array, shape (k, n, 4), (x, y, z, w)
    object_size : array, shape (k, 3)
    contact_radius : float
        Distance from a box's surface within which a fingertip keypoint touches it.

    NaN keypoints give NaN; NaN object samples are ignored (that box is not touched there).
    """
    kp = np.asarray(keypoints, dtype=np.float64)
    thumb = kp[:, THUMB_TIP]
    aperture = np.linalg.norm(kp[:, INDEX_TIP] - thumb, axis=1)
    best = np.full(aperture.shape, np.inf)
    tips = kp[:, [THUMB_TIP, *OPPOSING_TIPS]]  # (n, 5, 3): the thumb, then the fingers
    span = tips[:, 1:] - thumb[:, None]  # thumb -> finger
    length = np.linalg.norm(span, axis=2)
    for pos, quat, size in zip(object_position, object_quaternion, object_size, strict=True):
        ok = np.isfinite(pos).all(axis=1) & np.isfinite(quat).all(axis=1)
        # the thumb touches the box only within its half diagonal and the contact radius of
        # the centre: the other samples cannot oppose (and are not measured)
        reach = 0.5 * float(np.linalg.norm(size)) + contact_radius + 1e-6
        with np.errstate(invalid="ignore"):
            near = np.flatnonzero(
                ok & (np.linalg.norm(thumb - np.where(ok[:, None], pos, 0.0), axis=1) <= reach)
            )
        if near.size == 0:
            continue
        c, q = pos[near], quat[near]
        th, tp, sp = thumb[near], tips[near], span[near]
        with np.errstate(invalid="ignore"):
            touch = box_distance(tp, c[:, None], q[:, None], size) <= contact_radius
            opposed = (
                touch[:, :1]
                & touch[:, 1:]
                & (np.einsum("ij,itj->it", c - th, sp) > 0)
                & (np.einsum("itj,itj->it", c[:, None] - tp[:, 1:], -sp) > 0)
            )
            best[near] = np.minimum(best[near], np.where(opposed, length[near], np.inf).min(axis=1))
    return np.where(np.isfinite(best), best, aperture)
