"""Motion building blocks: straight min-jerk lines, clearance checks, the push motion.

Shared by the skills and DMP modes (:mod:`lfd.reproduce.modes`). Paths are arrays of
``[x, y, z, yaw]`` rows at the control tick.
"""

from __future__ import annotations

from itertools import pairwise

import numpy as np

from ..errors import DemonstrationError
from .controller import TICK
from .dmp import dmp_rollout, min_jerk, resample
from .goals import (
    HAND_ROOM,
    DemoFrames,
    grasp_goal,
    grasp_max_width,
    grasp_opening,
    palm_near,
    pose,
    push_goal,
    upright,
    wrap_near,
    yaw_of,
)
from .program import Segment

LINEAR_SPEED = 0.15
"""Mean TCP speed of the straight moves of the skills mode (m/s)."""
CLEARANCE = 0.01
"""Vertical clearance (m) of the lowest point (fingertips, a carried box) over every object
within reach of a move (:func:`clear`)."""
GRASP_CLEAR = 0.01
"""A pick_up whose fingers would sweep into the object approaches this far (m) above the height
where the open fingertips reach the object's top, then descends vertically onto the grasp pose."""
GRASP_SLACK = 0.006
"""Horizontal offset from the grasp pose (m) allowed while the open fingertips are below the
object's top (plus :data:`GRASP_CLEAR`)."""


def segment_indices(frames: DemoFrames, seg: Segment) -> tuple[int, int]:
    i0, i1 = frames.index(seg.start_s), frames.index(seg.end_s)
    return i0, max(i1, i0 + 1) if i0 + 1 < frames.n else i1


def need_object(seg: Segment, objects: dict[str, np.ndarray]) -> str:
    if seg.object is None or seg.object not in objects:
        raise DemonstrationError(
            f"skill {seg.skill!r} needs a known target object, got {seg.object!r} "
            f"(objects: {sorted(objects)})"
        )
    return seg.object


def line(start: np.ndarray, goal: np.ndarray, *, min_s: float = 0.6) -> np.ndarray:
    """Straight min-jerk line in (x, y, z, yaw)."""
    dist = float(np.linalg.norm(goal[:3] - start[:3]))
    dur = max(min_s, dist / LINEAR_SPEED, abs(goal[3] - start[3]) / 1.2)
    s = min_jerk(round(dur / TICK) + 1)[:, None]
    return np.asarray(start + s * (goal - start))


def pick_arrival(
    goal: np.ndarray,
    grasp: np.ndarray,
    name: str,
    frames: DemoFrames,
    objects: dict[str, np.ndarray],
    *,
    asked: bool = False,
) -> np.ndarray:
    """Where the move before a pick_up of ``name`` ends (``[x, y, z, yaw]``): at ``goal``, the
    pick_up's mapped start (Eq. 2), raised or moved above the grasp pose ``grasp`` (the pick_up
    descends from there) where the open fingers would hit an object:

    * the hand reached low beside (or into the box of) the object, e.g. by a mug's handle:
      arrive :data:`GRASP_CLEAR` above its top, where it is;
    * the grasp is asked elsewhere (``asked``: a handover's), or the mapped start lies in
      another object (within the robot's ``hand_radius`` of its footprint, the fingertips below
      :data:`CLEARANCE` over its top: a layout put that object where the person's hand came
      from): arrive above the grasp.
    """
    robot = frames.robot
    T, size = objects[name], frames.size[frames.object_index(name)]
    above = T[2, 3] + size[2] / 2 + robot.finger_below_tcp + GRASP_CLEAR
    out = goal.copy()
    reach = 0.5 * float(np.hypot(size[0], size[1])) + robot.max_opening / 2
    off = float(np.hypot(*(goal[:2] - grasp[:2])))
    if goal[2] < above and GRASP_SLACK < off and float(np.hypot(*(goal[:2] - T[:2, 3]))) < reach:
        out[2] = above
    if asked or _inside(goal, frames, {n: U for n, U in objects.items() if n != name}):
        out[:2] = grasp[:2]
        out[2] = max(out[2], above)
    return out


def _inside(state: np.ndarray, frames: DemoFrames, objects: dict[str, np.ndarray]) -> bool:
    """Whether the open fingers at the TCP state ``state`` are in one of ``objects``: the TCP
    within the robot's ``hand_radius`` of its footprint, the fingertips below :data:`CLEARANCE`
    over its top."""
    robot = frames.robot
    for n, T in objects.items():
        size = frames.size[frames.object_index(n)]
        local = T[:3, :3].T @ (state[:3] - T[:3, 3])
        over_top = state[2] - robot.finger_below_tcp - (T[2, 3] + size[2] / 2)
        if over_top < CLEARANCE and np.all(np.abs(local[:2]) < size[:2] / 2 + robot.hand_radius):
            return True
    return False


def required_height(
    xy: np.ndarray,
    frames: DemoFrames,
    objects: dict[str, np.ndarray],
    *,
    skip: tuple[str, ...],
    below: float,
    extra: float,
    yaw: np.ndarray | None = None,
) -> np.ndarray:
    """Lowest TCP height (m) at each horizontal position ``xy`` (n, 2) that keeps the lowest
    point ``below`` under the TCP 1 cm above every object within reach (-inf: no object near),
    and the hand (:attr:`~lfd.reproduce.arm.Robot.palm_half`, at the gripper yaw ``yaw`` (n,);
    None: any yaw) :data:`CLEARANCE` above every object its outline comes near
    (:func:`~lfd.reproduce.goals.palm_near`).

    An object is within reach of a position closer (horizontally) than its half diagonal plus
    1 cm plus ``extra`` (the open fingers, or a carried object's half diagonal).
    """
    req = np.full(xy.shape[0], -np.inf)
    robot = frames.robot
    palm = robot.palm_half
    for name, T in objects.items():
        if name in skip:
            continue
        size = frames.size[frames.object_index(name)]
        top = T[2, 3] + size[2] / 2
        dist = np.hypot(xy[:, 0] - T[0, 3], xy[:, 1] - T[1, 3])
        reach = 0.5 * float(np.hypot(size[0], size[1])) + 0.01 + extra
        near = dist < reach
        req[near] = np.maximum(req[near], top + CLEARANCE + below)
        if palm is None:
            continue
        if yaw is None:  # any yaw: the hand's circumscribed disc
            reach = 0.5 * float(np.hypot(size[0], size[1])) + float(np.hypot(*palm)) + HAND_ROOM
            near = dist < reach
        else:
            near = palm_near(xy, yaw, palm, T, size)
        req[near] = np.maximum(req[near], top + CLEARANCE - robot.palm_above_tcp)
    return req


def open_fingers(
    frames: DemoFrames, below: float | None = None, extra: float | None = None
) -> tuple[float, float]:
    """``(below, extra)`` of :func:`clear`: given, or the open gripper of ``frames.robot`` (the
    fingertips below the TCP, its :attr:`~lfd.reproduce.arm.Robot.hand_radius` beside it)."""
    robot = frames.robot
    return (
        robot.finger_below_tcp if below is None else below,
        robot.hand_radius if extra is None else extra,
    )


def clear(
    a: np.ndarray,
    b: np.ndarray,
    frames: DemoFrames,
    objects: dict[str, np.ndarray],
    *,
    skip: tuple[str, ...],
    below: float | None = None,
    extra: float | None = None,
) -> bool:
    """True if the open fingers moving straight from ``a`` to ``b`` keep clear of every object.

    ``below``: how far the lowest point (fingertips or a carried object) is below the TCP;
    ``extra``: horizontal reach around the TCP (open fingers, or a carried object's half
    diagonal plus the fingers). Default: the open fingers of ``frames.robot``.
    """
    m = min(len(a), len(b), 4)
    pts = a[None, :m] + np.linspace(0.0, 1.0, 40)[:, None] * (b[:m] - a[:m])[None]
    return path_clear(pts, frames, objects, skip=skip, below=below, extra=extra)


def path_clear(
    pts: np.ndarray,
    frames: DemoFrames,
    objects: dict[str, np.ndarray],
    *,
    skip: tuple[str, ...],
    below: float | None = None,
    extra: float | None = None,
) -> bool:
    """True if every point of ``pts`` (n, >=3; the yaw in a fourth column) keeps clear of every
    object (as :func:`clear`)."""
    below, extra = open_fingers(frames, below, extra)
    yaw = pts[:, 3] if pts.shape[1] > 3 else None
    req = required_height(pts[:, :2], frames, objects, skip=skip, below=below, extra=extra, yaw=yaw)
    return bool(np.all(pts[:, 2] >= req))


def _upper_hull(pts: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """Upper convex hull of points sorted by x (first and last kept)."""
    hull: list[tuple[float, float]] = []
    for p in pts:
        while len(hull) >= 2:
            (x0, z0), (x1, z1) = hull[-2], hull[-1]
            if (x1 - x0) * (p[1] - z0) - (z1 - z0) * (p[0] - x0) >= 0.0:  # not a right turn
                hull.pop()
            else:
                break
        hull.append(p)
    return hull


def over(
    a: np.ndarray,
    b: np.ndarray,
    frames: DemoFrames,
    objects: dict[str, np.ndarray],
    *,
    skip: tuple[str, ...],
    below: float | None = None,
    extra: float | None = None,
    n: int = 120,
) -> list[np.ndarray]:
    """Corners of the shortest path from ``a`` to ``b`` (``[x, y, z, yaw]``) over the objects.

    The path stays in the vertical plane through ``a`` and ``b`` and keeps the clearance of
    :func:`clear`: it rises vertically first when ``a`` is within reach of an object (a
    lift-off), descends vertically last when ``b`` is, and in between is the taut string over
    the heights the objects along the way require (the upper convex hull of those heights and
    the two ends), so it rises only where and as much as needed. ``[a, b]`` when the straight
    line is clear. The yaw turns in proportion to the distance travelled.
    """
    d = b[:2] - a[:2]
    D = float(np.linalg.norm(d))
    if D < 1e-6:
        return [a, b]
    s = np.linspace(0.0, 1.0, n)
    below, extra = open_fingers(frames, below, extra)
    yaw = float(a[3]) + s * (float(b[3]) - float(a[3])) if min(len(a), len(b)) > 3 else None
    req = required_height(
        a[None, :2] + s[:, None] * d, frames, objects, skip=skip, below=below, extra=extra, yaw=yaw
    )
    # each sample also covers the gap to its neighbours (an edge of a reach falls between them)
    req = np.maximum(req, np.maximum(np.r_[req[1:], -np.inf], np.r_[-np.inf, req[:-1]]))
    req = req + 0.001
    za, zb = max(float(a[2]), req[0]), max(float(b[2]), req[-1])
    inner = [(float(s[i]) * D, float(req[i])) for i in range(1, n - 1) if np.isfinite(req[i])]
    hull = _upper_hull([(0.0, za), *inner, (D, zb)])
    pts = [np.array([*a[:3], 0.0])]
    pts += [np.array([*(a[:2] + (x / D) * d), z, 0.0]) for x, z in hull]
    pts.append(np.array([*b[:3], 0.0]))
    keep = [pts[0]]
    for p in pts[1:]:
        if np.linalg.norm(p[:3] - keep[-1][:3]) > 1e-6:
            keep.append(p)
    if len(keep) < 2:
        return [a, b]
    legs = [np.linalg.norm(q[:3] - p[:3]) for p, q in pairwise(keep)]
    run = np.r_[0.0, np.cumsum(legs)]
    for p, r in zip(keep, run / max(run[-1], 1e-12), strict=True):
        p[3] = a[3] + r * (b[3] - a[3])
    return keep


def safe_height(
    frames: DemoFrames, objects: dict[str, np.ndarray], below: float | None = None
) -> float:
    """TCP height at which the lowest point (default: the fingertips) clears every object top
    (+2 cm)."""
    below = frames.robot.finger_below_tcp if below is None else below
    tops = [T[2, 3] + frames.size[frames.object_index(n), 2] / 2 for n, T in objects.items()]
    return max(tops, default=0.0) + below + 0.02


def min_jerk_clip(n: int, frac: float) -> np.ndarray:
    """Min-jerk ramp 0 -> 1 over the first ``frac`` of ``n`` samples, then 1."""
    m = max(2, round(n * frac))
    out = np.ones(n)
    out[: min(m, n)] = min_jerk(m)[: min(m, n)]
    return out


def push_geometry(
    frames: DemoFrames,
    seg: Segment,
    objects: dict[str, np.ndarray],
    ref_yaw: float,
    *,
    by_grasp: bool = False,
) -> dict[str, np.ndarray]:
    """Key poses of a push: hover, start (behind), contact, goal, and the pushed pose.

    The object is pushed by its demonstrated displacement and yaw change, expressed in its own
    frame at the push's start (Eq. 2), from its current pose: ``d`` turns with the box; the
    closed fingers touch the face opposite ``d``. A push whose hand would press on the box's
    top, or asked ``by_grasp`` (two arms: the pushing fingers would go between the box and one
    the other arm holds, :mod:`.two_arm_holds`), grasps the box instead when it fits the
    gripper (:func:`_slide_geometry`).
    """
    name = need_object(seg, objects)
    i0, i1 = segment_indices(frames, seg)
    T0_demo, T1_demo = frames.object_pose(name, i0), frames.object_pose(name, i1)
    T_now = objects[name]
    # Eq. 2 with the box at the push's start as the reference: a turned box is pushed on the
    # same face, along the same direction in its own frame
    T_new = upright(T_now @ np.linalg.inv(T0_demo) @ T1_demo)
    T_new[2, 3] = T_now[2, 3]
    d = T_new[:3, 3] - T_now[:3, 3]
    size = frames.size[frames.object_index(name)]
    u = d[:2] / max(float(np.linalg.norm(d[:2])), 1e-9)
    p_c, yaw = push_goal(T_now, size, d, ref_yaw, frames.robot)
    yaw = float(wrap_near(yaw, float(frames.natural_yaw(p_c))))  # one representative throughout
    p_end, _ = push_goal(T_new, size, d, yaw, frames.robot)
    contact = np.array([*(p_c[:2] - 0.005 * u), p_c[2], yaw])
    start = contact - [0.025 * u[0], 0.025 * u[1], 0.0, 0.0]
    hover = start.copy()
    top = T_now[2, 3] + size[2] / 2
    hover[2] = max(start[2], top + frames.robot.finger_below_tcp + CLEARANCE + 0.001)
    geo = {
        "goal": np.array([*p_end, yaw]),
        "contact": contact,
        "start": start,
        "hover": hover,
        "T_new": T_new,
        "u": u,
        "d": d,
        "T0_demo": T0_demo,
        "T_now": T_now,
        "d_demo": np.array([*(T1_demo[:2, 3] - T0_demo[:2, 3]), 0.0]),
    }
    robot = frames.robot
    hand_on_top = robot.palm_half is not None and p_c[2] + robot.palm_above_tcp < top
    if (hand_on_top or by_grasp) and min(size[0], size[1]) <= grasp_max_width(robot):
        geo.update(_slide_geometry(frames, name, objects, geo, yaw))
    return geo


SLIDE_LIFT = 0.003
"""A box pushed by grasping it (:func:`push_geometry`) is lifted this much (m) while it is
moved, and dropped from there (as a place releases :data:`~lfd.reproduce.modes.RELEASE_LIFT`
above the resting pose)."""


def _slide_geometry(
    frames: DemoFrames, name: str, objects: dict[str, np.ndarray], geo: dict, yaw: float
) -> dict[str, np.ndarray]:
    """A push whose hand would press on the box's top edge (the Panda's, 21 mm ahead of its
    fingers and 27 mm above its TCP: a 7 cm box pushed below its centre tilts and falls back
    short, pushed higher it topples): the box is grasped instead (closing across the push where
    it fits, :func:`~lfd.reproduce.goals.grasp_goal`), lifted :data:`SLIDE_LIFT`, moved along
    the push to its pushed pose and released. ``grasp``: the grasp pose; ``contact`` and
    ``goal``: where the moving starts and ends; ``start``/``hover``: above the grasp."""
    T_now, T_new = geo["T_now"], geo["T_new"]
    k = frames.object_index(name)
    size = frames.size[k]
    level = [
        (T, frames.size[frames.object_index(n)])
        for n, T in objects.items()
        if n != name
        and abs(T[2, 3] - T_now[2, 3]) < 0.5 * (frames.size[frames.object_index(n), 2] + size[2])
    ]
    p, g_yaw = grasp_goal(T_now, size, yaw, level, robot=frames.robot)
    g_yaw = float(wrap_near(g_yaw, float(frames.natural_yaw(p))))
    rel = np.linalg.inv(T_now) @ pose(p, g_yaw)
    end = T_new @ rel
    lift = np.array([0.0, 0.0, SLIDE_LIFT, 0.0])
    grasp = np.array([*p, g_yaw])
    hover = grasp.copy()
    top = T_now[2, 3] + size[2] / 2
    hover[2] = max(grasp[2], top + frames.robot.finger_below_tcp + CLEARANCE + 0.001)
    across = abs(np.cos(g_yaw - yaw_of(T_now[:3, :3]))) * size[0]
    across += abs(np.sin(g_yaw - yaw_of(T_now[:3, :3]))) * size[1]
    return {
        "grasp": grasp,
        "contact": grasp + lift,
        "goal": np.array([*end[:3, 3], float(wrap_near(yaw_of(end[:3, :3]), g_yaw))]) + lift,
        "start": hover,
        "hover": hover,
        "opening": np.array(grasp_opening(float(across), frames.robot)),
        "release_top": np.array(T_new[2, 3] + size[2] / 2),
    }


def push_path(
    frames: DemoFrames,
    name: str,
    geo: dict[str, np.ndarray],
    span: tuple[int, int],
    cur: np.ndarray,
    mode: str,
) -> np.ndarray:
    """Hover -> descend -> approach -> push along the demonstrated object motion.

    The pushing part follows the demonstrated progress of the object along the push direction
    (skills: on a straight line; dmp: a DMP of the object's demonstrated path re-targeted to the
    new contact and goal).
    """
    pieces = []
    if np.linalg.norm(cur[:3] - geo["start"][:3]) > 0.002:  # not arrived straight behind it
        if np.linalg.norm(cur[:3] - geo["hover"][:3]) > 0.002:
            pieces.append(line(cur, geo["hover"]))
        pieces.append(line(geo["hover"], geo["start"], min_s=0.5))
    pieces.append(line(geo["start"], geo["contact"], min_s=0.4))
    pieces.append(push_progress(frames, name, geo, span, mode))
    return np.concatenate(pieces)


def push_progress(
    frames: DemoFrames, name: str, geo: dict[str, np.ndarray], span: tuple[int, int], mode: str
) -> np.ndarray:
    """The pushing part of a push, from ``geo["contact"]`` to ``geo["goal"]``: the demonstrated
    progress of the object along the push (skills: on a straight line; dmp: a DMP of the
    object's demonstrated path re-targeted to the new contact and goal)."""
    dist = float(np.linalg.norm(geo["d"]))
    contact, goal = geo["contact"], geo["goal"]
    if dist < 0.005:
        return line(contact, goal)
    idx = np.arange(span[0], span[1] + 1)
    obj = np.array([frames.object_pose(name, int(i))[:3, 3] for i in idx])
    d_demo = geo["d_demo"]  # progress along the demonstrated push (the frame may have turned)
    dd = max(float(d_demo @ d_demo), 1e-12)
    prog = np.maximum.accumulate(np.clip((obj - obj[0]) @ d_demo / dd, 0.0, 1.0))
    moving = np.flatnonzero((prog > 0.01) & (prog < 0.995))
    a, b = (moving[0], moving[-1] + 1) if moving.size >= 2 else (0, len(idx) - 1)
    t = frames.t[idx[a : b + 1]]
    if mode == "dmp":
        # the demonstrated object path carried into the box's current frame (Eq. 2), so a
        # turned box is pushed along the turned path, not sideways
        M = geo["T_now"] @ np.linalg.inv(geo["T0_demo"])
        xy = obj[a : b + 1] @ M[:3, :3].T + M[:3, 3]
        y = np.column_stack(
            [xy[:, :2], np.full(b - a + 1, contact[2]), np.full(b - a + 1, contact[3])]
        )
        return dmp_rollout(t, y, contact, goal, dt=TICK, start_velocity=np.zeros(4))
    pr = resample(t, prog[a : b + 1, None], TICK)[:, 0]
    pr = (pr - pr[0]) / max(pr[-1] - pr[0], 1e-9)
    return np.asarray(contact + pr[:, None] * (goal - contact))
