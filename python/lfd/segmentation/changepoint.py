"""Change points + contact rules: the OKAMI / ORION-style baseline (issue 13).

Five per-frame signals of the preprocessed trajectory, each divided by a fixed physical unit
(:data:`UNITS`; not z-scored, so a still box's noise stays small), downsampled to about 10 Hz:

* hand speed ``|d TCP / dt|``;
* grasp aperture, the smallest thumb-tip-to-fingertip distance (index, middle, ring or little
  finger: people also grasp with the thumb and the middle finger);
* contact distance, from the TCP to the surface of the nearest box (its pose and size are known;
  0 inside the box), capped at :data:`FAR`;
* box speed, the fastest box's ``|d p / dt|``;
* box lift, the highest box's height above its resting height at the start.

``ruptures.KernelCPD(kernel="rbf", min_size=2)`` cuts the signal with a penalty; contact rules
then name each segment, walking forward with the object in hand:

* a box moves, lifted or carried by the hand -> ``move_with``; its last motion while lowering
  and coming to rest -> ``place``, or ``stack`` when it rests on another box (then released);
* a box slides on the table next to the hand, nothing held -> ``push``;
* the box still, the hand in contact or reaching it -> ``pick_up`` if the box's next motion is a
  lift, ``push`` if it is a slide; after a place, the release at the box -> ``place``/``stack``;
* the hand slow and hovering over a box without touching it -> ``locate``;
* anything else -> ``move`` (``move_with`` while holding).

Adjacent segments with the same skill and object are merged. No templates, no grammar.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from ..demo import INDEX_TIP, THUMB_TIP, Demonstration
from ..errors import UsageError
from ..geometry import box_distance
from ..preprocessing.filters import finite_runs
from ..skills import SKILLS
from ..trajectory import Trajectory
from .drafts import _make_segment
from .gaps import fill_gaps
from .pipeline import as_trajectory
from .result import Segmentation

DEFAULT_PENALTY = 0.02
"""KernelCPD penalty (signals at 10 Hz, rbf ``gamma`` 0.5): the value with the highest mean frame
accuracy on training demos only (careful-style simulated exp1-4, seeds 0-29) in
``benches/changepoint_penalty.py``. The curve is flat below 1 (82.3 % at 0.02, 81.5 % at 0.5,
80.4 % at 1) and falls beyond (65 % at 5): fine cuts lose nothing, since the contact rules name
every 0.2 s piece."""

RATE_HZ = 10.0
"""Rate the signals are downsampled to before change-point detection."""

FINGERTIPS = (8, 12, 16, 20)
"""Keypoint indices of the index, middle, ring and little fingertips (MediaPipe order)."""

UNITS = {"hand_speed": 0.1, "aperture": 0.02, "contact": 0.03, "box_speed": 0.05, "lift": 0.02}
"""The physical unit of each signal (m/s or m): a change of one unit is a change worth a cut."""

FAR = 0.15
"""Contact distances beyond this (m) are all 'far'."""

CONTACT = 0.02
"""The TCP within this distance (m) of a box's surface touches it."""

REACH = 0.18
"""A reach to a box (pick up, push, locate) starts within this distance (m) of its surface."""

MOVING = 0.04
"""A box faster than this (m/s) moves ..."""

MIN_SHIFT = 0.015
"""... if it moves by more than this (m) in all."""

LIFTED = 0.015
"""A box this much (m) above its resting height is off its support."""

DESCENT = 0.01
"""A box sinking faster than this (m/s) at the end of a carry is being put down."""

ENTRY = 0.04
"""A reach starts at least this far (m) from the box (it ends in a slow final approach)."""

NOISE_SPEED = 0.01
"""Hand speed changes smaller than this (m/s) are noise."""

HOVER_HEIGHT = (0.02, 0.14)
"""Locate: the index fingertip between 2 and 14 cm above the box top ..."""

HOVER_RADIUS = 0.08
"""... within 8 cm of its centre horizontally ..."""

HOVER_SPEED = 0.08
"""... slower than 8 cm/s ..."""

MIN_HOVER_S = 0.4
"""... for at least 0.4 s."""


@dataclass
class _Signals:
    idx: np.ndarray  # (m,) trajectory sample of each 10 Hz frame
    dt: float  # their period, s
    hand_speed: np.ndarray  # (m,)
    aperture: np.ndarray  # (m,)
    contact: np.ndarray  # (k, m) TCP-to-surface distance per box
    above: np.ndarray  # (k, m) index fingertip height above the box top
    horizontal: np.ndarray  # (k, m) horizontal index-fingertip-to-centre distance
    position: np.ndarray  # (k, m, 3) box centres
    box_speed: np.ndarray  # (k, m)
    velocity_z: np.ndarray  # (k, m) vertical box velocity
    lift: np.ndarray  # (k, m) height above the resting height

    def matrix(self) -> np.ndarray:
        """The scaled signal that the change points are detected on, shape (m, 5)."""
        cols = [
            self.hand_speed / UNITS["hand_speed"],
            self.aperture / UNITS["aperture"],
            np.minimum(self.contact.min(axis=0), FAR) / UNITS["contact"],
            self.box_speed.max(axis=0) / UNITS["box_speed"],
            np.clip(self.lift.max(axis=0), 0.0, None) / UNITS["lift"],
        ]
        return np.stack(cols, axis=1)


def _fill(x: np.ndarray) -> np.ndarray:
    ok = np.isfinite(x)
    if ok.all() or not ok.any():
        return np.nan_to_num(x)
    i = np.arange(x.shape[0])
    return np.interp(i, i[ok], x[ok])


def _signals(traj: Trajectory, rate_hz: float) -> _Signals:
    step = max(1, round(1.0 / (rate_hz * traj.dt))) if traj.dt > 0 else 1
    idx = np.arange(0, len(traj), step)
    dt = traj.dt * step
    tcp = traj.tcp[idx]
    kp = traj.keypoints[idx]
    tip = np.stack([_fill(kp[:, INDEX_TIP, c]) for c in range(3)], axis=1)  # points at a box
    aperture = _fill(np.min(np.linalg.norm(kp[:, FINGERTIPS] - kp[:, [THUMB_TIP]], axis=2), axis=1))

    def grad(x: np.ndarray, axis: int) -> np.ndarray:
        return np.gradient(x, dt, axis=axis) if x.shape[axis] > 1 else np.zeros_like(x)

    hand_speed = np.linalg.norm(grad(tcp, 0), axis=-1)
    pos = traj.object_position[:, idx]
    k, m = pos.shape[:2]
    contact, above = np.empty((k, m)), np.empty((k, m))
    for i in range(k):
        size = traj.object_size[i]
        contact[i] = box_distance(tcp, pos[i], traj.object_quaternion[i, idx], size)
        above[i] = tip[:, 2] - pos[i, :, 2] - 0.5 * size[2]
    horizontal = np.linalg.norm(tip[None, :, :2] - pos[:, :, :2], axis=2)
    velocity = grad(pos, 1)
    rest = np.median(pos[:, : max(1, round(0.5 / dt)), 2], axis=1)
    return _Signals(
        idx=idx,
        dt=dt,
        hand_speed=hand_speed,
        aperture=aperture,
        contact=contact,
        above=above,
        horizontal=horizontal,
        position=pos,
        box_speed=np.linalg.norm(velocity, axis=-1),
        velocity_z=velocity[..., 2],
        lift=pos[:, :, 2] - rest[:, None],
    )


def _episodes(s: _Signals, k: int, dt: float) -> list[tuple[int, int]]:
    """Motions ``[a, b)`` of box ``k``: runs faster than :data:`MOVING`, joined across short
    stops and across stops in the air (a carry paused above both ends), at least
    :data:`MIN_SHIFT` long in displacement."""
    runs = finite_runs(s.box_speed[k] > MOVING)
    out: list[tuple[int, int]] = []
    for a, b in runs:
        if out:
            pa, pb = out[-1]
            floor = max(s.lift[k, pa], s.lift[k, b - 1]) + LIFTED
            if (a - pb) * dt < 0.3 or s.lift[k, pb:a].min() > floor:
                out[-1] = (pa, b)
                continue
        out.append((a, b))
    return [(a, b) for a, b in out if np.ptp(s.position[k, a:b], axis=0).max() > MIN_SHIFT]


def _approach_start(s: _Signals, k: int, first: int, free: np.ndarray) -> int:
    """Where the hand's reach to box ``k`` (touched or hovered over from ``first``) starts: going
    back over free frames within :data:`REACH` of the box, past the reach's peak speed, to the
    speed minimum before it (at least :data:`ENTRY` from the box); frame 0 if the reach is
    under way when the recording starts."""
    v = s.hand_speed
    t = first
    while t > 0 and free[t - 1] and s.contact[k, t - 1] < REACH:
        if v[t - 1] < v[t] - NOISE_SPEED and s.contact[k, t] > ENTRY:
            break  # passed the peak: now going back down into the valley
        t -= 1
    while t > 0 and free[t - 1] and s.contact[k, t - 1] < REACH and v[t - 1] <= v[t] + NOISE_SPEED:
        t -= 1
    return 0 if t > 0 and (s.contact[k, :t] < REACH).all() and free[:t].all() else t


REACHES = (SKILLS.index("pick_up"), SKILLS.index("push"))


def _frame_states(s: _Signals, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """The contact rules frame by frame: skill index into :data:`lfd.skills.SKILLS` and object
    (-1: none) of every 10 Hz frame."""
    m = len(s.idx)
    skill = np.full(m, SKILLS.index("move"))
    obj = np.full(m, -1)
    free = np.ones(m, dtype=bool)

    def put(a: int, b: int, name: str, k: int) -> None:
        skill[a:b], obj[a:b], free[a:b] = SKILLS.index(name), k, False

    events = []
    for k in range(s.contact.shape[0]):
        for a, b in _episodes(s, k, dt):
            lifted = s.lift[k, a:b].max() - max(s.lift[k, a], s.lift[k, b - 1]) > LIFTED
            events.append((a, b, k, lifted))
    for a, b, k, lifted in sorted(events):
        if not lifted:
            put(a, b, "push", k)
            after = "push"
        else:
            # the final descent to the resting place is the place / stack
            p = b - 1
            while p > a and s.velocity_z[k, p - 1] < -DESCENT:
                p -= 1
            rest = np.median(s.lift[k, b : b + round(1.0 / dt)]) if b < m else s.lift[k, -1]
            after = "stack" if rest > LIFTED else "place"
            put(a, p, "move_with", k)
            put(p, b, after, k)
        e = b
        while e < m and free[e] and s.contact[k, e] < CONTACT:
            e += 1
        put(b, e, after, k)  # release
        c = a
        while c > 0 and free[c - 1] and s.contact[k, c - 1] < CONTACT:
            c -= 1
        put(_approach_start(s, k, c, free), a, "pick_up" if lifted else "push", k)
    # locate: slow, over a box, not touching it
    near = np.argmin(s.horizontal, axis=0)
    cols = np.arange(m)
    hover = (
        free
        & (s.hand_speed < HOVER_SPEED)
        & (s.contact[near, cols] >= CONTACT)
        & (s.above[near, cols] > HOVER_HEIGHT[0])
        & (s.above[near, cols] < HOVER_HEIGHT[1])
        & (s.horizontal[near, cols] < HOVER_RADIUS)
    )
    for a, b in finite_runs(hover):
        k = int(np.bincount(near[a:b]).argmax())
        soon = slice(b, b + round(0.5 / dt))
        touched = np.isin(skill[soon], REACHES) & (obj[soon] == k)
        if (b - a) * dt >= MIN_HOVER_S and not touched.any():  # not the start of a reach
            put(_approach_start(s, k, a, free), b, "locate", k)
    return skill, obj


def changepoint_segmentation(
    demo_or_traj: Demonstration | Trajectory,
    *,
    penalty: float = DEFAULT_PENALTY,
    rate_hz: float = RATE_HZ,
) -> Segmentation:
    """Segment by kernel change points and name the segments by contact rules (module docs).

    Parameters
    ----------
    demo_or_traj : Demonstration or Trajectory
        A recording (preprocessed here) or an already preprocessed trajectory.
    penalty : float
        ``KernelCPD.predict(pen=...)``: larger gives fewer change points (> 0).
    rate_hz : float
        Rate of the signals the change points are detected on (> 0, at most the trajectory's).

    Raises
    ------
    UsageError
        ``penalty`` or ``rate_hz`` is not a positive finite number.
    DemonstrationError
        No hand data or no tracked object.
    """
    import ruptures

    for name, value in (("penalty", penalty), ("rate_hz", rate_hz)):
        if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
            raise UsageError(f"change-point {name} must be a positive number, got {value!r}")
    traj, warnings = fill_gaps(as_trajectory(demo_or_traj))
    s = _signals(traj, rate_hz)
    m = len(s.idx)
    cuts = [0]
    if m >= 4:
        algo = ruptures.KernelCPD(kernel="rbf", min_size=2, params={"gamma": 0.5})
        cuts += [int(c) for c in algo.fit(s.matrix()).predict(pen=penalty)][:-1]
    bounds = [*cuts, m]
    skill, obj = _frame_states(s, s.dt)
    names = []
    for a, b in itertools.pairwise(bounds):
        pairs, counts = np.unique(np.stack([skill[a:b], obj[a:b]]), axis=1, return_counts=True)
        best = pairs[:, int(np.argmax(counts))]
        names.append((SKILLS[int(best[0])], int(best[1]) if best[1] >= 0 else None))
    segments = []
    start = 0
    for j, (name, k) in enumerate(names):
        if j + 1 < len(names) and names[j + 1] == (name, k):
            continue
        a = int(s.idx[bounds[start]])
        b = int(s.idx[bounds[j + 1]]) if bounds[j + 1] < m else len(traj)
        segments.append(_make_segment(traj, name, a, b, k))
        start = j + 1
    return Segmentation(segments, warnings, "changepoint", [], list(traj.object_names))
