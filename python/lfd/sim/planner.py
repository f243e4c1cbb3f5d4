"""The planner's state: where the hand and the objects are, and what has been planned so far.

Skills (:mod:`lfd.sim.skills`) append segments, labels and object events to a :class:`Planner`.
Objects stay upright: an object pose is its centre ``pos`` (3,) and its ``yaw`` (rad).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..demo import INDEX_TIP, THUMB_TIP
from .hand import HandKinematics
from .motion import HandState, Segment, rotation
from .scene import DEMONSTRATOR_SHOULDER, ObjectSpec
from .variability import Variability


@dataclass
class ObjectPose:
    """Upright object pose: centre (m) and yaw (rad)."""

    pos: np.ndarray
    yaw: float

    def copy(self) -> ObjectPose:
        return ObjectPose(np.array(self.pos, float), float(self.yaw))


@dataclass(frozen=True)
class Attach:
    """From ``t`` on, ``name`` moves rigidly with the hand frame (TCP + wrist yaw)."""

    t: float
    name: str


@dataclass(frozen=True)
class Detach:
    """At ``t`` the object is released and rests at the planned pose."""

    t: float
    name: str
    pose: ObjectPose


@dataclass(frozen=True)
class Push:
    """During ``[t0, t1]`` the object slides along ``direction`` once the TCP passes ``contact``."""

    t0: float
    t1: float
    name: str
    direction: np.ndarray
    contact: np.ndarray


Event = Attach | Detach | Push


@dataclass(frozen=True)
class PlannedLabel:
    skill: str
    t0: float
    t1: float
    object: str | None


@dataclass
class Planner:
    """Accumulates the demonstrator's plan.

    Parameters
    ----------
    rng : numpy.random.Generator
        The demonstration's random stream (all motion draws come from it).
    var : Variability
        Resolved variability (no ``None`` left).
    kin : HandKinematics
        Hand forward kinematics (for grasp, pointing and pushing geometry).
    specs : dict
        Object specifications by name.
    poses : dict
        Current planned object poses by name (updated as skills are planned).
    """

    rng: np.random.Generator
    var: Variability
    kin: HandKinematics
    specs: dict[str, ObjectSpec]
    poses: dict[str, ObjectPose]
    t: float = 0.0
    hand: HandState | None = None
    held: str | None = None
    grasp_rel: tuple[np.ndarray, float] | None = None
    segments: list[Segment] = field(default_factory=list)
    labels: list[PlannedLabel] = field(default_factory=list)
    events: list[Event] = field(default_factory=list)
    skill_speed: float = 1.0
    pending: dict[tuple[str, str], dict[str, Any]] = field(default_factory=dict)
    log: list[dict[str, Any]] = field(default_factory=list)
    last_grasp: str | None = None
    grasps: list[dict[str, Any]] = field(default_factory=list)
    shoulder: np.ndarray = field(default_factory=lambda: DEMONSTRATOR_SHOULDER.copy())
    """The shoulder of this hand's arm (the forearm's natural direction starts there)."""
    carry_pose: ObjectPose | None = None
    """Where the next Move with puts the held object (in the air: a handover); None: on a free
    table spot or onto another object, drawn."""
    lift_scale: float = 1.0
    """Scales how high the natural demonstrator's Move with may rise beyond its 5 cm (1: up to
    45 cm, as from the table; a handover's carries, which start or end in the air, rise less)."""
    x_range: tuple[float, float] | None = None
    """The x range of the free table spots this hand puts objects on (None: the workspace)."""
    stack_offset: dict[str, np.ndarray] = field(default_factory=dict)
    """Per base object, the (x, y) offset (m, world) from its centre at which the next object
    stacked on it is put (none: centred)."""

    @property
    def scale(self) -> float:
        return float(self.var.hand_scale or 1.0)

    @property
    def state(self) -> HandState:
        if self.hand is None:
            raise RuntimeError("the hand has no initial pose yet")
        return self.hand

    # --- time and segments ---------------------------------------------------------------
    def begin_skill(self) -> None:
        """Draw this skill's speed factor (per-demo speed x per-skill jitter)."""
        jitter = float(np.exp(self.rng.normal(0.0, self.var.speed_jitter)))
        self.skill_speed = float(self.var.speed or 1.0) * jitter

    def dur(self, low: float, high: float) -> float:
        """A nominal duration drawn in [low, high] seconds, divided by the skill speed."""
        return float(self.rng.uniform(low, high)) / self.skill_speed

    def go(self, duration: float, end: HandState, **kw: object) -> None:
        """Append a segment from the current hand state to ``end``."""
        seg = Segment(self.t, self.t + duration, self.state, end, **kw)  # type: ignore[arg-type]
        self.segments.append(seg)
        self.t += duration
        self.hand = end

    def hold(self, duration: float) -> None:
        """Keep still (fingers and tremor still move)."""
        if duration > 0:
            self.go(duration, self.state.moved())

    def maybe_pause(self) -> None:
        """With probability ``var.pauses`` keep still for 0.15-0.6 s."""
        if self.rng.random() < float(self.var.pauses or 0.0):
            self.hold(float(self.rng.uniform(0.15, 0.6)))

    def detour(self, p0: np.ndarray, p1: np.ndarray, *, frac: tuple[float, float]) -> np.ndarray:
        """A horizontal mid-path offset perpendicular to ``p1 - p0`` (m), shape (3,)."""
        d = np.asarray(p1, float)[:2] - np.asarray(p0, float)[:2]
        length = float(np.linalg.norm(np.asarray(p1, float) - np.asarray(p0, float)))
        amp = float(self.var.detour or 0.0) * float(self.rng.uniform(*frac)) * length
        amp *= 1.0 if self.rng.random() < 0.5 else -1.0
        n = np.linalg.norm(d)
        perp = np.array([-d[1], d[0]]) / n if n > 1e-6 else np.array([1.0, 0.0])
        return np.array([perp[0] * amp, perp[1] * amp, 0.0])

    # --- hand geometry ---------------------------------------------------------------------
    def relative_keypoints(
        self, q: np.ndarray, yaw: float, pitch: float, roll: float
    ) -> np.ndarray:
        """Keypoints relative to the TCP in world axes for a posture and orientation, (21, 3)."""
        kp = self.kin.local_keypoints(q)
        tcp = 0.5 * (kp[THUMB_TIP] + kp[INDEX_TIP])
        R = rotation(np.array(yaw), np.array(pitch), np.array(roll))
        return (kp - tcp) @ R.T

    def natural_yaw(self, xy: np.ndarray) -> float:
        """Forearm direction from the demonstrator's shoulder to ``xy``, plus approach jitter."""
        d = np.asarray(xy[:2], float) - self.shoulder[:2]
        dev = np.deg2rad(self.var.approach_deg) * float(self.rng.uniform(-1.0, 1.0))
        return float(np.arctan2(d[1], d[0]) + dev)

    def top(self, name: str) -> float:
        """Height of the top face of an object (m)."""
        return float(self.poses[name].pos[2] + 0.5 * self.specs[name].size[2])

    def label(self, skill: str, t0: float, obj: str | None) -> None:
        """Close the label of a skill that started at ``t0`` (the first label starts at 0)."""
        self.labels.append(PlannedLabel(skill, 0.0 if not self.labels else t0, self.t, obj))


def wrap_angle(a: float) -> float:
    """Angle wrapped to (-pi, pi]."""
    return float((a + np.pi) % (2.0 * np.pi) - np.pi)
