"""Fill an object's tracking gap while it is carried by the hand.

A tag on a grasped object is often hidden by the hand from the approach to the release, longer
than any gap that interpolation may bridge. For such a gap: if the object ends where it started
(within 1 cm) it rested and is interpolated; if it moved, it was carried when the TCP came
within grasp distance of its old pose and later of its new pose: the hand grasps it where it
comes closest to the old pose (first visit) and releases it where it comes closest to the new
one (last visit). Before the grasp it rests at the old pose, after the release at the new one, and
in between it follows the TCP with an offset that changes linearly from the grasp offset to the
release offset, its orientation slerped between the two. The hand may be unseen in part of the
gap (lifted out of the camera's view): its TCP is bridged linearly there. Every filled gap is
reported; a moved object that the hand never reached keeps its gap (NaN).

A recording still being made does not know yet where a hidden object reappears.
:func:`carry_open_end` guesses that an object hidden since the hand reached it is carried. A
complete recording concludes it only from evidence (:func:`lfd.preprocessing.preprocess`): the
camera has had the object's last seen pose in clear view (no hand, forearm or other object near
the line of sight: :func:`in_clear_view`) for :data:`EMPTY_S` without seeing its tag there, so it
is no longer there.
"""

from __future__ import annotations

import numpy as np

from .. import rotations

REST_TOLERANCE = 0.01
"""An object that moved less than this (m) across a gap was resting: the gap is interpolated."""

HAND_SEEN = 0.5
"""A gap is filled from the hand when the hand was seen in at least this share of it, at its two
ends among them (the TCP is bridged linearly over the frames it was not: a hand lifting an
object out of the camera's view)."""


SIGHT_MARGIN_M = 0.02
"""An occluder nearer than this plus its own radius and the object's half size to the line of
sight from an object's last seen pose to the camera may hide the object's tag."""

FINGER_M = 0.01
"""Radius of the hand about its keypoints (m)."""

FOREARM_M = 0.26
"""Length of the forearm, from the wrist away from the middle finger's base, whose points may hide
a tag too (it has no keypoints)."""

FOREARM_RADIUS_M = 0.035
"""Radius of the forearm (m)."""

EMPTY_S = 0.3
"""How long an object's last seen pose must be in clear view without its tag before it counts as
moved (tags are detected on every camera frame, at 30 Hz: nine missed detections)."""

WRIST, MIDDLE_MCP = 0, 9


def occluders(keypoints: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Points of the hand that may hide a tag, per sample, and their radii: the 21 keypoints
    ``(n, 21, 3)`` and points every 3 cm along the forearm, from the wrist away from the middle
    finger's base (NaN where the hand is unknown)."""
    kp = np.asarray(keypoints, dtype=float)
    axis = kp[:, WRIST] - kp[:, MIDDLE_MCP]
    norm = np.linalg.norm(axis, axis=1, keepdims=True)
    unit = axis / np.where(norm > 1e-9, norm, np.nan)
    steps = np.arange(0.03, FOREARM_M + 1e-9, 0.03)
    arm = kp[:, WRIST, None, :] + steps[None, :, None] * unit[:, None, :]
    radii = np.concatenate([np.full(kp.shape[1], FINGER_M), np.full(steps.size, FOREARM_RADIUS_M)])
    return np.concatenate([kp, arm], axis=1), radii


def in_clear_view(
    spot: np.ndarray, camera: np.ndarray, points: np.ndarray, radius: np.ndarray | float
) -> np.ndarray:
    """Per sample, whether no point of ``points`` ``(n, k, 3)`` comes within its ``radius``
    (one per point, or one for all) of the segment from ``spot`` to ``camera`` (a sample with
    an unknown point is not clear)."""
    sight = np.asarray(camera, dtype=float) - spot
    length = float(np.linalg.norm(sight))
    rel = np.asarray(points, dtype=float) - spot
    along = np.clip(rel @ (sight / length), 0.0, length)
    dist = np.linalg.norm(rel - along[..., None] * (sight / length), axis=-1)
    return np.asarray(np.where(np.isfinite(dist), dist > radius, False).all(axis=1))


def seen_empty(clear: np.ndarray, samples: int) -> bool:
    """Whether ``clear`` holds for ``samples`` samples in a row."""
    c = np.asarray(clear, dtype=bool)
    if samples <= 0:
        return True
    if c.size < samples:
        return False
    # a window of ``samples`` all clear: its count of clear samples is ``samples``
    counts = np.convolve(c.astype(np.int64), np.ones(samples, dtype=np.int64), mode="valid")
    return bool((counts == samples).any())


def covered(spot: np.ndarray, half: float, others: list[np.ndarray], samples: int) -> bool:
    """Whether another object rests on ``spot`` (an object's last seen centre, ``half`` its
    largest half side): one of ``others`` (each other object's positions ``(n, 3)``, its gaps
    filled) ends within ``half`` of it horizontally and above it, still (within
    :data:`REST_TOLERANCE`) for its last ``samples`` samples. The base of a stack, its tag under
    the object put on it, rests: no hand carries it away from under another."""
    for p in others:
        end = p[-1]
        if not np.isfinite(end).all() or end[2] <= spot[2] + REST_TOLERANCE:
            continue
        if np.linalg.norm(end[:2] - spot[:2]) > half:
            continue
        tail = p[-samples - 1 :]
        if np.isfinite(tail).all() and np.linalg.norm(tail - end, axis=1).max() < REST_TOLERANCE:
            return True
    return False


RELEASE_REACH = 2.0
"""An object that moved while hidden, from a place the hand reached, was carried by the hand: if
the hand never came within the grasp radius of the new place, it let go where it came closest to
it in its last visit within this many times that radius (a hand estimated from depth at 5 Hz may
be several centimetres off the object it holds)."""


def _bridged(tcp: np.ndarray, seen: np.ndarray) -> np.ndarray:
    """``tcp`` ``(m, 3)`` with the samples not ``seen`` interpolated linearly between the seen
    ones (the first and last are seen)."""
    out = np.array(tcp, dtype=float)
    if seen.all():
        return out
    k = np.flatnonzero(seen)
    i = np.arange(len(out))
    for c in range(out.shape[1]):
        out[:, c] = np.interp(i, k, out[k, c])
    return out


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """Half-open index ranges where ``mask`` is True."""
    edges = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True))


def _closest_in_run(dist: np.ndarray, near: np.ndarray, first: bool) -> int:
    """Index of the smallest ``dist`` in the first (or last) run of consecutive ``near`` indices."""
    breaks = np.flatnonzero(np.diff(near) > 1)
    run = near[: breaks[0] + 1] if first and breaks.size else near
    if not first and breaks.size:
        run = near[breaks[-1] + 1 :]
    return int(run[np.argmin(dist[run])])


def _grasp_release(d0: np.ndarray, d1: np.ndarray, radius: float) -> tuple[int, int] | None:
    """Grasp and release samples from the TCP distances to the old and the new pose.

    The hand closes on the object where it comes closest to the old pose, in its first visit
    within ``radius``, and lets go where it comes closest to the new pose, in its last visit.
    None when the hand never reached one of the two poses or let go before it grasped.
    """
    near0, near1 = np.flatnonzero(d0 <= radius), np.flatnonzero(d1 <= radius)
    if not len(near1):
        near1 = np.flatnonzero(d1 <= RELEASE_REACH * radius)
    if not len(near0) or not len(near1):
        return None
    g, r = _closest_in_run(d0, near0, first=True), _closest_in_run(d1, near1, first=False)
    return (g, r) if g < r else None


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
        if a == 0 or b >= n or not (hand_valid[a - 1] and hand_valid[b]):
            continue
        seen = hand_valid[a - 1 : b + 1]
        if seen.mean() < HAND_SEEN:
            continue
        p0, p1 = position[a - 1].copy(), position[b].copy()
        idx = np.arange(a, b)
        if np.linalg.norm(p1 - p0) < REST_TOLERANCE:  # hidden while resting: it stayed put
            w = ((idx - (a - 1)) / (b - (a - 1)))[:, None]
            position[a:b] = (1.0 - w) * p0 + w * p1
            quaternion[a:b] = quaternion[a - 1]
        else:
            span = _bridged(tcp[a - 1 : b + 1], seen)
            d0, d1 = np.linalg.norm(span - p0, axis=1), np.linalg.norm(span - p1, axis=1)
            found = _grasp_release(d0, d1, grasp_radius)
            if found is None:
                continue  # the hand never reached the object: no evidence it carried it
            g, r = a - 1 + found[0], a - 1 + found[1]
            held_tcp = span[found[0] : found[1] + 1]
            off0, off1 = p0 - held_tcp[0], p1 - held_tcp[-1]
            w = ((np.arange(g, r + 1) - g) / (r - g))[:, None]
            carried = held_tcp + (1.0 - w) * off0 + w * off1
            ends = np.stack([quaternion[a - 1], quaternion[b]])
            turned = rotations.slerp([0.0, 1.0], ends, w[:, 0])
            q0, q1 = quaternion[a - 1].copy(), quaternion[b].copy()
            before, after = idx[idx < g], idx[idx > r]
            held = idx[(idx >= g) & (idx <= r)]
            position[before], quaternion[before] = p0, q0
            position[after], quaternion[after] = p1, q1
            position[held], quaternion[held] = carried[held - g], turned[held - g]
        valid[a:b] = True
        filled.append((int(a), int(b)))
    return filled


def carry_open_end(
    position: np.ndarray,
    quaternion: np.ndarray,
    valid: np.ndarray,
    tcp: np.ndarray,
    hand_valid: np.ndarray,
    grasp_radius: float,
    rate_hz: float,
) -> tuple[int, int] | None:
    """Fill, in place, an object's gap that runs to the end of the recording (so far), when the
    hand reached the object in it: the grasp of :func:`fill_carried_gaps` (where the TCP comes
    closest to the last seen pose, in its first visit), the object at rest before it, following
    the TCP at the grasp offset after it, and at rest again from where the hand sets it down
    (:func:`set_down`; where it reappears is not known, ``rate_hz`` the samples' rate). Returns
    the filled half-open range, or None (no trailing gap, or the hand never reached the object:
    :func:`hold_ends` holds it at rest)."""
    seen = np.flatnonzero(valid)
    if not seen.size or seen[-1] == len(valid) - 1:
        return None
    last = int(seen[-1])
    p0, q0 = position[last].copy(), quaternion[last].copy()
    span = tcp[last:]
    ok = hand_valid[last:] & np.isfinite(span).all(axis=1)
    d0 = np.where(ok, np.linalg.norm(np.where(ok[:, None], span, 0.0) - p0, axis=1), np.inf)
    near = np.flatnonzero(d0 <= grasp_radius)
    if not near.size:
        return None
    g = last + _closest_in_run(d0, near, first=True)
    off = p0 - tcp[g]
    put = set_down(tcp, hand_valid, g, rate_hz)
    # from the grasp on (to where the hand sets it down), the object follows the TCP where the
    # hand is known and stays where it was last carried to where it is not
    idx = np.arange(last + 1, len(valid))
    follows = (idx >= g) & (idx <= (put if put is not None else len(valid))) & hand_valid[idx]
    follows &= np.isfinite(tcp[idx]).all(axis=1)
    src = np.maximum.accumulate(np.where(follows, np.arange(idx.size), -1))
    position[idx] = np.where((src >= 0)[:, None], tcp[idx[np.maximum(src, 0)]] + off, p0)
    quaternion[idx] = q0
    valid[last + 1 :] = True
    return last + 1, len(valid)


LIFT_M = 0.02
"""A hand that rose this much (m) above where it grasped an object has lifted it..."""

STILL_MPS = 0.05
"""...and sets it down where it next comes lowest while moving slower than this (m/s)."""


def set_down(tcp: np.ndarray, hand_valid: np.ndarray, grasp: int, rate_hz: float) -> int | None:
    """Where a hand that grasped an unseen object at sample ``grasp`` sets it down: after it
    lifted (:data:`LIFT_M` above the grasp), the first sample where the TCP comes lowest
    (lower than both neighbours) and moves slower than :data:`STILL_MPS`; None if it has not
    (the recording so far ends while it carries it)."""
    z = tcp[:, 2]
    ok = hand_valid & np.isfinite(tcp).all(axis=1)
    up = np.flatnonzero(ok[grasp:] & (z[grasp:] >= z[grasp] + LIFT_M))
    if not up.size:
        return None
    speed = np.full(len(z), np.inf)
    speed[1:-1] = np.linalg.norm(tcp[2:] - tcp[:-2], axis=1) * rate_hz / 2
    i = np.arange(grasp + int(up[0]) + 1, len(z) - 1)
    low = ok[i - 1] & ok[i] & ok[i + 1] & (z[i] <= z[i - 1]) & (z[i] < z[i + 1])
    # come down from the highest point since the lift, not a pause in the carry
    high = np.maximum.accumulate(np.where(ok, z, -np.inf)[grasp + int(up[0]) :])
    down = z[i] <= high[i - grasp - int(up[0])] - LIFT_M
    found = i[low & down & (speed[i] < STILL_MPS)]
    return int(found[0]) if found.size else None


def hold_ends(
    position: np.ndarray, quaternion: np.ndarray, valid: np.ndarray
) -> list[tuple[int, int]]:
    """Hold an object at its first / last seen pose before / after it was seen (in place).

    An object is at rest until something moves it, and nothing can move it unseen at the start
    or end of a recording without the hand (which :func:`fill_carried_gaps` covers inside).
    Returns the filled half-open ranges. ``valid`` must have at least one True entry.
    """
    seen = np.flatnonzero(valid)
    first, last = int(seen[0]), int(seen[-1])
    held = []
    if first > 0:
        position[:first], quaternion[:first] = position[first], quaternion[first]
        held.append((0, first))
    if last < len(valid) - 1:
        position[last + 1 :], quaternion[last + 1 :] = position[last], quaternion[last]
        held.append((last + 1, len(valid)))
    valid[:first] = True
    valid[last + 1 :] = True
    return held
