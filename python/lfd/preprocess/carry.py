"""Fill an object's tracking gap while it is carried by the hand.

A tag on a carried object is often hidden by the hand for the whole carry, longer than any gap
that interpolation may bridge. When the hand holds the object at both ends of such a gap (the
TCP is within grasp distance of the object just before and just after it), the object moved
with the hand: its position is the TCP plus an offset that changes linearly from the offset at
the start of the gap to the offset at its end, and its orientation is slerped between the two
ends. Every filled gap is reported; gaps that do not start and end in the hand stay NaN.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation, Slerp


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """Half-open index ranges where ``mask`` is True."""
    edges = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True))


def fill_carried_gaps(
    position: np.ndarray,
    quaternion: np.ndarray,
    valid: np.ndarray,
    tcp: np.ndarray,
    hand_valid: np.ndarray,
    grasp_radius: float,
) -> list[tuple[int, int]]:
    """Fill, in place, the gaps of one object during which the hand carried it.

    Parameters
    ----------
    position : array, shape (n, 3)
        Object positions, NaN inside gaps (modified in place).
    quaternion : array, shape (n, 4)
        Object orientations (x, y, z, w), NaN inside gaps (modified in place).
    valid : array, shape (n,)
        True where the object pose is known (modified in place).
    tcp : array, shape (n, 3)
        Tool centre point; NaN where the hand is unknown.
    hand_valid : array, shape (n,)
        True where the hand is known.
    grasp_radius : float
        Largest TCP-object distance (m) at which the object counts as held.

    Returns
    -------
    list of (start, end)
        The filled gaps as half-open sample ranges.
    """
    filled = []
    n = len(valid)
    for a, b in _runs(~valid):
        if a == 0 or b >= n or not hand_valid[a - 1 : b + 1].all():
            continue
        off0 = position[a - 1] - tcp[a - 1]
        off1 = position[b] - tcp[b]
        if max(np.linalg.norm(off0), np.linalg.norm(off1)) > grasp_radius:
            continue
        w = ((np.arange(a, b) - (a - 1)) / (b - (a - 1)))[:, None]
        position[a:b] = tcp[a:b] + (1.0 - w) * off0 + w * off1
        ends = Rotation.from_quat(np.stack([quaternion[a - 1], quaternion[b]]))
        quaternion[a:b] = Slerp([0.0, 1.0], ends)(w[:, 0]).as_quat()
        valid[a:b] = True
        filled.append((int(a), int(b)))
    return filled
