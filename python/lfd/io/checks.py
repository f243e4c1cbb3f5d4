"""What a recording shows before anyone segments it: does the hand reach an object, does any
object move.

Two recordings that load fine cannot be segmented honestly:

* the hand never comes near any object (:func:`closest_approach`): every skill but Move acts on
  an object, so there is nothing to segment; such a file almost always has its hand and its
  objects in different frames or units. :func:`check_hand_reaches` refuses it
  (:class:`~lfd.errors.DemonstrationError`: ``lfd segment``, ``eval``, ``reproduce --segment``
  stop with one error line; ``lfd info`` only warns);
* no object ever moves (:func:`object_travel`): a Locate or a recording of moves is fine, but a
  Move with, Place, Stack or Push found there came from the hand's motion alone.
  :func:`unmoved_objects_message` says so for the skills a segmentation found (``lfd segment``
  and ``eval`` warn; ``lfd reproduce --segment`` refuses to move objects the demonstrator did
  not move).
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass

import numpy as np

from ..demo import Demonstration, HandTrack
from ..errors import DemonstrationError
from ..geometry import box_distance

NEAR_M = 0.15
"""A hand that never comes this close (metres, any keypoint to an object's box) reaches no
object: a Locate points 4-8 cm above a box's top (docs/skills.md); every other skill touches it."""

MOVED_M = 0.02
"""An object whose centre never gets this far (metres) from where it starts has not moved:
tracked tags jitter by millimetres, a push moves a box several centimetres."""

MOVING_SKILLS: tuple[str, ...] = ("move_with", "place", "stack", "push")
"""The skills during which the object moves (docs/skills.md)."""


@dataclass(frozen=True)
class Approach:
    """The closest the hand comes to an object: distance (m) from the nearest hand keypoint to
    the object's box (0 inside it), which object and when (s from the first sample);
    ``object`` is None (and the distance infinite) when no object is ever seen with the hand;
    ``hand`` the side of the hand that comes closest (None with no object)."""

    distance_m: float
    object: str | None
    t_s: float | None
    hand: str | None = None


def _object_offsets(
    demo: Demonstration, hand: HandTrack
) -> Iterator[tuple[str, np.ndarray, np.ndarray]]:
    """For each object seen with a valid pose: its name, the offsets (n, 21, 3) of ``hand``'s
    keypoints from its centre (its pose sampled nearest in time to each hand sample) and the
    indices (n,) of those poses among its seen ones, with the quaternions of those."""
    th = hand.t_ns
    kp = hand.keypoints  # (n, 21, 3)
    for name, obj in demo.objects.items():
        seen = obj.visible & np.all(np.isfinite(obj.position), 1)
        seen &= np.all(np.isfinite(obj.quaternion), 1)
        if not seen.any():
            continue
        t, pos = obj.t_ns[seen], obj.position[seen]
        j = _nearest(t, th)
        yield name, kp - pos[j][:, None, :], obj.quaternion[seen][j]


def _nearest(t: np.ndarray, at: np.ndarray) -> np.ndarray:
    """Index of the time in ``t`` (sorted, not empty) nearest each of ``at`` (the earlier on a
    tie)."""
    j = np.clip(np.searchsorted(t, at), 1, max(t.size - 1, 1))
    return np.where(np.abs(t[j - 1] - at) <= np.abs(t[j] - at), j - 1, j) if t.size > 1 else 0 * j


def _centre_distances(offset: np.ndarray) -> np.ndarray:
    """Distances (n, 21) of offsets (n, 21, 3); NaN for unseen keypoints."""
    return np.sqrt(np.einsum("nkc,nkc->nk", offset, offset))


def comes_within(demo: Demonstration, near_m: float, *, chunk: int = 4096) -> bool:
    """Whether a keypoint of any hand comes within ``near_m`` of an object's centre (then it
    comes at least as near its box: the cheap test :func:`reach_message` makes first),
    ``chunk`` hand samples at a time (it stops at the first)."""
    return any(_hand_comes_within(demo, h, near_m, chunk) for h in demo.hands.values())


def _hand_comes_within(demo: Demonstration, hand: HandTrack, near_m: float, chunk: int) -> bool:
    th, kp = hand.t_ns, hand.keypoints
    for obj in demo.objects.values():
        seen = obj.visible & np.all(np.isfinite(obj.position), 1)
        seen &= np.all(np.isfinite(obj.quaternion), 1)
        if not seen.any():
            continue
        t, pos = obj.t_ns[seen], obj.position[seen]
        for a in range(0, len(th), chunk):
            j = _nearest(t, th[a : a + chunk])
            offset = kp[a : a + chunk] - pos[j][:, None, :]
            with np.errstate(invalid="ignore"):
                if np.any(_centre_distances(offset) <= near_m):
                    return True
    return False


def closest_approach(demo: Demonstration) -> Approach:
    """How close a hand (either of two) comes to any object (each hand sample against the
    object's pose sampled nearest in time; unseen keypoints and poses are left out)."""
    best = Approach(float("inf"), None, None)
    for side, hand in demo.hands.items():
        a = _hand_approach(demo, side, hand)
        if a.distance_m < best.distance_m:
            best = a
    return best


def _hand_approach(demo: Demonstration, side: str, hand: HandTrack) -> Approach:
    best = Approach(float("inf"), None, None)
    th = hand.t_ns
    if len(hand) == 0:
        return best
    for name, offset, quat in _object_offsets(demo, hand):
        obj = demo.objects[name]
        centre = _centre_distances(offset)  # >= the distance from the box
        if not np.isfinite(centre).any():
            continue
        # the box distance is at least the centre's less the half diagonal: only samples that
        # can come closer than the nearest centre are measured exactly (the same minimum)
        near = np.flatnonzero(
            np.any(centre - 0.5 * float(np.linalg.norm(obj.size)) <= np.nanmin(centre), axis=1)
        )
        # (m, 21), NaN for unseen keypoints
        dist = box_distance(offset[near], 0.0, quat[near][:, None], obj.size)
        flat = int(np.nanargmin(dist))
        d = float(dist.flat[flat])
        if d < best.distance_m:
            i = int(near[flat // dist.shape[1]])
            best = Approach(d, name, (int(th[i]) - demo.start_ns) * 1e-9, side)
    return best


def running_median(x: np.ndarray, size: int) -> np.ndarray:
    """``scipy.ndimage.median_filter(x, size=(size, 1), mode="nearest")`` along axis 0: the
    element of rank ``size // 2`` of the window ``i - size // 2 .. i + (size - 1) // 2``,
    the ends repeated."""
    half = size // 2
    padded = np.concatenate([np.repeat(x[:1], half, 0), x, np.repeat(x[-1:], size - 1 - half, 0)])
    windows = np.lib.stride_tricks.sliding_window_view(padded, size, axis=0)
    return np.asarray(np.partition(windows, half, axis=-1)[..., half])


def object_travel(demo: Demonstration) -> dict[str, float]:
    """How far (m) each object's centre gets from where it starts (a running median of 5
    samples first, so a single misdetected tag does not count as motion); 0 for an object
    seen fewer than twice."""
    out: dict[str, float] = {}
    for name, obj in demo.objects.items():
        seen = obj.visible & np.all(np.isfinite(obj.position), 1)
        pos = obj.position[seen]
        if len(pos) < 2:
            out[name] = 0.0
            continue
        smooth = running_median(pos, min(5, len(pos)))
        out[name] = float(np.max(np.linalg.norm(smooth - smooth[0], axis=1)))
    return out


def reach_message(demo: Demonstration, *, near_m: float = NEAR_M) -> str | None:
    """Why the hand reaches no object (None when it does, or when there is no object)."""
    if not demo.objects or comes_within(demo, near_m):
        return None
    a = closest_approach(demo)
    if a.distance_m <= near_m:
        return None
    if a.object is None:
        return "no object is ever seen while the hand is: nothing to segment"
    return (
        f"the hand never comes within {near_m:.2f} m of an object (closest {a.distance_m:.2f} m, "
        f"{a.object} at {a.t_s:.2f} s), so it acts on none: are the hand and the objects in one "
        "frame and unit?"
    )


def check_hand_reaches(demo: Demonstration, *, near_m: float = NEAR_M) -> None:
    """Refuse a recording whose hand reaches no object (see the module documentation).

    Raises
    ------
    DemonstrationError
        The hand never comes within ``near_m`` of any object's box.
    """
    message = reach_message(demo, near_m=near_m)
    if message is not None:
        raise DemonstrationError(message)


def unmoved_objects_message(
    demo: Demonstration | Mapping[str, float],
    skills: Iterable[str],
    *,
    source: str = "the segmentation",
    moved_m: float = MOVED_M,
) -> str | None:
    """A warning when ``skills`` (``source``'s: a segmentation's, the labels') include a skill
    that moves an object (:data:`MOVING_SKILLS`) but no object of ``demo`` (a demonstration,
    or its :func:`object_travel`) moves; else None."""
    found = [s for s in dict.fromkeys(skills) if s in MOVING_SKILLS]
    if not found or not (demo if isinstance(demo, Mapping) else demo.objects):
        return None
    travel = demo if isinstance(demo, Mapping) else object_travel(demo)
    if max(travel.values()) >= moved_m:
        return None
    return (
        f"no object moves (at most {1000 * max(travel.values()):.1f} mm), yet {source} has "
        f"{', '.join(found)}, which move one: are the object tracks right?"
    )
