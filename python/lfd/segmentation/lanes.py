"""Both hands segmented together (docs/skills.md, "Two hands"): each hand's lane on the
demonstration as that hand sees it (:func:`lfd.segmentation.attribution.hand_view`), the lanes
reconciled with contact (an object is held only by the hand(s) touching it), the handovers
found where one hand's carry ends in the air while the other already holds the object, and the
grammar checked per hand and across hands.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..demo import Demonstration, Handover, ObjectTrack
from ..geometry import box_distance, in_box_frame
from ..skills import TOUCHING, impossible_transitions
from .attribution import (
    INDEX_TIP,
    THUMB_TIP,
    AttributionParams,
    _nearest,
    filled,
    hand_distance,
    hand_view,
    tip_distances,
)
from .cycles import PUSHED_M, displacement, is_reach_hesitation
from .episodes import CarryParams, carries, overlay, snap, still_holds
from .hands import HandsSegmentation
from .result import Segment, Segmentation


@dataclass(frozen=True)
class LaneParams:
    """How the lanes are reconciled.

    Attributes
    ----------
    touch_m : float
        A hand touches an object when its TCP is within this of the object's box (m).
    release_m : float
        A hand is off an object when its TCP is this far (m) from the object's box.
    pushed_m : float
        A Push moves its object this far (m) or more while the hand touches it (an object
        that stays where it is, or that the other hand moves, is not pushed: a Move).
    support_m : float
        A released object is stacked when another object's box is within this (m) under
        its lowest point (a support); let go of on the table or in the other hand it is
        placed.
    near_m : float
        A Push begins with its hand nearer its object than this (m): above its start,
        behind the object.
    point_m : float
        A Locate points: the index tip from 2 cm to this high (m) above the object's top.
    reach_s : float
        A Pick up's grasp, a Place's release may fall this long (s) after its end or before
        its start.
    air_m : float
        A release is in the air (a handover, not a Place on the table) when the object is at
        least this much (m) above the lowest it rests in the recording.
    snap_s : float
        A carry's boundary moves to the lane's own boundary between the same skills when one
        is this close (s): the templates' boundaries, refined by the one-hand contact rules.
    gone_s : float
        A giver lets go for good: its TCP stays ``release_m`` off the object this long (s)
        after the handover, and the taker carries the object on at least this long.
    withdraw_m : float
        A giver whose TCP is off the object ``gone_s`` after its release and this far (m)
        from where it let go has let go for good, even if the taker carried the object past it.
    handover_s : float
        In a handover both hands hold the object together for at most this long (s): the
        taker's grasp to the giver's release (longer: a two-handed carry).
    """

    touch_m: float = 0.02
    pushed_m: float = PUSHED_M
    support_m: float = 0.01
    point_m: float = 0.12
    near_m: float = 0.10
    reach_s: float = 0.3
    air_m: float = 0.05
    gone_s: float = 1.0
    handover_s: float = 3.0
    withdraw_m: float = 0.10
    snap_s: float = 0.5
    release_m: float = 0.03


def segment_lanes(
    demo: Demonstration,
    segment_one: Callable[[Demonstration], Segmentation],
    *,
    attribution: AttributionParams | None = None,
    params: LaneParams | None = None,
    carry: CarryParams | None = None,
    complete: bool = True,
) -> HandsSegmentation:
    """Every hand of ``demo`` segmented by ``segment_one`` on its own view, the lanes
    reconciled and the handovers found (see the module). A one-hand demonstration gives one
    lane, ``segment_one`` of that hand alone, untouched. ``complete`` False: the recording is
    still being made (a grasp held at its end may yet lift its object)."""
    if len(demo.sides) < 2:
        side = demo.sides[0]
        return HandsSegmentation(lanes={side: segment_one(demo.one_hand(side))})
    p = params or LaneParams()
    lanes: dict[str, Segmentation] = {}
    # the objects' poses filled in through occlusions, once (contact and support read them);
    # where an object went unseen for long (the hand holding it hides it), at the hands'
    # samples too
    grid = np.union1d(*(h.t_ns for h in demo.hands.values()))
    whole = dataclasses.replace(
        demo,
        objects={n: filled(_densified(o, grid)) if len(o) else o for n, o in demo.objects.items()},
    )
    near = {
        side: {
            name: tip_distances(demo.hands[side], whole.objects[name], 2)
            for name, obj in demo.objects.items()
            if len(obj)
        }
        for side in demo.sides
    }

    def view_tcp(side: str) -> dict[str, np.ndarray] | None:
        same = all(len(whole.objects[n]) == len(o) for n, o in demo.objects.items())
        return {n: d[0] for n, d in near[side].items()} if same else None

    segs = {
        side: segment_one(hand_view(demo, side, attribution, view_tcp(side))) for side in demo.sides
    }
    both = {side: _at_samples(whole, near[side], seg) for side, seg in segs.items()}
    dists = {side: got[0] for side, got in both.items()}
    holds = {
        side: {name: np.asarray(d <= (carry or CarryParams()).hold_m) for name, d in dist.items()}
        for side, dist in dists.items()
    }
    for side, seg in segs.items():
        other = next(s for s in demo.sides if s != side)
        t = _sample_times(seg)
        dt = float(np.median(np.diff(t))) * 1e-9 if len(t) > 1 else 1.0
        thumbs = both[side][1]
        tol = max(1, round(p.snap_s / dt))
        spans = {}
        for name, d in dists[side].items():
            other_hold = _resampled(holds[other].get(name), _sample_times(segs[other]), t)
            got = carries(
                d, _positions(demo, name, t), _rest_height(demo, name), dt, carry,
                other_hold=other_hold, thumb=thumbs[name],
                depth=_tcp_depth(whole, side, name, t),
            )  # fmt: skip
            still = still_holds(
                np.fmin(d, thumbs[name]),
                _positions(demo, name, t),
                _rest_height(demo, name),
                dt,
                carry,
                thumbs[name],
                complete=complete,
            )
            got = _merged(got, still)
            spans[name] = snap(got, seg.segments, name, tol, other_hold)
        touch = {
            name: np.asarray(np.fmin(d, thumbs[name]) <= p.touch_m)
            for name, d in dists[side].items()
        }
        pushes = _PushTouch(demo, side, t, p.touch_m, p.pushed_m)
        seg.segments = _reconcile(
            overlay(seg.segments, spans, _seconds(seg.segments)), touch, p, seg, pushes
        )
        checked = _points(whole, side, t, _supports(whole, seg.segments, p), p)
        seg.segments = _merge_same(_push_reach(whole, side, t, checked, p))
        lanes[side] = seg
    handovers = find_handovers(demo, lanes, p, dists)
    result = HandsSegmentation(lanes=lanes, handovers=handovers)
    result.warnings.extend(check_lanes(result))
    return result


def _merged(
    carried: list[tuple[str, int, int]], still: list[tuple[str, int, int]]
) -> list[tuple[str, int, int]]:
    """The carries and the still holds of one object in time order, a still hold that
    overlaps a carry left out (whole: a hold's three spans go together)."""
    if not still:
        return carried
    holds: list[list[tuple[str, int, int]]] = []
    for span in still:
        if span[0] == "pick_up" or not holds or holds[-1][-1][0] == "place":
            holds.append([])
        holds[-1].append(span)
    out = list(carried)
    for hold in holds:
        a, b = hold[0][1], hold[-1][2]
        if all(b <= x or a >= y for _, x, y in carried):
            out += hold
    return sorted(out, key=lambda span: span[1])


def _densified(obj: ObjectTrack, grid: np.ndarray) -> ObjectTrack:
    """``obj`` with a NaN (unseen) sample at each time of ``grid`` that falls in a gap of its
    samples longer than twice their usual spacing, or before its first or after its last
    (a recorder drops the poses of a hidden object); :func:`filled` then puts it where it
    would be (where it was last seen, outside)."""
    if len(obj) < 2:
        return obj
    step = float(np.median(np.diff(obj.t_ns)))
    i = np.searchsorted(obj.t_ns, grid)
    inside = (i > 0) & (i < len(obj))
    j = np.clip(i, 1, len(obj) - 1)
    gap = np.where(inside, obj.t_ns[j] - obj.t_ns[j - 1], np.iinfo(np.int64).max)
    add = grid[(gap > 2 * step) & (np.abs(grid - obj.t_ns[np.clip(i, 0, len(obj) - 1)]) > step)]
    add = np.setdiff1d(add, obj.t_ns)
    if not len(add):
        return obj
    t = np.concatenate([obj.t_ns, add])
    order = np.argsort(t, kind="stable")
    nan3, nan4 = np.full((len(add), 3), np.nan), np.full((len(add), 4), np.nan)
    return dataclasses.replace(
        obj,
        t_ns=t[order],
        position=np.concatenate([obj.position, nan3])[order],
        quaternion=np.concatenate([obj.quaternion, nan4])[order],
        visible=np.concatenate([obj.visible, np.zeros(len(add), dtype=bool)])[order],
    )


def _at_samples(
    demo: Demonstration, near: dict[str, tuple[np.ndarray, ...]], seg: Segmentation
) -> list[dict[str, np.ndarray]]:
    """The distances ``near`` (per object name, at the object's samples: TCP, thumb tip) at
    ``seg``'s trajectory samples, one dict per distance (inf where unknown)."""
    t = _sample_times(seg)
    out: list[dict[str, np.ndarray]] = [{}, {}]
    for name, got in near.items():
        obj = demo.objects[name]
        i = np.clip(np.searchsorted(obj.t_ns, t), 0, len(obj) - 1)
        for k, d in enumerate(got[:2]):
            out[k][name] = np.where(np.isfinite(d[i]), d[i], np.inf)
    return out


def _sample_times(seg: Segmentation) -> np.ndarray:
    """Absolute times (ns) of the segmented trajectory's samples."""
    if seg.run is not None:
        traj = seg.run.trajectory
        return np.asarray(traj.t_ns, dtype=np.int64)
    end = seg.segments[-1].end
    t0, t1 = seg.segments[0].start_ns, seg.segments[-1].end_ns
    return np.linspace(t0, t1, end, endpoint=False).astype(np.int64)


class _PushTouch:
    """Does the hand push a Push's object: touch it with any keypoint (within ``touch_m``)
    while it moves ``pushed_m`` or more? Measured on the Push's samples only, when asked."""

    def __init__(
        self, demo: Demonstration, side: str, t_ns: np.ndarray, touch_m: float, pushed_m: float
    ):
        self.demo, self.side, self.t_ns = demo, side, t_ns
        self.touch_m, self.pushed_m = touch_m, pushed_m

    def touches(self, seg: Segment, k: int) -> bool:
        obj = self.demo.objects.get(seg.object or "")
        if obj is None or not len(obj):
            return True
        t = self.t_ns[max(seg.start, 0) : min(seg.end + k, len(self.t_ns))]
        if not len(t):
            return True
        d = hand_distance(self.demo.hands[self.side], obj, t)
        on = d <= self.touch_m
        if not on.any():
            return False
        pos = _positions(self.demo, seg.object or "", t)
        return displacement(pos, int(np.argmax(on)), len(pos)) >= self.pushed_m


def _touches(seg: Segment, touch: dict[str, np.ndarray], k: int) -> bool:
    """Does the hand touch ``seg``'s object during it (``k`` samples of slack at the end of a
    Pick up, at the start of a Place or Stack)?"""
    mask = touch.get(seg.object or "")
    if mask is None:
        return True
    a, b = seg.start, seg.end
    if seg.skill == "pick_up":
        b += k
    elif seg.skill in ("place", "stack"):
        a -= k
    a, b = max(a, 0), min(b, len(mask))
    return bool(mask[a:b].any()) if b > a else True


def _reconcile(
    segments: list[Segment],
    touch: dict[str, np.ndarray],
    p: LaneParams,
    seg: Segmentation,
    pushes: _PushTouch | None = None,
) -> list[Segment]:
    """A skill on an object the hand never touches becomes a Move (its motion was the other
    hand's); neighbouring Moves merge into one."""
    if not segments:
        return segments
    dt = (segments[-1].end_s - segments[0].start_s) / max(segments[-1].end - segments[0].start, 1)
    k = max(1, round(p.reach_s / dt)) if dt > 0 else 1
    out: list[Segment] = []
    for s in segments:
        cur = s
        if s.skill == "push" and pushes is not None:
            touched = pushes.touches(s, k)
        else:
            touched = s.skill not in TOUCHING or _touches(s, touch, k)
        if not touched:
            cur = dataclasses.replace(
                s, skill="move", score=float("nan"), confidence=float("nan"),
                margin=float("nan"), params={},
            )  # fmt: skip
            if seg.warnings is not None:
                seg.warnings.append(
                    f"{s.skill} of {s.object} at {s.start_s:.2f}-{s.end_s:.2f} s: the hand never "
                    "touches it (the other hand moved it): a move"
                )
        if out and out[-1].skill == "move" and cur.skill == "move":
            out[-1] = _joined(out[-1], cur)
            continue
        out.append(cur)
    return out


def _tcp_at(demo: Demonstration, side: str, t_ns: np.ndarray) -> np.ndarray:
    """The ``side`` hand's TCP ``(n, 3)`` at ``t_ns`` (the nearest samples)."""
    hand = demo.hands[side]
    i = _nearest(hand, t_ns)
    return np.asarray(0.5 * (hand.keypoints[i, THUMB_TIP] + hand.keypoints[i, INDEX_TIP]))


def _tcp_depth(demo: Demonstration, side: str, name: str, t_ns: np.ndarray) -> np.ndarray:
    """The signed distance (m) of the ``side`` hand's TCP from object ``name``'s box at
    ``t_ns`` (the nearest samples): positive outside, negative inside; NaN where unknown."""
    hand, obj = demo.hands[side], demo.objects[name]
    i = _nearest(hand, t_ns)
    tcp = 0.5 * (hand.keypoints[i, THUMB_TIP] + hand.keypoints[i, INDEX_TIP])
    j = np.clip(np.searchsorted(obj.t_ns, t_ns), 0, len(obj) - 1)
    quat, pos = obj.quaternion[j], obj.position[j]
    ok = np.isfinite(quat).all(axis=1) & np.isfinite(pos).all(axis=1)
    safe = np.where(ok[:, None], quat, np.array([0.0, 0.0, 0.0, 1.0]))
    q = np.abs(in_box_frame(tcp - np.where(ok[:, None], pos, 0.0), safe)) - 0.5 * obj.size
    out = np.linalg.norm(np.maximum(q, 0.0), axis=1) + np.minimum(q.max(axis=1), 0.0)
    return np.where(ok, out, np.nan)


def _supported(demo: Demonstration, name: str, t_ns: int, margin: float) -> bool:
    """Is another object's box within ``margin`` under the lowest point of ``name`` at
    ``t_ns`` (the object rests on it)?"""
    obj = demo.objects.get(name)
    if obj is None or not len(obj):
        return False
    i = int(np.clip(np.searchsorted(obj.t_ns, t_ns), 0, len(obj) - 1))
    pos, quat = obj.position[i], obj.quaternion[i]
    if not (np.isfinite(pos).all() and np.isfinite(quat).all()):
        return False
    up = in_box_frame(np.array([0.0, 0.0, 1.0]), quat)
    low = pos - np.array([0.0, 0.0, 0.5 * float(np.abs(up) @ np.asarray(obj.size)) + 0.5 * margin])
    for other_name, other in demo.objects.items():
        if other_name == name or not len(other):
            continue
        j = int(np.clip(np.searchsorted(other.t_ns, t_ns), 0, len(other) - 1))
        d = box_distance(low, other.position[j], other.quaternion[j], other.size)
        if np.isfinite(d) and d <= 0.5 * margin:
            return True
    return False


def _supports(demo: Demonstration, segments: list[Segment], p: LaneParams) -> list[Segment]:
    """Every Place or Stack a Stack exactly when its object rests on another object as the
    hand lets go (:func:`_supported` at its end), a Place otherwise (on the table, or in the
    other hand)."""
    out = []
    for s in segments:
        if s.skill in ("place", "stack") and s.object in demo.objects:
            on = _supported(demo, s.object, s.end_ns, p.support_m)
            skill = "stack" if on else "place"
            if skill != s.skill:
                s = dataclasses.replace(s, skill=skill)
        out.append(s)
    return out


def _points(
    demo: Demonstration, side: str, t_ns: np.ndarray, segments: list[Segment], p: LaneParams
) -> list[Segment]:
    """A Locate stays one only where the hand points at an object: its index tip above the
    object's top (``point_m``: from 2 cm to this high, within 2 cm of its footprint) on at
    least a third of its samples, and not as it reaches for the object it picks up next (a
    hesitation above it before the grasp); otherwise the hand only moved (a Move)."""
    out = []
    hand = demo.hands[side]
    for i, s in enumerate(segments):
        nxt = segments[i + 1] if i + 1 < len(segments) else None
        if nxt is not None and is_reach_hesitation(s.skill, s.object, nxt.skill, nxt.object):
            s = dataclasses.replace(s, skill="move")  # the Pick up's reach, slowed
        if s.skill == "locate":
            t = t_ns[max(s.start, 0) : min(s.end, len(t_ns))]
            tip = hand.keypoints[_nearest(hand, t), INDEX_TIP] if len(t) else np.zeros((0, 3))
            names = [s.object] if s.object in demo.objects else list(demo.objects)
            if not any(_above(demo, n, t, tip, p.point_m) for n in names):
                s = dataclasses.replace(s, skill="move")
        out.append(s)
    return out


def _above(demo: Demonstration, name: str, t_ns: np.ndarray, tip: np.ndarray, high: float) -> bool:
    """Is ``tip`` (at ``t_ns``) 2 cm to ``high`` above the top of object ``name`` and within
    2 cm of its footprint on a third of the samples or more?"""
    obj = demo.objects[name]
    if not len(obj) or not len(t_ns):
        return False
    j = np.clip(np.searchsorted(obj.t_ns, t_ns), 0, len(obj) - 1)
    pos, quat = obj.position[j], obj.quaternion[j]
    ok = np.isfinite(pos).all(axis=1) & np.isfinite(quat).all(axis=1) & np.isfinite(tip).all(1)
    if not ok.any():
        return False
    safe = np.where(ok[:, None], quat, np.array([0.0, 0.0, 0.0, 1.0]))
    up = in_box_frame(np.array([0.0, 0.0, 1.0]), safe)
    top = np.nan_to_num(pos[:, 2]) + 0.5 * np.abs(up) @ np.asarray(obj.size)
    level = np.where(ok[:, None], tip, 0.0).copy()
    level[:, 2] = np.nan_to_num(pos[:, 2])  # the tip's footprint, at the object's centre
    flat = box_distance(level, np.where(ok[:, None], pos, 0.0), safe, obj.size)
    height = np.nan_to_num(tip[:, 2]) - top
    hit = ok & (flat <= 0.02) & (height >= 0.02) & (height <= high)
    return bool(hit.mean() >= 1 / 3)


def _push_reach(
    demo: Demonstration, side: str, t_ns: np.ndarray, segments: list[Segment], p: LaneParams
) -> list[Segment]:
    """A Push begins above its start, behind the object (docs/skills.md): what comes before
    the last sample its hand (nearest keypoint) is ``near_m`` or farther from the object,
    before it first touches it, is a Move."""
    out: list[Segment] = []
    for s in segments:
        obj = demo.objects.get(s.object or "")
        if s.skill != "push" or obj is None or not len(obj) or s.end - s.start < 3:
            out.append(s)
            continue
        t = t_ns[max(s.start, 0) : min(s.end, len(t_ns))]
        d = hand_distance(demo.hands[side], obj, t)
        touch = np.flatnonzero(d <= p.touch_m)
        far = np.flatnonzero(d[: int(touch[0])] >= p.near_m) if len(touch) else np.array([])
        if not len(far):
            out.append(s)
            continue
        k = s.start + int(far[-1]) + 1
        frac = (k - s.start) / (s.end - s.start)
        at_s = s.start_s + frac * (s.end_s - s.start_s)
        at_ns = s.start_ns + round(frac * (s.end_ns - s.start_ns))
        nan = float("nan")
        reach = dataclasses.replace(
            s, skill="move", end=k, end_s=at_s, end_ns=at_ns, score=nan, confidence=nan,
            margin=nan, params={},
        )  # fmt: skip
        out += [reach, dataclasses.replace(s, start=k, start_s=at_s, start_ns=at_ns)]
    return out


def _merge_same(segments: list[Segment]) -> list[Segment]:
    """Neighbouring segments of one skill and object merged into one (Moves whatever their
    object: a Move takes the object of the skill after it)."""
    out: list[Segment] = []
    for s in segments:
        if out and out[-1].skill == s.skill and (out[-1].object == s.object or s.skill == "move"):
            out[-1] = _joined(out[-1], s)
            continue
        out.append(s)
    return out


def _seconds(segments: list[Segment]) -> np.ndarray:
    """The seconds of every sample of the segments, and of the end (linear inside each)."""
    n = segments[-1].end
    out = np.zeros(n + 1)
    for s in segments:
        out[s.start : s.end + 1] = np.linspace(s.start_s, s.end_s, s.end - s.start + 1)
    return out


def _rest_height(demo: Demonstration, name: str) -> float:
    """The lowest height (m) at which the object is seen, the table under it."""
    z = demo.objects[name].position[:, 2]
    return float(np.nanmin(z)) if np.isfinite(z).any() else float("nan")


def _resampled(mask: np.ndarray | None, t_from: np.ndarray, t_to: np.ndarray) -> np.ndarray | None:
    """``mask`` at samples ``t_from`` taken at ``t_to`` (the nearest sample before)."""
    if mask is None or not len(t_from):
        return None
    i = np.clip(np.searchsorted(t_from, t_to, side="right") - 1, 0, len(t_from) - 1)
    return np.asarray(mask[i])


def _positions(demo: Demonstration, name: str, t_ns: np.ndarray) -> np.ndarray:
    """The object's true centre at times ``t_ns`` (its nearest sample; where it was not seen,
    interpolated between where it was)."""
    obj = demo.objects[name]
    i = np.clip(np.searchsorted(obj.t_ns, t_ns), 0, len(obj) - 1)
    pos = np.array(obj.position[i], dtype=np.float64)
    for axis in range(3):
        ok = np.isfinite(pos[:, axis])
        if ok.any() and not ok.all():
            pos[:, axis] = np.interp(t_ns, t_ns[ok], pos[ok, axis])
    return pos


def _height_at(demo: Demonstration, name: str, t_ns: int) -> float:
    """The object's height at ``t_ns`` (its nearest sample; through an occlusion, where it
    would be between where it was seen)."""
    obj = demo.objects[name]
    i = int(np.clip(np.searchsorted(obj.t_ns, t_ns), 0, len(obj) - 1))
    if not np.isfinite(obj.position[i, 2]):
        obj = filled(obj)
    return float(obj.position[i, 2])


def _holding_at(lane: Segmentation, name: str | None, t_ns: int) -> Segment | None:
    """The lane's segment carrying ``name`` at ``t_ns`` (a Move with, or a Pick up ending
    there), else None."""
    for s in lane.segments:
        if s.object == name and s.skill in ("move_with", "pick_up", "place", "stack"):
            if s.start_ns <= t_ns < s.end_ns:
                return s
    return None


def find_handovers(
    demo: Demonstration,
    lanes: dict[str, Segmentation],
    p: LaneParams,
    dists: dict[str, dict[str, np.ndarray]] | None = None,
) -> list[Handover]:
    """The handovers of the lanes: a giver's Place whose release leaves the object in the air
    while the taker, who grasped it after the giver did, carries it on; the giver lets go for
    good (its TCP ``release_m`` off the object for ``gone_s``; ``dists``: each hand's TCP
    distances at its lane's samples). The giver's lane is made to follow the definition
    (Move with until the taker has grasped, then Place until the release)."""
    out: list[Handover] = []
    sides = list(lanes)
    for giver in sides:
        taker = next(s for s in sides if s != giver)
        g_lane, t_lane = lanes[giver], lanes[taker]
        tcp: np.ndarray | None = None
        for i, s in enumerate(g_lane.segments):
            if s.skill != "place" or s.object is None or s.object not in demo.objects:
                continue
            rest = _rest_height(demo, s.object)
            if not _height_at(demo, s.object, s.end_ns) - rest >= p.air_m:
                continue
            carry = _holding_at(t_lane, s.object, s.end_ns)
            if carry is None or carry.skill != "move_with":
                continue
            if not _holds_on(dists, taker, s, lanes[taker], p):
                continue
            began = next(
                (g.start_ns for g in reversed(g_lane.segments[:i]) if g.skill == "pick_up"),
                g_lane.segments[0].start_ns,
            )
            if tcp is None:
                tcp = _tcp_at(demo, giver, _sample_times(g_lane))
            if carry.start_ns <= began or not _gone(dists, giver, s, g_lane, p, tcp):
                continue
            if s.end_ns - carry.start_ns > round(p.handover_s * 1e9):
                continue  # held together longer: a two-handed carry one hand lets go of
            start_ns = max(min(carry.start_ns, s.end_ns), g_lane.segments[i].start_ns)
            _giver_follows(g_lane, i, start_ns)
            out.append(Handover(start_ns, s.end_ns, giver, taker, s.object))
    return sorted(out, key=lambda h: h.start_ns)


def _holds_on(
    dists: dict[str, dict[str, np.ndarray]] | None,
    side: str,
    place: Segment,
    lane: Segmentation,
    p: LaneParams,
) -> bool:
    """Does the ``side`` hand keep its TCP within ``release_m`` of ``place``'s object for
    ``gone_s`` after the giver's ``place`` (the taker holds on)?"""
    if dists is None or place.object not in dists.get(side, {}):
        return True
    d = dists[side][place.object]
    dt = (lane.segments[-1].end_s - lane.segments[0].start_s) / max(lane.segments[-1].end, 1)
    k = max(1, round(p.gone_s / dt)) if dt > 0 else 1
    after = d[place.end : place.end + k]
    return bool(len(after)) and bool((after < p.release_m).all())


def _gone(
    dists: dict[str, dict[str, np.ndarray]] | None,
    side: str,
    place: Segment,
    lane: Segmentation,
    p: LaneParams,
    tcp: np.ndarray | None = None,
) -> bool:
    """Does the hand let go of ``place``'s object for good: its TCP ``release_m`` off the
    object for ``gone_s`` after it, or (``tcp``: its TCP at the lane's samples) off it
    ``gone_s`` later and ``withdraw_m`` from where it let go (the other hand may carry the
    object past the withdrawing hand)?"""
    if dists is None or place.object not in dists.get(side, {}):
        return True
    d = dists[side][place.object]
    dt = (lane.segments[-1].end_s - lane.segments[0].start_s) / max(lane.segments[-1].end, 1)
    k = max(1, round(p.gone_s / dt)) if dt > 0 else 1
    after = d[place.end : place.end + k] >= p.release_m
    if len(after) < k:
        return False
    if after.all():
        return True
    if tcp is None or place.end + k >= len(tcp):
        return False
    away = float(np.linalg.norm(tcp[place.end + k] - tcp[place.end]))
    return bool(after[-1]) and away >= p.withdraw_m


def _giver_follows(lane: Segmentation, i: int, start_ns: int) -> None:
    """The giver's Place ``i`` starts when the taker has grasped (``start_ns``), the Move with
    before it ending there, when that falls inside both."""
    if i == 0:
        return
    prev, place = lane.segments[i - 1], lane.segments[i]
    if prev.skill != "move_with" or not prev.start_ns < start_ns < place.end_ns:
        return
    frac = (start_ns - place.start_ns) / max(place.end_ns - place.start_ns, 1)
    k = place.start + round(frac * (place.end - place.start))
    k = min(max(k, prev.start + 1), place.end - 1)
    s_at = place.start_s + (k - place.start) * (place.end_s - place.start_s) / max(
        place.end - place.start, 1
    )
    t_at = place.start_ns + round((s_at - place.start_s) * 1e9)
    lane.segments[i - 1] = dataclasses.replace(prev, end=k, end_s=s_at, end_ns=t_at)
    lane.segments[i] = dataclasses.replace(place, start=k, start_s=s_at, start_ns=t_at)


def check_lanes(result: HandsSegmentation) -> list[str]:
    """The grammar per hand and across hands, as warnings prefixed by the hand's side."""
    out: list[str] = []
    for side, lane in result.lanes.items():
        out.extend(f"{side}: {w}" for w in impossible_transitions(lane.skill_sequence))
    for h in result.handovers:
        taker = result.lanes[h.taker]
        if _holding_at(taker, h.object, h.end_ns) is None:
            out.append(
                f"handover of {h.object} at {h.end_ns} ns: the {h.taker} hand does not hold it"
            )
    return out


def _joined(prev: Segment, nxt: Segment) -> Segment:
    """``prev`` and the ``nxt`` segment after it as one segment: ``prev`` up to ``nxt``'s end,
    with ``nxt``'s object and no search scores (no run of the search is both)."""
    return dataclasses.replace(
        prev, end=nxt.end, end_s=nxt.end_s, end_ns=nxt.end_ns, object=nxt.object,
        score=float("nan"), confidence=float("nan"), margin=float("nan"),
    )  # fmt: skip
