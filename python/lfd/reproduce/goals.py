"""Object-relative skill goals (paper Eq. 2) and the demo quantities they are built from.

A goal is a top-down TCP pose ``(position, yaw)``. Every skill goal is attached to a reference
frame, the pose of an object it involves: ``pick_up``/``locate`` to the target object,
``stack`` to the supporting object, ``place`` to the nearest other object within
:data:`PLACE_NEIGHBOUR_RADIUS` of where the demonstration put the object down
(:meth:`DemoFrames.neighbour_of`; the world when none is that close), ``push`` to the pushed
object's pose when the push starts (the pushed face and the push direction turn with the box),
and ``move``/``move_with`` to the start of the next skill (in that skill's reference). With
displaced objects the goal follows its reference, ``T_goal' = T_ref' · T_ref^-1 · T_goal``
(Eq. 2), recomputed from the objects' poses when the skill is planned (an object moved by an
earlier skill is a reference at its new pose). Skill knowledge adapts the human's poses to
the gripper: grasps are centred on the object with the closing axis along a face normal, placed
objects stay upright, pushes keep the closed fingers against the face opposite the push.
"""

from __future__ import annotations

import numpy as np

from ..errors import DemonstrationError, UsageError
from ..geometry import outside_distance
from ..trajectory import Trajectory
from .arm import Robot
from .robot import KUKA_LWR4


def wrap_near(angle: np.ndarray | float, ref: float, period: float = np.pi) -> np.ndarray:
    """The representative of ``angle`` modulo ``period`` closest to ``ref``."""
    return ref + (np.asarray(angle) - ref + period / 2) % period - period / 2


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrix of an (x, y, z, w) quaternion."""
    x, y, z, w = np.asarray(q, dtype=np.float64) / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def yaw_of(R: np.ndarray) -> float:
    """Heading of a rotation's x axis in the table plane (rad)."""
    return float(np.arctan2(R[1, 0], R[0, 0]))


def pose(p: np.ndarray, yaw: float) -> np.ndarray:
    """4x4 pose with a rotation about world Z."""
    c, s = np.cos(yaw), np.sin(yaw)
    T = np.eye(4)
    T[:3, :3] = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
    T[:3, 3] = p
    return T


def upright(T: np.ndarray) -> np.ndarray:
    """The pose with its rotation reduced to a yaw (objects rest upright)."""
    return pose(T[:3, 3], yaw_of(T[:3, :3]))


SQUARE_FOOTPRINT = 0.003
"""A box whose sides in the table plane differ by less (m) is the same a quarter turn round
(:func:`square_footprint`)."""


def square_footprint(size: np.ndarray) -> bool:
    """Whether a box of ``size`` (x, y, z) maps onto itself turned 90 deg about z."""
    return bool(abs(size[0] - size[1]) < SQUARE_FOOTPRINT)


def closing_axis(T_obj: np.ndarray, yaw: float) -> int:
    """The object's axis (0: x, 1: y) nearest a gripper's closing direction ``yaw``."""
    d = float(yaw) - yaw_of(T_obj[:3, :3])
    return 0 if abs(np.cos(d)) >= abs(np.sin(d)) else 1


def width_across(T_obj: np.ndarray, size: np.ndarray, yaw: float) -> float:
    """Extent (m) of an upright box along the gripper's closing axis (direction ``yaw``)."""
    d = float(yaw) - yaw_of(T_obj[:3, :3])
    return float(abs(np.cos(d)) * size[0] + abs(np.sin(d)) * size[1])


PLACE_NEIGHBOUR_RADIUS = 0.15
"""A place is relative to the nearest other object whose centre is within this distance (m,
horizontal) of the placed object's demonstrated resting position; farther, to the world."""
WRIST_RANGE = np.radians(150.0)
"""Largest wrist rotation away from the natural yaw that a demonstrated yaw is mapped to."""


class DemoFrames:
    """Demo quantities at sample indices: TCP (position, yaw) and object poses (gap-filled).

    Parameters
    ----------
    traj : Trajectory
        The preprocessed demonstration.
    base : array, shape (3,)
        Robot base; the gripper yaw (symmetric under 180 deg) is chosen nearest to the heading
        that needs no wrist rotation at that point.
    robot : Robot
        The arm the demonstration is planned for (its gripper: ``frames.robot``).
    """

    def __init__(self, traj: Trajectory, base: np.ndarray, robot: Robot = KUKA_LWR4) -> None:
        self.traj = traj
        self.robot = robot
        self.base = np.asarray(base, dtype=np.float64)
        self.t = traj.t_s
        self.n = len(traj)
        if self.n < 2:
            raise DemonstrationError("the trajectory needs at least 2 samples")
        tcp = np.asarray(traj.tcp, dtype=np.float64)
        good = np.all(np.isfinite(tcp), axis=1)
        if not good.any():
            raise DemonstrationError("the trajectory has no valid TCP samples")
        self.tcp = np.stack(
            [np.interp(self.t, self.t[good], tcp[good, j]) for j in range(3)], axis=1
        )
        c = self.tcp.mean(axis=0)
        self.facing = float(np.arctan2(c[1] - self.base[1], c[0] - self.base[0]))
        """Heading from the base to the demonstration's workspace (rad): natural yaws are
        measured from it, so they do not jump by 2 pi anywhere in the workspace."""
        self.yaw = self._robot_yaw(np.asarray(traj.rotation), good, base)
        self.names = list(traj.object_names)
        self.size = np.asarray(traj.object_size, dtype=np.float64)
        self._opos = np.asarray(traj.object_position, dtype=np.float64)
        self._oquat = np.asarray(traj.object_quaternion, dtype=np.float64)

    def _robot_yaw(self, rot: np.ndarray, good: np.ndarray, base: np.ndarray) -> np.ndarray:
        """Gripper yaw from the hand frame: its y axis (thumb-index direction) projected on XY."""
        yaw = np.full(self.n, np.nan)
        if rot.shape == (self.n, 3, 3):
            yax = rot[:, :, 1]
            horiz = np.hypot(yax[:, 0], yax[:, 1])
            ok = good & np.isfinite(horiz) & (horiz > 0.2)
            yaw[ok] = np.arctan2(yax[ok, 1], yax[ok, 0])
        ok = np.isfinite(yaw)
        if not ok.any():
            yaw[:] = 0.0
            ok[:] = True
        natural = self.natural_yaw(self.tcp)
        yaw = wrap_near(yaw, 0.0)
        # unwrap with period pi (the gripper is symmetric), shift by a multiple of pi so the wrist
        # rotation (natural - yaw) is centred, then saturate it at +-WRIST_RANGE
        yy = yaw[ok]
        yy = np.unwrap(2 * yy) / 2
        yaw = np.interp(self.t, self.t[ok], yy)
        rel = natural - yaw
        shift = np.round(0.5 * (rel.max() + rel.min()) / np.pi) * np.pi
        rel = np.clip(rel - shift, -WRIST_RANGE, WRIST_RANGE)
        return np.asarray(natural - rel)

    def natural_yaw(self, p: np.ndarray) -> np.ndarray:
        """Yaw that needs no wrist rotation at TCP position(s) ``p``: the last joint at 0 with the
        arm turned towards ``p`` (the robot's :attr:`~lfd.reproduce.arm.Robot.wrist_yaw`; the
        KUKA's closing axis is then tangential)."""
        p = np.asarray(p)
        heading = np.arctan2(p[..., 1] - self.base[1], p[..., 0] - self.base[0])
        offset, sign = self.robot.wrist_yaw
        # continuous over the workspace (the base is outside it): no cut behind the base
        return offset / sign + wrap_near(heading, self.facing, 2 * np.pi)

    def index(self, t_s: float) -> int:
        """Nearest sample index to a time (s since the first sample)."""
        return int(np.clip(np.searchsorted(self.t, t_s), 0, self.n - 1))

    def object_index(self, name: str | None) -> int:
        if name is None or name not in self.names:
            raise DemonstrationError(f"unknown object {name!r}; known: {self.names}")
        return self.names.index(name)

    def object_pose(self, name: str, i: int) -> np.ndarray:
        """Upright 4x4 pose of an object at sample ``i`` (nearest valid sample)."""
        k = self.object_index(name)
        p, q = self._opos[k], self._oquat[k]
        valid = np.all(np.isfinite(p), axis=1) & np.all(np.isfinite(q), axis=1)
        if not valid.any():
            raise DemonstrationError(f"object {name!r} is never observed")
        idx = np.flatnonzero(valid)
        j = int(idx[np.argmin(np.abs(idx - i))])
        T = np.eye(4)
        T[:3, :3] = quat_to_matrix(q[j])
        T[:3, 3] = p[j]
        return upright(T)

    def tcp_pose(self, i: int) -> np.ndarray:
        """4x4 top-down pose of the demonstrated TCP at sample ``i``."""
        return pose(self.tcp[i], float(self.yaw[i]))

    def support_of(self, name: str, i: int) -> str | None:
        """The object that ``name`` rests on at sample ``i`` (None = the table)."""
        k = self.object_index(name)
        p = self.object_pose(name, i)[:3, 3]
        best, best_d = None, np.inf
        for other in self.names:
            if other == name:
                continue
            q = self.object_pose(other, i)[:3, 3]
            j = self.names.index(other)
            dz = p[2] - q[2]
            dxy = np.hypot(*(p[:2] - q[:2]))
            if 0.5 * (self.size[k, 2] + self.size[j, 2]) * 0.6 < dz < self.size[j, 2] * 1.5 + 0.02:
                if dxy < 0.6 * max(self.size[j, :2].max(), self.size[k, :2].max()) and dxy < best_d:
                    best, best_d = other, dxy
        return best

    def neighbour_of(self, name: str, i: int, radius: float = PLACE_NEIGHBOUR_RADIUS) -> str | None:
        """The object nearest to ``name`` at sample ``i`` (horizontal centre distance), if
        closer than ``radius``; None otherwise (the reference of a place, see the module doc)."""
        p = self.object_pose(name, i)[:3, 3]
        best, best_d = None, float(radius)
        for other in self.names:
            if other == name:
                continue
            d = float(np.hypot(*(self.object_pose(other, i)[:2, 3] - p[:2])))
            if d < best_d:
                best, best_d = other, d
        return best


GRASP_OPENING_CLEARANCE = 0.03
"""A pick_up approaches with the fingers opened to the grasped width plus this much (m), not
fully: open fingers reach less far beside the box."""
FINGER_ROOM = 0.008
"""A grasp direction whose open fingers come closer than this (m) to another object is used only
when no direction leaves that much room."""


GRASP_FIT_CLEARANCE = 0.008
"""The open fingers must pass beside a grasped object with this much room in all (m): the
widest object the gripper can grasp is its :attr:`~lfd.reproduce.arm.Robot.max_opening`
minus this."""


def grasp_max_width(robot: Robot) -> float:
    """Widest object side (m) a pick_up can close across (:func:`check_grasp_fits`)."""
    return robot.max_opening - GRASP_FIT_CLEARANCE


def check_grasp_fits(
    name: str, size: np.ndarray, *, when: str = "", robot: Robot = KUKA_LWR4
) -> None:
    """Refuse a pick_up of an object whose every side is wider than :func:`grasp_max_width`.

    The object is its upright bounding box: the gripper closes across one of its two horizontal
    sides (a handle or knob a person may hold by is not modelled).

    Raises
    ------
    UsageError
        One line: which object, how wide, how wide the gripper opens.
    """
    narrow = float(min(size[0], size[1]))
    widest = grasp_max_width(robot)
    if narrow > widest:
        raise UsageError(
            f"cannot grasp {name}{when}: its narrowest side is {narrow * 1000:.0f} mm, the "
            f"gripper opens {robot.max_opening * 1000:.0f} mm (objects up to "
            f"{widest * 1000:.0f} mm wide, with room for the fingers)"
        )


PALM_CLEARANCE = 0.005
"""A grasp or a push is never so low that the palm (the robot's
:attr:`~lfd.reproduce.arm.Robot.palm_above_tcp`) comes closer than this to the object's top (m):
the Panda's hand hangs 27 mm above its TCP; the KUKA's palm, 70 mm, matters only for objects
taller than 11 cm."""


PUSH_ABOVE_CENTRE = 0.0
"""A push raised for the palm (:func:`palm_floor`) stays at most this far above the pushed box's
centre (m): higher, a tall narrow box topples (the Panda pushing a 4 x 4 x 7 cm box at 4.8 cm
toppled it every time; at its centre the palm touches its face near the top, and it slides)."""


def palm_floor(top: float, robot: Robot) -> float:
    """Lowest TCP height (m) at which the palm clears an object whose top is at ``top``."""
    return top - robot.palm_above_tcp + PALM_CLEARANCE


HAND_ROOM = 0.01
"""Horizontal room (m) the hand's outline (:attr:`~lfd.reproduce.arm.Robot.palm_half`) keeps
from an object whose top it does not clear (:func:`palm_near`)."""


def _rect_half(yaw: np.ndarray | float, half: tuple[float, float], u: np.ndarray) -> np.ndarray:
    """Half extent along unit vectors ``u`` (n, 2) of rectangles turned by ``yaw``."""
    c, s = np.cos(yaw), np.sin(yaw)
    return np.asarray(
        np.abs(u[:, 0] * c + u[:, 1] * s) * half[0] + np.abs(-u[:, 0] * s + u[:, 1] * c) * half[1]
    )


def palm_near(
    xy: np.ndarray,
    yaw: np.ndarray,
    half: tuple[float, float],
    T: np.ndarray,
    size: np.ndarray,
    room: float = HAND_ROOM,
) -> np.ndarray:
    """Whether the hand's outline (a rectangle of half sizes ``half``, x across the closing
    axis, centred on the TCP at ``xy`` (n, 2), its closing axis along ``yaw`` (n,)) comes
    within ``room`` (m, along the rectangles' axes) of an upright box ``T``, ``size``.

    Separating axes: the two rectangles are apart when on one of their four axes the gap
    between their shadows is at least ``room``.
    """
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    yaw = np.broadcast_to(np.asarray(yaw, dtype=np.float64), (xy.shape[0],))
    psi = float(np.arctan2(T[1, 0], T[0, 0]))
    d = xy - T[:2, 3]
    gap = np.full(xy.shape[0], -np.inf)
    # the hand's two axes and the box's two
    cands = [yaw, yaw + np.pi / 2, np.full_like(yaw, psi), np.full_like(yaw, psi + np.pi / 2)]
    for a in cands:
        u = np.column_stack([np.cos(a), np.sin(a)])
        box = _rect_half(psi, (0.5 * float(size[0]), 0.5 * float(size[1])), u)
        hand = _rect_half(yaw, (half[1], half[0]), u)  # half[1] along the closing axis
        gap = np.maximum(gap, np.abs(np.sum(u * d, axis=1)) - box - hand)
    return np.asarray(gap < room)


GRASP_EDGE = 0.005
"""A grasp off the box centre (where the person held it) keeps the fingers this far (m) inside
the box's edge."""


def grasp_opening(width: float, robot: Robot = KUKA_LWR4) -> float:
    """Opening (m) a pick_up approaches with for a closing width ``width``."""
    return float(min(robot.max_opening, width + GRASP_OPENING_CLEARANCE))


def _box_distance(q: np.ndarray, T: np.ndarray, size: np.ndarray) -> float:
    """Horizontal distance (m) from point ``q`` to an upright box (0 inside)."""
    return float(outside_distance(T[:2, :2].T @ (np.asarray(q[:2]) - T[:2, 3]), size[:2]))


def grasp_goal(
    T_obj: np.ndarray,
    size: np.ndarray,
    demo_yaw: float,
    neighbours: list[tuple[np.ndarray, np.ndarray]] | None = None,
    demo_offset: np.ndarray | None = None,
    robot: Robot = KUKA_LWR4,
    close_along: int | None = None,
) -> tuple[np.ndarray, float]:
    """Skill-knowledge grasp: closing across a face that fits the gripper, centred on the
    object along the closing axis, where the person held it along the other.

    Of the two face directions, the one whose open fingers (:func:`grasp_opening`) keep
    :data:`FINGER_ROOM` from every ``neighbours`` box (``(pose, size)``, upright) is preferred
    (then the one nearest, modulo 180 deg, to the demonstrated yaw).

    ``demo_offset`` (x, y in the object's frame, m): where the person's grasp (the TCP between
    thumb and index) was relative to the object's centre. The object is only its bounding box: a
    mug's box includes its handle, so its body is not at the box centre, and the person's grasp
    shows where the body is. Across the closing axis the grasp keeps that offset (clipped so
    the fingers stay :data:`GRASP_EDGE` inside the box); along it the grasp is centred (the
    closing fingers centre the body themselves, an offset there would push it).

    ``close_along`` (0 or 1): the object's axis the gripper closes along, asked by the caller (two
    arms: :func:`~lfd.reproduce.two_arm_clearance.stack_across`), taken when that side fits
    (:func:`grasp_max_width`) with room.

    Returns the TCP position (3,) and the yaw nearest (modulo 180 deg) to the demonstrated one.
    """
    p = T_obj[:3, 3].copy()
    p[2] = max(
        p[2],
        p[2] - size[2] / 2 + robot.finger_below_tcp + 0.006,
        palm_floor(p[2] + size[2] / 2, robot),
    )
    psi = yaw_of(T_obj[:3, :3])
    cands = [(psi, size[0]), (psi + np.pi / 2, size[1])]
    fits = (
        [c for c in cands if c[1] <= robot.max_opening - 0.015]
        or [c for c in cands if c[1] <= grasp_max_width(robot)]  # (a mug: only across its body)
        or cands
    )

    def room(c: tuple[float, float]) -> float:
        u = np.array([np.cos(c[0]), np.sin(c[0])])
        reach = grasp_opening(c[1], robot) / 2 + robot.finger_half_x
        fingers = [p[:2] + reach * u, p[:2] - reach * u]
        d = [_box_distance(f, T, sz) for T, sz in neighbours or [] for f in fingers]
        # the hand over a neighbour it does not clear: no room (its long side along the closing
        # axis, :attr:`~lfd.reproduce.arm.Robot.palm_half`)
        hit = robot.palm_half is not None and any(
            T[2, 3] + sz[2] / 2 > p[2] + robot.palm_above_tcp - PALM_CLEARANCE
            and bool(palm_near(p[None, :2], np.array([c[0]]), robot.palm_half, T, sz)[0])
            for T, sz in neighbours or []
        )
        return min(d, default=np.inf) - (1.0 if hit else 0.0)

    roomy = [c for c in fits if room(c) >= FINGER_ROOM]
    asked = cands[close_along] if close_along is not None else None
    if asked is not None and asked[1] <= grasp_max_width(robot) and room(asked) >= FINGER_ROOM:
        best = asked
    elif roomy:
        best = min(roomy, key=lambda c: abs(float(wrap_near(c[0], demo_yaw)) - demo_yaw))
    else:
        best = max(fits, key=room)
    if demo_offset is not None:
        across = np.array([-np.sin(best[0]), np.cos(best[0])])  # the gripper's x axis
        o = T_obj[:2, :2] @ np.asarray(demo_offset, dtype=np.float64)[:2]
        extent = size[1] if best is cands[0] else size[0]  # the box along ``across``
        free = max(0.0, float(extent) / 2 - robot.finger_half_x - GRASP_EDGE)
        p[:2] += float(np.clip(float(o @ across), -free, free)) * across
    return p, float(wrap_near(best[0], demo_yaw))


def push_goal(
    T_obj_end: np.ndarray,
    size: np.ndarray,
    direction: np.ndarray,
    demo_yaw: float,
    robot: Robot = KUKA_LWR4,
) -> tuple[np.ndarray, float]:
    """Where the TCP ends a push that leaves the object at ``T_obj_end``.

    The closed fingers (closing axis across the push) touch the face opposite the push direction.
    """
    u = np.asarray(direction[:2], dtype=np.float64)
    u = u / max(float(np.linalg.norm(u)), 1e-9)
    R = T_obj_end[:3, :3]
    # half extent of the box along u (support function of the rectangle)
    half = 0.5 * (abs(u @ R[:2, 0]) * size[0] + abs(u @ R[:2, 1]) * size[1])
    p = T_obj_end[:3, 3].copy()
    p[:2] -= u * (half + robot.finger_half_x + 0.002)
    top, centre = p[2] + size[2] / 2, p[2]
    p[2] = max(p[2] - size[2] / 2 + robot.finger_below_tcp + 0.008, p[2] - 0.01)
    # the palm over the box's top, but never pushing above its centre: a tall box would topple
    p[2] = max(p[2], min(palm_floor(top, robot), centre + PUSH_ABOVE_CENTRE))
    yaw = float(np.arctan2(u[1], u[0]) + np.pi / 2)
    return p, float(wrap_near(yaw, demo_yaw))
