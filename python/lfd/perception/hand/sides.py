"""Both hands from one depth image, with the depth network trained on right hands.

The points above the table and outside the tagged boxes (:func:`~lfd.perception.hand.dataset.
hand_points`) are the demonstrator's hands and forearms. They are split into connected blobs
(voxels of :data:`VOXEL_M`, 26-connected): the two largest are the two arms (an object held
between the hands is a tagged box, whose points are removed, so the hands of a handover or a
two-handed carry fall apart), each smaller one joins the nearest arm, or is dropped when far
from both. An arm is the right one when its end nearest the demonstrator (its forearm, the -y
end) lies at larger world x than the other's; a single arm is the right one when that end is at
x >= 0. The left arm is mirrored (world x -> -x) before the network, which then sees a right
hand, and its keypoints are mirrored back: the simulated left hand is exactly the right one
mirrored (:class:`~lfd.sim.hand.MirroredKinematics`).

:class:`DepthHands` wraps a :class:`~lfd.perception.hand.infer.HandEstimator`; its
:meth:`~DepthHands.side` views are one-hand estimators (``estimate_with_spread``) that share the
split of each frame, so ``lfd record`` writes one hand topic per view.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from ...demo import HAND_SIDES
from ...errors import LfdError
from .dataset import MIN_POINTS, backproject, hand_points

VOXEL_M = 0.015
"""Side of the voxels whose 26-neighbourhood connects the points of one arm (m)."""
JOIN_M = 0.06
"""A small blob joins the nearest arm when a point of it is this close (m), else it is dropped."""

Box = tuple[np.ndarray, np.ndarray, np.ndarray]


def split_arms(points: np.ndarray) -> dict[str, np.ndarray]:
    """The hand points (m, 4) of each arm by side (``"right"``, ``"left"``); an arm with fewer
    than :data:`~lfd.perception.hand.dataset.MIN_POINTS` points is not in view."""
    if len(points) < MIN_POINTS:
        return {}
    from scipy import ndimage

    ijk = np.floor(points[:, :3] / VOXEL_M).astype(np.int64)
    ijk -= ijk.min(axis=0)
    grid = np.zeros(tuple(ijk.max(axis=0) + 1), bool)
    grid[tuple(ijk.T)] = True
    labels, n = ndimage.label(grid, structure=np.ones((3, 3, 3), bool))
    comp = labels[tuple(ijk.T)]
    counts = np.bincount(comp, minlength=n + 1)
    counts[0] = 0
    order = [int(c) for c in np.argsort(counts)[::-1] if counts[c] >= MIN_POINTS][:2]
    if not order:
        return {}
    members = {c: comp == c for c in order}
    for c in range(1, n + 1):  # fragments join the nearest arm
        if c in members or counts[c] == 0:
            continue
        frag = points[comp == c, :3]
        dist = {
            a: float(np.min(np.linalg.norm(points[m, :3][None, :, :] - frag[:, None, :], axis=2)))
            if frag.shape[0] * int(m.sum()) <= 2_000_000
            else float(np.linalg.norm(points[m, :3].mean(0) - frag.mean(0)))
            for a, m in members.items()
        }
        best = min(dist, key=lambda a: dist[a])
        if dist[best] <= JOIN_M:
            members[best] |= comp == c
    roots = {c: _root_x(points[m]) for c, m in members.items()}
    if len(order) == 1:
        c = order[0]
        return {"right" if roots[c] >= 0.0 else "left": points[members[c]]}
    right, left = sorted(order, key=lambda c: -roots[c])
    return {"right": points[members[right]], "left": points[members[left]]}


def _root_x(points: np.ndarray) -> float:
    """World x of an arm's end nearest the demonstrator (its points of lowest y)."""
    y = points[:, 1]
    near = points[y <= np.quantile(y, 0.1), 0]
    return float(near.mean())


def _mirrored(points: np.ndarray) -> np.ndarray:
    out = np.array(points, dtype=np.float64, copy=True)
    out[..., 0] *= -1.0
    return out


class DepthHands:
    """Both hands of each depth frame from a right-hand depth network (module docstring).

    Parameters
    ----------
    net : HandEstimator
        The depth network (:class:`~lfd.perception.hand.infer.HandEstimator`).
    """

    def __init__(self, net: Any) -> None:
        self.net = net
        self.info: dict[str, Any] = {**getattr(net, "info", {}), "hands": "both (split arms)"}
        self._key: tuple[int, int] | None = None
        self._arms: dict[str, np.ndarray] = {}

    def side(self, side: str) -> DepthSide:
        """The one-hand estimator of the ``side`` hand."""
        if side not in HAND_SIDES:
            raise LfdError(f"hand must be one of {', '.join(HAND_SIDES)}, got {side!r}")
        return DepthSide(self, side)

    def arms(
        self,
        depth_mm: np.ndarray,
        K: np.ndarray,
        world_T_camera: np.ndarray,
        boxes: Sequence[Box] = (),
    ) -> dict[str, np.ndarray]:
        """The hand points of each arm in this depth frame (computed once per frame)."""
        key = (id(depth_mm), int(np.asarray(depth_mm).sum(dtype=np.int64)))
        if key != self._key:
            d = np.asarray(depth_mm)
            if d.ndim != 2 or not np.issubdtype(d.dtype, np.integer):
                raise LfdError(
                    f"depth image must be (H, W) integer millimetres, got {d.dtype} {d.shape}"
                )
            pts = hand_points(
                backproject(d, np.asarray(K, float), np.asarray(world_T_camera, float)), boxes
            )
            self._arms, self._key = split_arms(pts), key
        return self._arms

    def estimate_side(
        self,
        side: str,
        depth_mm: np.ndarray,
        K: np.ndarray,
        world_T_camera: np.ndarray,
        boxes: Sequence[Box] = (),
    ) -> tuple[np.ndarray, np.ndarray] | None:
        """Keypoints (21, 3) of the ``side`` hand and their spread (21,), or None."""
        pts = self.arms(depth_mm, K, world_T_camera, boxes).get(side)
        if pts is None:
            return None
        if side == "right":
            return self.net.estimate_points(pts)  # type: ignore[no-any-return]
        found = self.net.estimate_points(_mirrored(pts))
        if found is None:
            return None
        kp, spread = found
        return _mirrored(kp), spread


class DepthSide:
    """One hand of a :class:`DepthHands`, with the one-hand estimator's interface."""

    def __init__(self, hands: DepthHands, side: str) -> None:
        self.hands, self.hand_side = hands, side
        self.info = {**hands.info, "side": side}

    def estimate_with_spread(
        self,
        depth_mm: np.ndarray,
        K: np.ndarray,
        world_T_camera: np.ndarray,
        boxes: Sequence[Box] = (),
    ) -> tuple[np.ndarray, np.ndarray] | None:
        return self.hands.estimate_side(self.hand_side, depth_mm, K, world_T_camera, boxes)
