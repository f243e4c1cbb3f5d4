"""Plan a reproduction: replay, execution with skill knowledge, or per-segment DMPs.

* ``replay`` (the paper's baseline): the demonstrated TCP path at the demonstrated speed, the
  gripper opening from the fingertip distance (minus :data:`PAD_OFFSET`, the keypoints sit
  inside the finger pads) and the hand orientation mapped to the gripper as "top-down with the
  demonstrated yaw": the yaw is the heading of the hand frame's y axis (thumb-index direction,
  the closing direction of a pinch) projected on the table; pitch and roll of the hand are
  dropped because a parallel gripper grasps cuboids best from above.
* ``skills``: ``move``/``move_with`` become straight min-jerk lines between skill end points;
  ``pick_up``/``place``/``stack``/``locate`` follow the demonstrated motion, shifted (min-jerk
  blend) so they end exactly at the object-relative goal; the gripper closes at the end of
  ``pick_up`` and opens at the end of ``place``/``stack`` (0.5 s dwell). A push approaches from
  behind the object (from above when the straight way is blocked) and then follows the
  demonstrated progress of the object along its displacement, fingers closed.
* ``dmp``: like ``skills`` but every segment, including the moves, is a DMP learned from its
  demonstrated motion and re-targeted to the new start and goal (Eq. 2 with displaced objects).

Skill knowledge that adapts the human's motion to the robot (skills and dmp): grasps centred on
the object with the closing axis across a face (the face direction whose open fingers keep room
from neighbouring boxes), approached with the fingers opened to the box's width plus 3 cm and,
when the demonstrated approach would sweep the fingers into the box, from above it vertically
(a move to a pick_up that would end low beside the object, or in another one, arrives above it:
:func:`~lfd.reproduce.motion.pick_arrival`); resting heights from the box sizes; the gripper
yaw turned during the preceding move and held constant while grasping/releasing; a vertical final
approach ("funnel") onto grasp and release poses, never dipping below them; a vertical lift-off
after a release, just until the fingertips clear the released box; a move whose straight line
would sweep the open fingers (or a carried box) over an object takes the shortest way over it in
the same vertical plane (:func:`~lfd.reproduce.motion.over`: it rises only where and as much as
needed), a DMP move is lifted only as much as its own path needs; the fingertips never go below
the table. While the gripper closes or opens (the dwell) the arm holds still. The robot's hand
(:attr:`~lfd.reproduce.arm.Robot.palm_half`) is kept clear like the fingers, at the gripper's
yaw; a grasp closes across the face whose hand clears a taller neighbour; a push whose hand
would press on the pushed box's top grasps the box instead, lifts it 3 mm, moves it along the
push and releases it (:func:`~lfd.reproduce.motion.push_geometry`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import partial
from itertools import pairwise
from typing import Any

import numpy as np

from ..errors import InvalidParameterError
from .controller import TICK, Plan
from .dmp import dmp_rollout, min_jerk, resample, warp
from .goals import (
    DemoFrames,
    check_grasp_fits,
    closing_axis,
    grasp_goal,
    grasp_opening,
    pose,
    square_footprint,
    upright,
    width_across,
    wrap_near,
    yaw_of,
)
from .motion import (
    CLEARANCE,
    GRASP_CLEAR,
    GRASP_SLACK,
    clear,
    line,
    min_jerk_clip,
    need_object,
    open_fingers,
    over,
    path_clear,
    pick_arrival,
    push_geometry,
    push_path,
    push_progress,
    required_height,
    safe_height,
    segment_indices,
)
from .program import Segment, TaskProgram
from .timescale import retime

MODES = ("replay", "skills", "dmp")
PAD_OFFSET = 0.015
"""Replay: fingertip-keypoint distance minus this = commanded pad distance (m)."""
DWELL_S = 0.5
"""Time the robot holds still while the gripper closes or opens (s)."""
Z_ABOVE_TABLE = 0.004
"""The fingertips stay this far above the table (m): the lowest TCP height is the robot's
:attr:`~lfd.reproduce.arm.Robot.finger_below_tcp` plus this."""
FUNNEL = 0.04
"""Height above a grasp/release pose below which the approach is vertical (m); at least the
object's half height plus the finger length, so open fingers never sweep over its top."""
RELEASE_LIFT = 0.003
"""Place/stack goals are this much above the exact resting pose (m)."""
RELEASE_CLEARANCE = 0.02
"""Opening beyond the held width when releasing (m): a gripper opened fully would sweep its
fingers 5 cm beside the object and knock a neighbouring box."""


@dataclass
class PlanResult:
    """A plan plus the task semantics it was built from."""

    plan: Plan
    expected: dict[str, np.ndarray]
    """Expected final 4x4 pose of every object (the displaced equivalent of the demo's)."""
    goals: list[np.ndarray] = field(default_factory=list)
    """Goal TCP position (3,) of each segment."""
    program: TaskProgram | None = None
    """The executed program (after :func:`repair_program`); ``plan.segment`` indexes it."""
    scenes: list[dict[str, np.ndarray]] = field(default_factory=list)
    """Every object's planned pose right after each place, stack and push, then at the end
    (:func:`~lfd.reproduce.displacement.check_goals` checks each for overlaps and reach)."""
    turned: set[str] = field(default_factory=set)
    """The objects stacked (last) a quarter turn round (:func:`plan_task`'s ``turn_to_across``)."""


def _ref_pose(
    frames: DemoFrames, seg: Segment, i: int, objects: dict[str, np.ndarray]
) -> tuple[np.ndarray, np.ndarray]:
    """Reference frame of a segment: (demo pose, current pose) — Eq. 2's T_o and T_o'."""
    if seg.skill in ("pick_up", "locate", "push") and seg.object in objects:
        return frames.object_pose(seg.object, i), objects[seg.object]
    if seg.skill in ("place", "stack") and seg.object is not None:
        ref = place_reference(frames, seg, seg.object, _end_index(frames, seg))
        if ref in objects:
            return frames.object_pose(ref, i), objects[ref]
    return np.eye(4), np.eye(4)


def place_reference(frames: DemoFrames, seg: Segment, name: str, i1: int) -> str | None:
    """The object a place/stack of ``name`` ending at sample ``i1`` is relative to (Eq. 2).

    stack: its support (``params["support"]``, else what it rests on in the demonstration);
    place: ``params["reference"]`` if given, else the nearest other object within
    :data:`~lfd.reproduce.goals.PLACE_NEIGHBOUR_RADIUS` of the demonstrated resting position
    (:meth:`~lfd.reproduce.goals.DemoFrames.neighbour_of`); None: the world.
    """
    if seg.skill == "stack":
        return seg.params.get("support") or frames.support_of(name, i1)
    if seg.skill == "place":
        return seg.params.get("reference") or frames.neighbour_of(name, i1)
    return None


def _end_index(frames: DemoFrames, seg: Segment) -> int:
    return frames.index(seg.end_s)


def _map(frames: DemoFrames, seg: Segment, i: int, objects: dict[str, np.ndarray]) -> np.ndarray:
    """Demo TCP pose at sample ``i`` carried along with the segment's reference (Eq. 2)."""
    T_ref, T_ref_new = _ref_pose(frames, seg, i, objects)
    T = T_ref_new @ np.linalg.inv(T_ref) @ frames.tcp_pose(i)
    return T


def _state(T: np.ndarray, ref_yaw: float) -> np.ndarray:
    return np.array([*T[:3, 3], float(wrap_near(yaw_of(T[:3, :3]), ref_yaw))])


def _demo_states(frames: DemoFrames, i0: int, i1: int) -> tuple[np.ndarray, np.ndarray]:
    sl = slice(i0, i1 + 1)
    y = np.column_stack([frames.tcp[sl], frames.yaw[sl]])
    return frames.t[sl], y


def plan_replay(frames: DemoFrames, program: TaskProgram) -> Plan:
    """The paper's baseline: the demonstrated path, orientation (mapped) and opening."""
    i0 = frames.index(program.segments[0].start_s)
    i1 = frames.index(program.segments[-1].end_s)
    t, y = _demo_states(frames, i0, i1)
    opening = np.asarray(frames.traj.opening, dtype=np.float64)[i0 : i1 + 1]
    good = np.isfinite(opening)
    opening = (
        np.interp(t, t[good], opening[good]) if good.any() else np.full(t.shape, REPLAY_OPENING)
    )
    path = resample(t, np.column_stack([y, opening]), TICK)
    seg_of = np.full(len(path), -1)
    tt = np.linspace(t[0], t[-1], len(path))
    for k, seg in enumerate(program.segments):
        seg_of[(tt >= seg.start_s) & (tt <= seg.end_s)] = k
    width = np.clip(path[:, 4] - PAD_OFFSET, 0.0, frames.robot.max_opening)
    return Plan(path[:, :3], path[:, 3], width, seg_of)


# skill knowledge in plan_task's steps (metres and seconds unless said otherwise)
CARRY_WRIST = np.radians(120.0)
"""A place keeps the yaw a box is carried with (modulo 180 deg) while the wrist stays within
this of its natural yaw at the goal."""
CARRY_CLEARANCE = 0.016
"""Clearance around a carried box's half diagonal that a move_with keeps from other objects."""
RISE_STEP = 0.01
"""A blocked DMP move is lifted in steps of this much until its path is free."""
RISE_MIN_S = 0.4
"""Shortest duration of each leg of a move that goes over objects."""
YAW_TURN = 0.3
"""Fraction of a pick_up/place/stack over which the gripper turns to the goal yaw (then holds)."""
FUNNEL_MARGIN = 0.015
"""Added to half the object's height plus the finger length for a tall object's funnel."""
LIFT_MIN_S = 0.5
"""Shortest duration of the vertical lift-off after a release."""
LIFT_ABOVE_RELEASED = CLEARANCE + 0.001
"""The lift-off ends this far above the released object's top (fingertips): the clearance
every move keeps from the objects (:func:`~lfd.reproduce.motion.clear`)."""
PUSH_BACK_OFF = 0.015
"""After a push the fingers back away from the pushed face by this much..."""
PUSH_BACK_UP = 0.005
"""...while rising this much..."""
PUSH_BACK_MIN_S = 0.3
"""...over at least this long."""
REPLAY_OPENING = 0.08
"""Replay: the opening commanded when the recording has no fingertip distance at all."""
GRASP_DESCENT_MIN_S = 0.4
"""Shortest duration of that vertical descent (s)."""
_GRASP_SKILLS = ("pick_up", "place", "stack")
"""Skills that grasp or release: they keep their goal's yaw and end in a vertical funnel."""


@dataclass
class _SkillGoal:
    """What a skill's planner decides for its segment, before the path is made."""

    goal: np.ndarray
    """TCP goal ``[x, y, z, yaw]``."""
    grip: float
    """Gripper opening commanded during the segment (m)."""
    name: str | None = None
    """The object grasped or released (pick_up, place, stack)."""
    close_at_end: bool = False
    open_at_end: bool = False
    release_top: float = 0.0
    """Height of the released object's top (m; place, stack)."""
    release: float = 0.0
    """Opening when releasing (m; place, stack)."""
    push: dict[str, Any] | None = None
    """:func:`~lfd.reproduce.motion.push_geometry` of a push."""


class _TaskPlanner:
    """The state of :func:`plan_task` along the program: where the TCP is, what is held, where
    every object is; one planner method per skill decides the goal, the shared steps make the
    path."""

    def __init__(
        self,
        frames: DemoFrames,
        program: TaskProgram,
        mode: str,
        initial: dict[str, np.ndarray] | None,
        events: list[tuple[float, str, np.ndarray]] | None = None,
        grasp_at: dict[str, np.ndarray] | None = None,
        grasp_across: dict[str, int] | None = None,
        push_by_grasp: set[str] | None = None,
        carry_to_grasp: bool = False,
        turn_to_across: bool = False,
    ) -> None:
        self.frames, self.program, self.mode = frames, program, mode
        self.grasp_at, self.across = grasp_at or {}, grasp_across or {}
        self.carry_to_grasp, self.turn_to_across = carry_to_grasp, turn_to_across
        self.turns: set[str] = set()  # stacked (next) a quarter turn round (turn_to_across)
        self.by_grasp = set(push_by_grasp or ())
        self.events = sorted(events or [], key=lambda e: e[0])
        self.robot = frames.robot
        self.segs = program.segments
        start_i = frames.index(self.segs[0].start_s)
        self.objects = {n: frames.object_pose(n, start_i) for n in frames.names}
        if initial:
            self.objects.update({k: upright(v) for k, v in initial.items()})
        self.expected = dict(self.objects)  # propagated through the program
        self.scenes: list[dict[str, np.ndarray]] = []
        self.parts: list[Plan] = []
        self.goals: list[np.ndarray] = []
        self.cur = _state(frames.tcp_pose(start_i), float(frames.yaw[start_i]))
        self.opening = self.robot.max_opening
        self.held: tuple[str, np.ndarray] | None = None
        self._slides_next = False
        """The push after the current move is done by grasping (:meth:`_slide`)."""

    def plan(self) -> PlanResult:
        for k, seg in enumerate(self.segs):
            horizon = self.segs[min(k + 1, len(self.segs) - 1)].end_s
            while self.events and self.events[0][0] <= horizon:  # moved by someone else
                _, name, T = self.events.pop(0)
                self.objects[name] = T
            self._segment(k, seg)
        frames, program = self.frames, self.program
        plan = plan_replay(frames, program) if self.mode == "replay" else Plan.concat(self.parts)
        # the fingertips never go below the table top (human fingertips may graze it)
        plan.position[:, 2] = np.maximum(
            plan.position[:, 2], self.robot.finger_below_tcp + Z_ABOVE_TABLE
        )
        # the demonstration's timing is a wish: slowed down to what the arm can follow
        plan = retime(plan, self.robot.limits)
        self.scenes.append(dict(self.expected))
        return PlanResult(plan, self.expected, self.goals, program, self.scenes, self.turns)

    # --- one planner per skill: the goal, the grip, what changes in the scene -------------
    def _pick_up(self, k: int, seg: Segment, i1: int) -> _SkillGoal:
        name, goal = _pick_goal(self.frames, seg, self.objects, i1, self.grasp_at, self.across)
        self.held = (name, np.linalg.inv(self.objects[name]) @ pose(goal[:3], goal[3]))
        size = self.frames.size[self.frames.object_index(name)]
        ask, self.turns = self.across.get(name), self.turns - {name}
        put = next((s.skill for s in self.segs[k + 1 :] if s.skill in ("place", "stack")), None)
        if self.turn_to_across and ask is not None and put == "stack" and square_footprint(size):
            if closing_axis(self.objects[name], goal[3]) != ask:  # the other axis had room
                self.turns.add(name)
        grip = grasp_opening(width_across(self.objects[name], size, goal[3]), self.robot)
        return _SkillGoal(goal, grip, name=name, close_at_end=True)

    def _place(self, k: int, seg: Segment, i1: int) -> _SkillGoal:  # place and stack
        name, goal, T_end_demo = _place_goal(
            self.frames, seg, self.objects, self.held, i1, self.cur[3], self.turns
        )
        self.objects[name] = self.expected[name] = T_end_demo
        self.scenes.append(dict(self.objects))
        size = self.frames.size[self.frames.object_index(name)]
        release = min(
            self.robot.max_opening, width_across(T_end_demo, size, goal[3]) + RELEASE_CLEARANCE
        )
        self.held = None
        return _SkillGoal(
            goal,
            0.0,
            name=name,
            open_at_end=True,
            release_top=T_end_demo[2, 3] + size[2] / 2,
            release=release,
        )

    def _push(self, k: int, seg: Segment, i1: int) -> _SkillGoal:
        geo = push_geometry(
            self.frames, seg, self.objects, self.cur[3], by_grasp=seg.object in self.by_grasp
        )
        self.objects[seg.object] = self.expected[seg.object] = geo["T_new"]  # type: ignore[index]
        self.scenes.append(dict(self.objects))
        if "grasp" in geo:  # grasped, moved along the push and released
            return _SkillGoal(
                geo["goal"],
                0.0,
                name=seg.object,
                open_at_end=True,
                release_top=float(geo["release_top"]),
                release=float(geo["opening"]),
                push=geo,
            )
        return _SkillGoal(geo["goal"], 0.0, push=geo)

    def _slide(self, k: int, seg: Segment, sg: _SkillGoal, i0: int, i1: int) -> None:
        """A push done by grasping (:func:`~lfd.reproduce.motion.push_geometry`): descend onto
        the grasp with open fingers, close, lift, move along the push, then :meth:`_after`
        opens and lifts off."""
        geo, cur = sg.push or {}, self.cur
        pieces = []
        if np.linalg.norm(cur[:3] - geo["hover"][:3]) > 0.002:
            pieces.append(line(cur, geo["hover"]))
        pieces.append(line(geo["hover"], geo["grasp"], min_s=GRASP_DESCENT_MIN_S))
        self.parts.append(Plan.of_path(np.concatenate(pieces), k, float(geo["opening"])))
        grasp = geo["grasp"]
        self.parts.append(Plan.of_path(np.repeat(grasp[None], round(DWELL_S / TICK), 0), -1, 0.0))
        moving = np.concatenate(
            [
                line(grasp, geo["contact"], min_s=PUSH_BACK_MIN_S),
                push_progress(self.frames, str(seg.object), geo, (i0, i1), self.mode),
            ]
        )
        self.parts.append(Plan.of_path(moving, k, 0.0))
        self.cur, self.opening = moving[-1].copy(), 0.0

    def _locate(self, k: int, seg: Segment, i1: int) -> _SkillGoal:
        goal = _state(_map(self.frames, seg, i1, self.objects), float(self.frames.yaw[i1]))
        return _SkillGoal(goal, self.opening)

    def _move(self, k: int, seg: Segment, i1: int) -> _SkillGoal:  # move and move_with
        """To the (mapped) start of the next skill, set up for it."""
        frames, objects = self.frames, self.objects
        grip = 0.0 if seg.skill == "move_with" else self.robot.max_opening
        if k + 1 >= len(self.segs):
            # the last move ends where the hand did, but never on or in an object (a person's
            # hand may rest on the box it has just put down)
            goal = _state(frames.tcp_pose(i1), float(frames.yaw[i1]))
            need = required_height(
                goal[None, :2], frames, objects, **self._clearance(seg), yaw=goal[3:4]
            )[0]
            goal[2] = max(goal[2], float(need) + 0.001)
            return _SkillGoal(goal, grip)
        nxt = self.segs[k + 1]
        j0, _ = segment_indices(frames, nxt)
        goal = _state(_map(frames, nxt, j0, objects), float(frames.yaw[j0]))
        if nxt.skill == "push":  # straight behind the object, or via a hover pose
            ng = push_geometry(
                frames, nxt, objects, self.cur[3], by_grasp=nxt.object in self.by_grasp
            )
            self._slides_next = "grasp" in ng
            direct = clear(self.cur, ng["start"], frames, objects, skip=())
            goal = ng["start"] if direct else ng["hover"]
        elif nxt.skill == "pick_up":  # arrive with the grasp yaw already set
            ie = _end_index(frames, nxt)
            name, grasp = _pick_goal(frames, nxt, objects, ie, self.grasp_at, self.across)
            goal[3] = grasp[3]
            # (the pick_up descends from above the grasp: :meth:`_vertical_grasp`)
            asked = name in self.grasp_at
            goal = pick_arrival(goal, grasp, name, frames, objects, asked=asked)
        elif nxt.skill in ("place", "stack"):
            ie = _end_index(frames, nxt)
            nxt_goal = _place_goal(frames, nxt, objects, self.held, ie, self.cur[3], self.turns)[1]
            goal[3] = nxt_goal[3]
            if self.carry_to_grasp and self.held and self.held[0] in self.grasp_at:
                goal[:2] = nxt_goal[:2]  # right above where the grasp puts the object
        return _SkillGoal(goal, grip)

    # --- the steps every segment goes through ------------------------------------------
    def _segment(self, k: int, seg: Segment) -> None:
        frames = self.frames
        i0, i1 = segment_indices(frames, seg)
        planner = {
            "pick_up": self._pick_up,
            "place": self._place,
            "stack": self._place,
            "push": self._push,
            "locate": self._locate,
        }.get(seg.skill, self._move)
        sg = planner(k, seg, i1)
        goal = sg.goal
        # (a move before a grasp, a release or a push arrives with that skill's yaw)
        nxt_grasps = k + 1 < len(self.segs) and self.segs[k + 1].skill in (*_GRASP_SKILLS, "push")
        if seg.skill not in ("push", *_GRASP_SKILLS) and not nxt_grasps:
            # (those keep the yaw of their goal, already wrist-friendly)
            goal[3] = float(wrap_near(goal[3], float(frames.natural_yaw(goal[:3]))))
        self.goals.append(goal[:3].copy())
        if sg.push is not None and "grasp" in sg.push:
            self._slide(k, seg, sg, i0, i1)
            self._after(sg)
            return
        path = self._path(seg, sg, i0, i1)
        if seg.skill in _GRASP_SKILLS:
            self._funnel(path, goal, str(sg.name))
        if seg.skill == "pick_up":
            path = self._vertical_grasp(path, goal, str(sg.name))
        part = Plan.of_path(path, k, sg.grip)
        if seg.skill == "move" and k + 1 < len(self.segs) and self.segs[k + 1].skill == "push":
            if not self._slides_next:
                part.opening[len(part) // 2 :] = 0.0  # close the fingers on the way to a push
        self.parts.append(part)
        self.cur = path[-1].copy()
        self._after(sg)

    def _velocity(self) -> np.ndarray:
        """The planned ``[x, y, z, yaw]`` velocity at the end of the plan so far (per s)."""
        last = self.parts[-1] if self.parts else None
        if last is None or len(last) < 2:
            return np.zeros(4)
        p = np.column_stack([last.position[-2:], last.yaw[-2:]])
        return (p[1] - p[0]) / TICK

    def _clearance(self, seg: Segment) -> dict[str, Any]:
        """How a move keeps clear of the objects (:func:`~lfd.reproduce.motion.clear`): the
        open fingers, or a carried box (it hangs lower and reaches farther)."""
        frames = self.frames
        if seg.skill == "move_with" and self.held is not None:
            hsize = frames.size[frames.object_index(self.held[0])]
            return {
                "skip": (self.held[0],),
                "below": max(self.robot.finger_below_tcp, float(self.held[1][2, 3]) + hsize[2] / 2),
                "extra": 0.5 * float(np.hypot(hsize[0], hsize[1])) + CARRY_CLEARANCE,
            }
        below, extra = open_fingers(frames)
        return {"skip": (), "below": below, "extra": extra}

    def _move_path(self, seg: Segment, goal: np.ndarray, i0: int, i1: int) -> np.ndarray:
        """A move/move_with from the current TCP state to ``goal`` that keeps clear of the
        objects (the model of :func:`~lfd.reproduce.motion.clear`).

        skills: the straight line, or where it is blocked the shortest way over the objects
        (:func:`~lfd.reproduce.motion.over`: a vertical lift-off while the fingers are beside an
        object, straight legs over the objects on the way, a vertical descent onto a goal beside
        one). dmp: the DMP from the current state, first lifted vertically (in
        :data:`RISE_STEP` steps, as little as needed) when its path would pass too low over an
        object on the way (the goal's own neighbours excepted: the demonstrated approach); the
        shortest way over the objects when no lift clears it.
        """
        frames, objects, cur = self.frames, self.objects, self.cur
        kw = self._clearance(seg)
        ways = over(cur, goal, frames, objects, **kw)
        if self.mode == "dmp":
            t, y = _demo_states(frames, i0, i1)
            # the objects the goal is beside: the demonstrated approach to them is kept
            # (those the goal is above are no exception: the path keeps clear of them)
            beside = tuple(
                n
                for n, T in objects.items()
                if goal[2]
                < required_height(goal[None, :2], frames, {n: T}, **kw, yaw=goal[3:4])[0]
                < np.inf
            )
            free = partial(
                path_clear,
                frames=frames,
                objects=objects,
                skip=(*kw["skip"], *beside),
                below=kw["below"],
                extra=kw["extra"],
            )
            top = safe_height(frames, objects, kw["below"])
            for h in np.arange(0.0, max(top - cur[2], 0.0) + RISE_STEP, RISE_STEP):
                start = cur + np.array([0.0, 0.0, h, 0.0])
                v0 = self._velocity() if h == 0.0 else np.zeros(4)  # (a lift ends at rest)
                path = dmp_rollout(t, y, start, goal, dt=TICK, start_velocity=v0)
                # the yaw is the robot's (a wrist-friendly or grasp yaw, not the hand's): a DMP's
                # spring would turn a goal offset of up to 90 deg in the first fraction of the move
                path[:, 3] = start[3] + min_jerk(len(path)) * (goal[3] - start[3])
                if free(path):
                    if h == 0.0:
                        return path
                    return np.concatenate([line(cur, start, min_s=RISE_MIN_S), path])
        if len(ways) == 2:
            return line(cur, goal)
        return np.concatenate([line(p, q, min_s=RISE_MIN_S) for p, q in pairwise(ways)])

    def _path(self, seg: Segment, sg: _SkillGoal, i0: int, i1: int) -> np.ndarray:
        """The segment's path from the current TCP state to its goal."""
        cur, goal = self.cur, sg.goal
        if sg.push is not None:
            return push_path(self.frames, str(seg.object), sg.push, (i0, i1), cur, self.mode)
        if seg.skill in ("move", "move_with"):
            return self._move_path(seg, goal, i0, i1)
        t, y = _demo_states(self.frames, i0, i1)
        if self.mode == "dmp":
            path = dmp_rollout(t, y, cur, goal, dt=TICK, start_velocity=self._velocity())
        else:
            path = warp(resample(t, y, TICK), cur, goal)
        # the yaw is the robot's (turned from the current yaw to the goal's), not the hand's: a
        # goal yaw differing from the hand's by a half or full turn would be blended in as one
        path[:, 3] = cur[3] + min_jerk(len(path)) * (goal[3] - cur[3])
        return path

    def _funnel(self, path: np.ndarray, goal: np.ndarray, name: str) -> None:
        """Grasp and release: turn early, then keep the yaw; never below the goal height (the
        human's hand may dip lower); a vertical final approach (within the funnel above the
        goal, x-y converge onto it). Changes ``path`` in place."""
        cur = self.cur
        path[:, 3] = cur[3] + min_jerk_clip(len(path), YAW_TURN) * (goal[3] - cur[3])
        path[:, 2] = np.maximum(path[:, 2], goal[2])
        obj_h = self.frames.size[self.frames.object_index(name), 2]
        funnel = max(FUNNEL, obj_h / 2 + self.robot.finger_below_tcp + FUNNEL_MARGIN)
        w = np.clip((path[:, 2] - goal[2]) / funnel, 0.0, 1.0)[:, None]
        path[:, :2] = goal[:2] + w * (path[:, :2] - goal[:2])
        # a start inside the funnel is where the robot is: the pull is blended in, not jumped
        ramp = min_jerk_clip(len(path), YAW_TURN)[:, None]
        path[:, :2] += (1.0 - ramp) * (cur[:2] - path[0, :2])

    def _vertical_grasp(self, path: np.ndarray, goal: np.ndarray, name: str) -> np.ndarray:
        """A pick_up whose open fingertips would pass below the object's top more than
        :data:`GRASP_SLACK` beside the grasp pose (they would hit it) instead stays above
        :data:`GRASP_CLEAR` over the top and descends vertically onto the grasp pose."""
        T = self.objects[name]
        top = T[2, 3] + self.frames.size[self.frames.object_index(name), 2] / 2
        low = path[:, 2] - self.robot.finger_below_tcp < top + GRASP_CLEAR
        off = np.hypot(path[:, 0] - goal[0], path[:, 1] - goal[1])
        if not np.any(low & (off > GRASP_SLACK)):
            return path
        hover = np.array(
            [*goal[:2], max(goal[2], top + self.robot.finger_below_tcp + GRASP_CLEAR), goal[3]]
        )
        path = path.copy()
        path[:, 2] = np.maximum(path[:, 2], hover[2])
        pieces = [path, line(hover, goal, min_s=GRASP_DESCENT_MIN_S)[1:]]
        start = self.cur
        if start[2] < hover[2] - 1e-6:  # starting low beside the object: rise vertically first
            up = np.array([*start[:2], hover[2], start[3]])
            pieces[:0] = [line(start, up, min_s=GRASP_DESCENT_MIN_S), line(up, path[0])[1:-1]]
        return np.concatenate(pieces)

    def _after(self, sg: _SkillGoal) -> None:
        """What follows the segment: close (pick_up), open and lift off (place, stack), back
        off the pushed face (push)."""
        cur = self.cur
        dwell = round(DWELL_S / TICK)
        if sg.close_at_end:
            self.opening = 0.0
            self.parts.append(Plan.of_path(np.repeat(cur[None], dwell, 0), -1, 0.0))
        if sg.open_at_end:
            self.opening = self.robot.max_opening
            self.parts.append(Plan.of_path(np.repeat(cur[None], dwell, 0), -1, sg.release))
            up = cur.copy()  # leave the released object vertically, just clear of its top
            up[2] = max(up[2], sg.release_top + self.robot.finger_below_tcp + LIFT_ABOVE_RELEASED)
            self.parts.append(Plan.of_path(line(cur, up, min_s=LIFT_MIN_S), -1, sg.release))
            self.cur = up
        if sg.push is not None and "grasp" not in sg.push:  # back off the pushed face
            self.opening = 0.0
            u = sg.push["u"]
            back = cur + np.array([-PUSH_BACK_OFF * u[0], -PUSH_BACK_OFF * u[1], PUSH_BACK_UP, 0.0])
            self.parts.append(Plan.of_path(line(cur, back, min_s=PUSH_BACK_MIN_S), -1, 0.0))
            self.cur = back


def plan_task(
    frames: DemoFrames,
    program: TaskProgram,
    mode: str,
    *,
    initial: dict[str, np.ndarray] | None = None,
    events: list[tuple[float, str, np.ndarray]] | None = None,
    grasp_at: dict[str, np.ndarray] | None = None,
    grasp_across: dict[str, int] | None = None,
    push_by_grasp: set[str] | None = None,
    carry_to_grasp: bool = False,
    turn_to_across: bool = False,
) -> PlanResult:
    """Plan ``skills`` or ``dmp`` execution (or ``replay``) of ``program``.

    Parameters
    ----------
    frames : DemoFrames
        The demonstration.
    program : TaskProgram
        The segmentation.
    mode : {"replay", "skills", "dmp"}
    initial : dict, optional
        Initial 4x4 object poses (displaced); default: the demonstrated initial poses.
    events : list of (t_s, name, 4x4), optional
        Objects moved by someone else (the other arm, :mod:`.two_arms`): ``name`` is at the
        pose from demonstration time ``t_s`` on. Each is known to the planner from the skill
        before the one during which it happens (a ``move`` plans towards the next skill's goal).
    grasp_at : dict, optional
        Where each named object is grasped (x, y in its frame; the component along the
        gripper's closing axis is centred as ever), instead of where the person held it (a
        handover's two grasps kept apart, :mod:`.two_arm_handover`).
    grasp_across : dict, optional
        The axis (0: x, 1: y of the object) the gripper closes along for each named object,
        when it fits (:func:`~lfd.reproduce.goals.grasp_goal`'s ``close_along``).
    push_by_grasp : set, optional
        The objects whose pushes grasp them and slide them instead, when they fit the gripper
        (:func:`~lfd.reproduce.motion.push_geometry`'s ``by_grasp``).
    carry_to_grasp : bool
        A carry before a place or stack of an object grasped at ``grasp_at`` ends right above
        the release (where that grasp puts the object; the place or stack then goes straight
        down), not where the person's hand, holding it elsewhere, began to put it down (a box
        stacked beside the other arm's press, taken at its end away from it:
        :func:`~lfd.reproduce.two_arm_clearance.stack_away`). Off (a handover's grasps), the
        place or stack itself moves the difference while it descends.
    turn_to_across : bool
        A square box (:func:`~lfd.reproduce.goals.square_footprint`) whose ``grasp_across``
        axis does not fit at its pick-up is stacked a quarter turn round: there the gripper
        closes along the direction asked (beside the other arm's press, across the line to
        it: :func:`~lfd.reproduce.two_arm_clearance.stack_across`).
    """
    if mode not in MODES:
        raise InvalidParameterError(f"unknown mode {mode!r}; choose one of {', '.join(MODES)}")
    program = repair_program(frames, program)
    if mode != "replay":
        check_grasps(frames, program)
    return _TaskPlanner(
        frames,
        program,
        mode,
        initial,
        events,
        grasp_at,
        grasp_across,
        push_by_grasp,
        carry_to_grasp,
        turn_to_across,
    ).plan()


def check_grasps(frames: DemoFrames, program: TaskProgram) -> None:
    """Refuse a program that picks up an object wider than the gripper can close across
    (:func:`~lfd.reproduce.goals.check_grasp_fits`), before anything is planned or run."""
    for seg in repair_program(frames, program).segments:
        if seg.skill == "pick_up" and seg.object in frames.names:
            size = frames.size[frames.object_index(seg.object)]
            check_grasp_fits(
                str(seg.object),
                size,
                when=f" (pick_up at {seg.start_s:.1f} s)",
                robot=frames.robot,
            )


def repair_program(frames: DemoFrames, program: TaskProgram) -> TaskProgram:
    """Insert a missing ``pick_up`` before a ``move_with`` of an object that is not held.

    A segmentation may merge the grasp into the preceding ``move``; the grasp is then cut out
    of that move from the moment the hand comes closest to the object (the pick_up segment
    gets the rest).
    """
    segs: list[Segment] = []
    held: str | None = None
    for seg in program.segments:
        if seg.skill == "pick_up":
            held = seg.object
        elif seg.skill in ("place", "stack"):
            held = None
        elif seg.skill == "move_with" and seg.object is not None and held != seg.object:
            prev = segs[-1] if segs else None
            if prev is not None and prev.skill in ("move", "locate") and seg.object in frames.names:
                a, b = frames.index(prev.start_s), frames.index(prev.end_s)
                obj = np.array([frames.object_pose(seg.object, i)[:3, 3] for i in range(a, b + 1)])
                dist = np.linalg.norm(frames.tcp[a : b + 1] - obj, axis=1)
                # the approach starts where the hand comes within 12 cm of the object
                near = np.flatnonzero(dist < max(0.12, float(dist.min()) + 0.02))
                cut = frames.t[a + int(near[0])] if near.size else prev.end_s
                cut = min(max(cut, prev.start_s), prev.end_s)
                segs[-1] = Segment(prev.skill, prev.start_s, cut, prev.object, prev.params)
                segs.append(Segment("pick_up", cut, seg.start_s, seg.object))
                held = seg.object
        segs.append(seg)
    segs = [s for s in segs if s.end_s > s.start_s or s.skill != "move"]
    return TaskProgram(segs)


def _pick_goal(
    frames: DemoFrames,
    seg: Segment,
    objects: dict[str, np.ndarray],
    i1: int,
    grasp_at: dict[str, np.ndarray] | None = None,
    across: dict[str, int] | None = None,
) -> tuple[str, np.ndarray]:
    """Grasp goal ``[x, y, z, yaw]`` of a pick_up (object-centred, wrist-friendly yaw; where
    the person held it along the object, or ``grasp_at[name]``)."""
    name = need_object(seg, objects)
    size = frames.size[frames.object_index(name)]
    others = [(T, frames.size[frames.object_index(n)]) for n, T in objects.items() if n != name]
    # (only the boxes on the same level: a box it rests on or under is no obstacle for fingers)
    near = [
        (T, sz)
        for T, sz in others
        if abs(T[2, 3] - objects[name][2, 3]) < 0.5 * (sz[2] + size[2]) - 0.005
    ]
    # where the person held it, relative to the object (Eq. 2: it moves with the object)
    held = np.linalg.inv(frames.object_pose(name, i1)) @ frames.tcp_pose(i1)
    at = (grasp_at or {}).get(name, held[:2, 3])
    ax = (across or {}).get(name)
    p, yaw = grasp_goal(objects[name], size, float(frames.yaw[i1]), near, at, frames.robot, ax)
    # the gripper is symmetric: take the representative the wrist reaches most easily
    yaw = float(wrap_near(yaw, float(frames.natural_yaw(p))))
    return name, np.array([*p, yaw])


def _place_goal(
    frames: DemoFrames,
    seg: Segment,
    objects: dict[str, np.ndarray],
    held: tuple[str, np.ndarray] | None,
    i1: int,
    yaw_now: float | None = None,
    turns: set[str] | None = None,
) -> tuple[str, np.ndarray, np.ndarray]:
    """TCP goal of a place/stack and the object's resting pose there, relative to
    :func:`place_reference` (Eq. 2); an object of ``turns`` stacked a quarter turn round.

    The gripper is symmetric: of the goal yaw's two representatives, the one nearest ``yaw_now``
    (the yaw the box is carried with) when the wrist stays within :data:`CARRY_WRIST` of its
    natural yaw there (a carried box is not spun half a turn), else the most natural one.
    """
    carried = seg.object or (held[0] if held else None)
    name = need_object(Segment(seg.skill, 0, 0, carried), objects)
    T_end = frames.object_pose(name, i1)
    h = frames.size[frames.object_index(name), 2]
    ref = place_reference(frames, seg, name, i1)
    if ref in objects and ref != name:  # Eq. 2: the resting pose follows its reference
        T_end = objects[ref] @ np.linalg.inv(frames.object_pose(ref, i1)) @ T_end
    if name in (turns or ()):  # only a box stacked next is turned (``_pick_up``)
        T_end = T_end @ pose(np.zeros(3), np.pi / 2)
    T_end[2, 3] = h / 2  # objects rest on the table (the tracked height is noisy) ...
    if seg.skill == "stack" and ref in objects:  # ... or on top of their support
        T_end[2, 3] = objects[ref][2, 3] + frames.size[frames.object_index(ref), 2] / 2 + h / 2
    rel = held[1] if held and held[0] == name else np.linalg.inv(T_end) @ frames.tcp_pose(i1)
    T_goal = T_end @ rel
    T_goal[2, 3] += RELEASE_LIFT
    natural = float(frames.natural_yaw(T_goal[:3, 3]))
    goal = _state(T_goal, natural)
    if yaw_now is not None:
        kept = float(wrap_near(goal[3], yaw_now))
        if abs(float(wrap_near(kept - natural, 0.0, 2 * np.pi))) <= CARRY_WRIST:
            goal[3] = kept
    if held and held[0] == name:
        # the box hangs where it was grasped (off its centre when the person held it so): the
        # TCP goes where that puts the box's centre on its resting position, at the goal's yaw
        # (which may be the held yaw's other, symmetric representative)
        in_grip = np.linalg.inv(held[1])[:3, 3]
        goal[:3] = T_end[:3, 3] - pose(np.zeros(3), float(goal[3]))[:3, :3] @ in_grip
        goal[2] += RELEASE_LIFT
    return name, goal, T_end
