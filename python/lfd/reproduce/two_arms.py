"""A two-hand task program (:class:`~lfd.reproduce.program.HandsProgram`) on a two-arm robot
(:class:`~lfd.reproduce.aloha.TwoArmRobot`): each hand's lane to the arm of its side.

* **Bases** (:func:`~.two_arm_bases.choose_bases`): each arm's base is placed, as one arm's is
  (:func:`~lfd.reproduce.scene.choose_base`), so that every TCP point of its hand's lane is
  reachable top-down, the right arm on the right of the workspace (+x) and the left on the left,
  at least :data:`~.two_arm_bases.BASE_GAP` apart and clear of the objects and of both lanes'
  paths.
* **Plans**: each lane is planned alone by the one-arm planner
  (:func:`~lfd.reproduce.displacement.plan_layout`, the lane's
  :meth:`~lfd.reproduce.program.HandsProgram.program`), then the lanes are put on one clock
  (:func:`synchronise`): at a ``hold_until`` the holding arm keeps holding (its ``move_with``
  is lengthened) until the other arm's step has ended, and the other arm's step starts only once
  the holder holds. At a ``handover`` the taker's lane is planned with the object where the
  giver's ``place`` leaves it, the taker's ``pick_up`` starts once the giver is there and the
  giver lets go only once the taker has grasped, the two grasps a gripper's width apart
  (:mod:`.two_arm_handover`). A ``carry``: both arms hold the object
  together (:mod:`lfd.reproduce.two_arm_carry`).
* **Clearance** (:mod:`.two_arm_holds`): at a ``hold_until`` whose arms' colliding geoms
  come within 1 cm of each other on the common clock (each arm's IK following its plan), the
  hold is pressed at the object's end away from the other arm's step, and if still too close
  the other arm's approach waits until the holder holds, or a pushing arm waits for the hold
  low behind the box it pushes, or pushes it by grasping and sliding it; then the hold is
  re-ordered, or the holder's way to it made straight (:mod:`.two_arm_clearance`); each kept
  only when it leaves more room.
* **Execution** (:func:`execute_two`): both arms in one MuJoCo scene, one IK per arm, one
  control tick for both; an arm that has finished holds its last pose. The links collide with
  the table and the other arm (:mod:`.two_arms_contacts`): the first contact of the two arms,
  and of each arm with the table, is a failure naming the arm.
* **Layouts** (:func:`plan_two_arms` with ``displace``): the objects moved as ``--displace``
  moves them for one arm, the bases chosen again for the re-grounded paths; each lane is
  planned twice, the second time knowing where the other arm puts the objects only it handles
  (:func:`~.two_arm_lanes.lane_events`). A two-handed carry and a hold by pressing start
  from the layout too (the units of :func:`~.two_arm_sequence.plan_sequence` and
  :func:`~.two_arm_press.plan_press_lane` re-grounded on the moved objects), their goals
  checked per arm (:func:`~.two_arm_lanes.check_lane_goals`). Randomised layouts:
  :mod:`.two_arms_randomise`.
* **Success**, per arm (its skills, :func:`~lfd.reproduce.outcome.skill_results` over the
  objects the other arm does not handle, and no collision) and for the task (every object at
  its goal: the pose the lane that handles it leaves it in, else where it started; no
  collision).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any, NamedTuple

import numpy as np

from ..errors import DemonstrationError, UsageError
from .aloha import TwoArmRobot
from .arm import OPTIONS, Robot
from .controller import LOOKAHEAD, TICK, Execution, Plan
from .ik import ArmIK, gripper_rotation
from .program import HandsProgram, TaskProgram
from .scene import ObjectSpec, _colour
from .two_arm_bases import choose_bases, layout, mount_yaw, mounted
from .two_arm_clock import _before, _end, _release, _start, _wait  # noqa: F401 (tests use them)
from .two_arm_lanes import check_lane_goals, lane_events, named_arm, plan_lane
from .two_arms_contacts import ARM_BITS, Collision, Contacts, collision_bits

RUNS = ("hold_until", "handover", "carry")
"""The synchronisation points the two arms run; the others are refused."""


def scene_xml(
    bases: dict[str, np.ndarray],
    objects: list[ObjectSpec],
    robot: TwoArmRobot,
    yaws: dict[str, float] | None = None,
) -> str:
    """MJCF of the table (top at z = 0), both arms at their bases (turned by ``yaws``) and the
    cuboids."""
    bodies = []
    for ob in objects:
        s, p = np.asarray(ob.size) / 2, ob.position
        x, y, z, w = ob.quaternion
        bodies.append(
            f'<body name="{ob.name}" pos="{p[0]:.6f} {p[1]:.6f} {p[2]:.6f}" '
            f'quat="{w:.6f} {x:.6f} {y:.6f} {z:.6f}"><freejoint name="{ob.name}"/>'
            f'<geom name="{ob.name}" type="box" size="{s[0]:.5f} {s[1]:.5f} {s[2]:.5f}" '
            f'mass="0.1" friction="1 0.005 0.0001" condim="4" rgba="{_colour(ob.name)}"/></body>'
        )
    arms = "".join(
        f'<body name="{side}/robot_base" pos="{b[0]:.6f} {b[1]:.6f} 0">'
        f"{collision_bits(mounted(robot.arms[side], (yaws or {}).get(side, 0.0)).body, side)}"
        "</body>"
        for side, b in bases.items()
    )
    acts = [robot.arms[side].actuators for side in bases]
    actuators = "<actuator>" + "".join(_inner(a, "actuator") for a in acts) + "</actuator>"
    contacts = "<contact>" + "".join(_inner(a, "contact") for a in acts) + "</contact>"
    c = np.mean([b[:2] for b in bases.values()], axis=0)
    return f"""<mujoco model="lfd_two_arms">{OPTIONS}{robot.ik.defaults}
  <visual><quality offsamples="0"/><global offwidth="1280" offheight="960"/></visual>
  <worldbody>
    <light pos="{c[0]:.3f} {c[1]:.3f} 2.5" dir="0 0 -1" directional="true"/>
    <geom name="table" type="box" pos="{c[0]:.3f} {c[1]:.3f} -0.02" size="1.2 1.2 0.02"
          rgba="0.75 0.7 0.62 1" friction="1 0.005 0.0001" conaffinity="{1 | sum(ARM_BITS.values())}"/>
    {arms}{"".join(bodies)}
  </worldbody>{actuators}{contacts}
</mujoco>"""


def _inner(xml: str, tag: str) -> str:
    a, b = xml.find(f"<{tag}>"), xml.find(f"</{tag}>")
    return xml[a + len(tag) + 2 : b] if a >= 0 and b > a else ""


# --- one clock for both lanes ------------------------------------------------------------------
def synchronise(plans: dict[str, Plan], hands: HandsProgram) -> dict[str, Plan]:
    """The lanes on one clock: at every ``hold_until`` the other arm's step waits until the
    holder has begun holding, and the holder's next step waits until the other arm's step has
    ended (its release, lift-off or back-off included)."""
    from .two_arm_handover import handover_waits

    plans = dict(plans)
    for _ in range(2 * len(hands.sync) + 1):
        changed = False
        for p in hands.sync:
            if p.kind == "handover":
                changed |= handover_waits(plans, p, hands)
                continue
            if p.kind != "hold_until":
                continue
            a, b = plans[p.hand], plans[p.other]
            # the other arm starts its step once the holder holds (its move_with has begun)
            need = _start(a, p.step) - _start(b, p.other_step)
            if need > 0:
                at = _start(b, p.other_step)
                plans[p.other] = _wait(b, at, need, _before(b, at))
                changed = True
            b = plans[p.other]
            need = _start(b, p.other_step + 1) - _start(a, p.step + 1)
            if need > 0:
                plans[p.hand] = _wait(a, _start(a, p.step + 1), need, p.step)
                changed = True
        if not changed:
            break
    return plans


def check_runs(hands: HandsProgram) -> None:
    """Refuse, in one line, a program with a synchronisation the two arms do not run yet."""
    for p in hands.sync:
        if p.kind not in RUNS:
            raise DemonstrationError(
                f"{p.describe(hands.lanes)}: a {p.kind} is not reproduced on two arms yet "
                f"(runs: {', '.join(RUNS)}); --hand right or --hand left reproduces one hand's part"
            )
    from .two_arm_carry import check_carries

    check_carries(hands)


# --- both arms in one scene ----------------------------------------------------------------------
def execute_two(
    plans: dict[str, Plan],
    bases: dict[str, np.ndarray],
    objects: list[ObjectSpec],
    robot: TwoArmRobot,
    yaws: dict[str, float],
    *,
    settle_s: float = 0.5,
    collisions: list[Collision] | None = None,
) -> dict[str, Execution]:
    """Run every arm's plan in one scene on one clock; each arm's :class:`Execution` (its TCP
    and IK, every object's motion; the scene's ``qpos`` and ``ctrl`` per tick and its MJCF, the
    same for both, as one arm's for robot data). ``collisions`` (when given) gets the first contact of an
    arm with the other arm, and of each arm with the table (:class:`Collision`)."""
    import mujoco

    t0 = time.perf_counter()
    warnings: list[str] = []
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(warnings.append)
    try:
        xml = scene_xml(bases, objects, robot, yaws)
        model = mujoco.MjModel.from_xml_string(xml)
        data = mujoco.MjData(model)
        arms = {s: _Arm(model, data, robot, s, bases[s], yaws[s], plans[s]) for s in plans}
        mujoco.mj_forward(model, data)
        body_ids = [model.body(o.name).id for o in objects]
        steps = max(1, round(TICK / model.opt.timestep))
        n = max(len(p) for p in plans.values())
        contacts = Contacts(model, list(plans))
        opos = np.zeros((len(objects), n, 3))
        oquat = np.zeros((len(objects), n, 4))
        qpos, ctrl = np.zeros((n, model.nq)), np.zeros((n, model.nu))
        for i in range(n + round(settle_s / TICK)):
            for arm in arms.values():
                arm.command(data, i)
            if i < n:
                qpos[i], ctrl[i] = data.qpos, data.ctrl
            for _ in range(steps):
                mujoco.mj_step(model, data)
            contacts.check(data, (i + 1) * TICK)
            if i < n:
                for arm in arms.values():
                    arm.record(data, i)
                for j, b in enumerate(body_ids):
                    opos[j, i] = data.xpos[b]
                    w, x, y, z = data.xquat[b]
                    oquat[j, i] = (x, y, z, w)
    finally:
        mujoco.set_mju_user_warning(previous)
    if collisions is not None:
        collisions.extend(sorted(contacts.seen.values(), key=lambda c: c.t_s))
    fpos = np.array([data.xpos[b].copy() for b in body_ids]).reshape(len(objects), 3)
    fq = np.array([[*data.xquat[b][1:], data.xquat[b][0]] for b in body_ids]).reshape(-1, 4)
    wall = time.perf_counter() - t0
    return {
        s: Execution(
            tcp=arm.tcp[: len(plans[s])],
            planned_ik=arm.ik_tcp[: len(plans[s])],
            object_names=[o.name for o in objects],
            object_position=opos[:, : len(plans[s])],
            object_quaternion=oquat[:, : len(plans[s])],
            final_position=fpos,
            final_quaternion=fq,
            wall_time_s=wall,
            warnings=warnings,
            qpos=qpos,
            ctrl=ctrl,
            scene=xml,
        )
        for s, arm in arms.items()
    }


class MountedIK(ArmIK):
    """:class:`~lfd.reproduce.ik.ArmIK` of an arm whose base is turned by ``yaw``."""

    def __init__(self, base: np.ndarray, yaw: float, arm: Robot) -> None:
        super().__init__(base, robot=mounted(arm, yaw))
        self.yaw = yaw

    def seed_towards(self, position: np.ndarray, rotation: np.ndarray) -> None:
        super().seed_towards(position, rotation)
        q = self.q
        q[0] = (q[0] - self.yaw + np.pi) % (2 * np.pi) - np.pi
        self.reset(q)


class _Arm:
    """One arm of the scene: its IK, its servos' ``ctrl`` entries and what it did."""

    def __init__(
        self,
        model: Any,
        data: Any,
        robot: TwoArmRobot,
        side: str,
        base: np.ndarray,
        yaw: float,
        plan: Plan,
    ) -> None:
        arm = robot.arms[side]
        self.plan, self.max_opening, self.dof = plan, arm.max_opening, arm.dof
        self.ik = MountedIK(base, yaw, robot.ik)
        R0 = gripper_rotation(float(plan.yaw[0]))
        self.ik.seed_towards(plan.position[0], R0)
        q0 = self.ik.solve(plan.position[0], R0)
        self.ctrl = [model.actuator(f"{side}/act_{j[len(side) + 1 :]}").id for j in arm.arm_joints]
        self.fingers = [
            model.actuator(f"{side}/act_{f[len(side) + 1 :]}").id for f in arm.finger_joints
        ]
        w0 = float(np.clip(plan.opening[0], 0.0, self.max_opening)) / 2
        for j, q in zip(arm.arm_joints, q0, strict=True):
            data.qpos[model.joint(j).qposadr[0]] = q
        for f in arm.finger_joints:
            data.qpos[model.joint(f).qposadr[0]] = w0
        data.ctrl[self.ctrl] = q0
        data.ctrl[self.fingers] = w0
        self.site = model.site(f"{side}/tcp").id
        self.tcp = np.zeros((len(plan), 3))
        self.ik_tcp = np.zeros((len(plan), 3))

    def command(self, data: Any, i: int) -> None:
        n = len(self.plan)
        k, ka = min(i, n - 1), min(i + LOOKAHEAD, n - 1)
        if i < n:
            q = self.ik.step(self.plan.position[ka], gripper_rotation(float(self.plan.yaw[ka])))
        else:
            q = self.ik.q
        data.ctrl[self.ctrl] = q
        data.ctrl[self.fingers] = float(np.clip(self.plan.opening[k], 0, self.max_opening)) / 2

    def record(self, data: Any, i: int) -> None:
        if i < len(self.plan):
            self.tcp[i] = data.site_xpos[self.site]
            self.ik_tcp[i] = self.ik.tcp_pose()[0]


# --- plan, run and judge -------------------------------------------------------------------------
@dataclass
class TwoArmReproduction:
    """What two arms did with a two-hand program."""

    mode: str
    bases: dict[str, np.ndarray]
    plans: dict[str, Plan]
    executions: dict[str, Execution]
    objects: list[Any]
    """:class:`~lfd.reproduce.measures.ObjectResult` of every object (the task's goals)."""
    skills: dict[str, list[Any]]
    """Each arm's :class:`~lfd.reproduce.outcome.SkillResult` list."""
    wall_time_s: float = 0.0
    owners: dict[str, str] = field(default_factory=dict)
    """The arm whose lane handles each object (last)."""
    collisions: list[Collision] = field(default_factory=list)
    """Each arm's first contact with the other arm and with the table."""
    programs: dict[str, TaskProgram] = field(default_factory=dict)
    """Each arm's executed program: its plan's ``segment`` indexes its segments."""

    @property
    def success(self) -> bool:
        """Every object at its goal, and neither arm touched the other or the table."""
        return all(o.success for o in self.objects) and not self.collisions

    def arm_success(self, side: str) -> bool:
        """The ``side`` arm did every skill of its lane and touched neither the other arm nor
        the table."""
        hit = any(side in (c.arm, c.other) for c in self.collisions)
        return not hit and all(r.ok for r in self.skills.get(side, []))

    @property
    def failures(self) -> list[str]:
        """One line per collision and per failed skill, naming the arm, then per object off
        its goal."""
        out = [c.describe() for c in self.collisions]
        out += [
            f"{side} arm: {r.label()}: {r.reason}"
            for side, rs in self.skills.items()
            for r in rs
            if not r.ok
        ]
        for o in self.objects:
            if not o.success:
                who = f" ({self.owners[o.name]} arm)" if o.name in self.owners else ""
                out.append(
                    f"task: {o.name}{who} {o.position_error * 1000:.0f} mm and "
                    f"{o.rotation_error_deg:.0f} deg from its goal"
                )
        return out

    @property
    def execution_time_s(self) -> float:
        return max(len(p) for p in self.plans.values()) * TICK


def _handled(program: TaskProgram) -> set[str]:
    return {s.object for s in program.segments if s.skill != "move" and s.object is not None}


@dataclass
class TwoArmPlan:
    """Both lanes of a two-hand program planned for a layout and put on one clock
    (:func:`plan_two_arms`), not yet run."""

    mode: str
    programs: dict[str, TaskProgram]
    bases: dict[str, np.ndarray]
    yaws: dict[str, float]
    planned: dict[str, tuple[Any, Any, Any]]
    """Each lane's (:class:`~lfd.reproduce.goals.DemoFrames`, initial poses,
    :class:`~lfd.reproduce.modes.PlanResult`)."""
    plans: dict[str, Plan]
    """Each arm's plan on the common clock."""
    specs: list[ObjectSpec]
    expected: dict[str, np.ndarray]
    owners: dict[str, str]

    @property
    def sides(self) -> list[str]:
        return list(self.programs)

    def others(self, side: str) -> set[str]:
        """The objects only the other arm handles (in ``side``'s lane they stay where they
        started: its planned scenes do not know where they are)."""
        return _others(self.programs, side)


def _others(programs: dict[str, TaskProgram], side: str) -> set[str]:
    theirs = set().union(*(_handled(programs[o]) for o in programs if o != side))
    return theirs - _handled(programs[side])


def _finish(
    hands: HandsProgram,
    mode: str,
    programs: dict[str, TaskProgram],
    bases: dict[str, np.ndarray],
    yaws: dict[str, float],
    planned: dict[str, tuple[Any, Any, Any]],
    plans: dict[str, Plan],
) -> TwoArmPlan:
    """Both lanes' plans on one clock (:func:`synchronise`), with the objects' scene and the
    goal of each object: the pose the lane that handles it last leaves it in."""
    sides = list(planned)
    frames, initial, _ = planned[sides[0]]
    owners: dict[str, str] = {}  # the lane that handles each object last
    for side, name, _ in sorted(
        ((s, g.object, g.end_s) for s in sides for g in programs[s].segments if g.skill != "move"),
        key=lambda x: x[2],
    ):
        if name is not None:
            owners[name] = side
    expected = {
        n: planned[owners[n]][2].expected[n] if n in owners else initial[n] for n in frames.names
    }
    specs = []
    for k, name in enumerate(frames.names):
        T = initial[name]
        yaw = float(np.arctan2(T[1, 0], T[0, 0]))
        p = T[:3, 3].copy()
        p[2] = max(p[2], frames.size[k, 2] / 2)
        specs.append(
            ObjectSpec(name, frames.size[k], p, np.array([0, 0, np.sin(yaw / 2), np.cos(yaw / 2)]))
        )
    plans = synchronise(plans, hands)
    return TwoArmPlan(mode, programs, bases, yaws, planned, plans, specs, expected, owners)


def prepare_two_arms(
    trajs: dict[str, Any], hands: HandsProgram, robot: TwoArmRobot
) -> tuple[HandsProgram, bool, dict[str, Any]]:
    """The program with its carries made two-armed
    (:func:`~lfd.reproduce.two_arm_sequence.prepare`), whether it has one, and the holds done
    by pressing (:func:`~lfd.reproduce.two_arm_press.press_holds`)."""
    from .two_arm_press import press_holds
    from .two_arm_sequence import has_carry, prepare

    t = trajs[next(iter(trajs))]
    sizes = dict(zip(t.object_names, np.asarray(t.object_size, dtype=np.float64), strict=True))
    hands = prepare(hands, sizes, robot)
    return hands, has_carry(hands), press_holds(hands, sizes, robot)


def _scene_points(
    planned: dict[str, tuple[Any, Any, Any]],
) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Each lane's planned TCP path and every object position of every planned scene: what
    :func:`choose_bases` places the bases for once the task is re-grounded."""
    scenes = [sc for _, ini, r in planned.values() for sc in [ini, *r.scenes]]
    objs = np.array([T[:3, 3] for sc in scenes for T in sc.values()])
    return {s: r.plan.position for s, (_, _, r) in planned.items()}, objs


def plan_two_arms(
    trajs: dict[str, Any],
    hands: HandsProgram,
    mode: str = "skills",
    *,
    robot: TwoArmRobot,
    displace: dict[str, Any] | None = None,
) -> TwoArmPlan:
    """Choose both bases, plan each lane for the arm of its side (the objects displaced by
    ``displace``, as :func:`~lfd.reproduce.displacement.plan_layout` does for one arm) and put
    both on one clock. With displaced objects the bases are chosen again for the planned,
    re-grounded paths and the lanes planned again from there (as one arm's base is). Where
    the arms still meet, a stacked box taken away from the other arm's press, the bases level
    with the work, or both (:func:`~.two_arm_apart.bases_apart`).

    Raises
    ------
    DemonstrationError
        A synchronisation the arms do not run (:func:`check_runs`), or a lane out of its arm's
        reach (:func:`choose_bases`), in one line.
    UsageError
        A displacement whose re-grounded task is impossible
        (:func:`~lfd.reproduce.displacement.check_goals`).
    """
    from .two_arm_apart import bases_apart
    from .two_arm_clearance import clearance_score

    def plan(level: float, away: bool, turn: bool) -> TwoArmPlan | None:
        return _plan_two_arms(trajs, hands, mode, robot, dict(displace or {}), level, away, turn)

    def score(p: TwoArmPlan) -> tuple[float, int, int]:
        def make_ik(side: str) -> MountedIK:
            return MountedIK(p.bases[side], p.yaws[side], robot.ik)

        return clearance_score(p.plans, scene_xml(p.bases, [], robot, p.yaws), make_ik, robot)

    return bases_apart(plan, score, robot.base_levels)


def _plan_two_arms(
    trajs: dict[str, Any],
    hands: HandsProgram,
    mode: str,
    robot: TwoArmRobot,
    displace: dict[str, Any],
    level: float,
    away: bool = False,
    turn: bool = False,
) -> TwoArmPlan | None:
    """:func:`plan_two_arms` with each base at most ``level`` (m) before or behind the work
    (:func:`~.two_arm_bases.choose_bases`); ``away``: a stack beside a press takes its object
    at the end away from the press (:func:`~.two_arm_clearance.stack_away`), and None is
    returned where no stack is beside a press (the plan would be the one without ``away``);
    ``turn``: a square box stacked there whose gripper cannot take it across the line to the
    press is stacked a quarter turn round, so that it closes across that line there
    (:func:`~lfd.reproduce.modes.plan_task`'s ``turn_to_across``), and None is returned
    where no box is so turned.

    Raises
    ------
    DemonstrationError
        A synchronisation the arms do not run (:func:`check_runs`), or a lane out of its arm's
        reach (:func:`choose_bases`), in one line.
    UsageError
        A displacement whose re-grounded task is impossible
        (:func:`~lfd.reproduce.displacement.check_goals`).
    """
    from .two_arm_clearance import stack_across, stack_away
    from .two_arm_handover import plan_handovers_apart
    from .two_arm_press import plan_press_lane

    hands, sequence, presses = prepare_two_arms(trajs, hands, robot)
    check_runs(hands)
    sides = [s for s in hands.sides if hands.lanes[s] and s in robot.arms]
    missing = [s for s in hands.sides if s not in robot.arms]
    if missing:
        raise DemonstrationError(f"the {missing[0]} hand has no arm on {robot.name}")
    programs = {s: hands.program(s) for s in sides}
    moved, points, bases = layout(trajs, hands, programs, robot, displace, sequence, level)
    work = _Work(trajs, hands, mode, robot, moved, displace, programs)

    def plan_lanes(
        bases: dict[str, np.ndarray],
        before: dict[str, tuple[Any, Any, Any]] | None = None,
        grasps: dict[str, dict[str, np.ndarray]] | None = None,
    ) -> dict[str, tuple[Any, Any, Any]]:
        out = {}
        for s in sides:
            others = _others(programs, s)
            if s in presses:
                lane = plan_press_lane(trajs[s], hands, presses[s], mode, bases[s], robot, moved)
                check_lane_goals(lane, displace, others, s)
                out[s] = lane
                continue
            try:
                events = lane_events(before, s, others) if before else []
                out[s] = plan_lane(
                    trajs[s],
                    programs[s],
                    mode,
                    moved,
                    bases[s],
                    robot.ik,
                    displace,
                    others,
                    events,
                    {**far.get(s, {}), **(grasps or {}).get(s, {})} or None,
                    turned.get(s),
                    slides.get(s),
                    s in far,
                    turn,
                )
            except UsageError as err:  # the arm named
                raise named_arm(err, s) from err
        return out

    if sequence:
        return _sequenced(work, bases, points, level)
    turned: dict[str, dict[str, int]] = {}  # grasps turned to keep two grippers apart
    far: dict[str, dict[str, np.ndarray]] = {}  # and taken away from the press (``away``)
    slides: dict[str, set[str]] = {}  # pushes done by grasping, likewise (two_arm_holds)

    def slid(p: Any) -> tuple[Any, Any, Any] | None:
        """The lane of the other arm of hold ``p`` with its push done by grasping."""
        slides[p.other] = {str(hands.lanes[p.other][p.other_step].object)}
        try:
            return plan_lanes(bases, planned)[p.other]
        except (UsageError, DemonstrationError):
            return None
        finally:
            del slides[p.other]

    planned = plan_lanes(bases)
    if len(sides) > 1:  # again, each lane knowing where the other arm moves its objects
        planned = plan_lanes(bases, planned)
    turned.update(stack_across(planned, presses))
    far.update(stack_away(planned, presses) if away else {})
    if away and not far:
        return None  # no stack beside a press: the plan without ``away``
    if turned:  # a stack beside a press: its grasp turned (the press' lane is the same)
        planned = plan_lanes(bases, planned)
    if turn and not any(r.turned for _, _, r in planned.values()):
        return None  # no box stacked turned: the plan without ``turn``
    if displace:
        bases, planned = _rebased(
            planned, bases, robot, level, lambda b: plan_lanes(b, plan_lanes(b))
        )
    yaws = {s: mount_yaw(bases[s], points[s]) for s in sides}
    planned, plans = plan_handovers_apart(planned, hands, mode, moved, bases, robot, plan_lanes)
    return _kept_clear(work, bases, yaws, planned, plans, slid)


class _Work(NamedTuple):
    """What every step of :func:`_plan_two_arms` plans from: the hands' trajectories and
    program, the mode, the robot, the objects where the layout puts them (``moved``), the
    displacement and each arm's program."""

    trajs: dict[str, Any]
    hands: HandsProgram
    mode: str
    robot: TwoArmRobot
    moved: dict[str, np.ndarray]
    displace: dict[str, Any]
    programs: dict[str, Any]


def _sequenced(
    work: _Work, bases: dict[str, np.ndarray], points: dict[str, np.ndarray], level: float
) -> TwoArmPlan:
    """:func:`_plan_two_arms` of a program the arms run as one sequence
    (:func:`~.two_arm_sequence.plan_sequence`), from ``bases`` or, displaced, from the bases
    chosen again for the re-grounded paths and every object pose."""
    from .two_arm_sequence import plan_sequence

    trajs, hands, mode, robot, moved, displace, programs = work

    def plan_units(bases: dict[str, np.ndarray]) -> dict[str, tuple[Any, Any, Any]]:
        out = plan_sequence(trajs, hands, mode, bases, robot, moved)
        for s in programs:
            check_lane_goals(out[s], displace, _others(programs, s), s)
        return out

    planned = plan_units(bases)
    if displace:
        bases, planned = _rebased(planned, bases, robot, level, plan_units)
    yaws = {s: mount_yaw(bases[s], points[s]) for s in programs}
    plans = {s: r.plan for s, (_, _, r) in planned.items()}
    return _finish(hands, mode, programs, bases, yaws, planned, plans)


def _rebased(
    planned: dict[str, tuple[Any, Any, Any]],
    bases: dict[str, np.ndarray],
    robot: TwoArmRobot,
    level: float,
    replan: Callable[[dict[str, np.ndarray]], dict[str, tuple[Any, Any, Any]]],
) -> tuple[dict[str, np.ndarray], dict[str, tuple[Any, Any, Any]]]:
    """The bases chosen again for the re-grounded paths and every planned object pose of
    ``planned`` (displaced objects; as one arm's base is), and the lanes planned again from
    them by ``replan`` where they moved; ``bases`` and ``planned`` where they did not."""
    new = choose_bases(*_scene_points(planned), robot, level=level)
    if all(np.linalg.norm(new[s] - bases[s]) <= 1e-9 for s in planned):
        return bases, planned
    return new, replan(new)


def _kept_clear(
    work: _Work,
    bases: dict[str, np.ndarray],
    yaws: dict[str, float],
    planned: dict[str, tuple[Any, Any, Any]],
    plans: dict[str, Plan],
    slid: Callable[[Any], tuple[Any, Any, Any] | None],
) -> TwoArmPlan:
    """The planned lanes on one clock with each hold kept clear of the other arm: pressed at
    the object's end away from it (:func:`~.two_arm_holds.press_if_clearer`), then
    re-ordered where the arms would still meet (:func:`_kept_apart`)."""
    from .two_arm_holds import press_if_clearer, press_lanes

    trajs, hands, mode, robot, moved, displace, programs = work
    others = {s: _others(programs, s) for s in programs}
    press = press_lanes(trajs, hands, mode, bases, robot, moved, displace, others)
    clearance = _clearance(bases, yaws, robot)
    planned, plans = press_if_clearer(planned, plans, hands, press, clearance, synchronise, slid)
    return _kept_apart(_finish(hands, mode, programs, bases, yaws, planned, plans), hands, robot)


def _kept_apart(plan: TwoArmPlan, hands: HandsProgram, robot: TwoArmRobot) -> TwoArmPlan:
    """``plan`` with its holds re-ordered where the arms would meet
    (:func:`~.two_arm_clearance.clear_holds`, on the arms alone)."""
    from .two_arm_clearance import clear_holds

    bases, yaws = plan.bases, plan.yaws
    xml = scene_xml(bases, [], robot, yaws)

    def make_ik(side: str) -> MountedIK:
        return MountedIK(bases[side], yaws[side], robot.ik)

    return replace(
        plan, plans=clear_holds(plan.plans, hands, xml, make_ik, robot, synchronise, bases)
    )


def _clearance(
    bases: dict[str, np.ndarray], yaws: dict[str, float], robot: TwoArmRobot
) -> Callable[[dict[str, Plan]], tuple[float, float]]:
    """:func:`~.two_arm_holds.arm_clearance` of plans on one clock, the arms at ``bases``."""
    from .two_arm_holds import arm_clearance

    def make_ik(side: str) -> MountedIK:
        return MountedIK(bases[side], yaws[side], robot.ik)

    def clearance(plans: dict[str, Plan]) -> tuple[float, float]:
        return arm_clearance(plans, scene_xml(bases, [], robot, yaws), make_ik, robot)

    return clearance


def reproduce_two_arms(
    trajs: dict[str, Any],
    hands: HandsProgram,
    mode: str = "skills",
    *,
    robot: TwoArmRobot | None = None,
    displace: dict[str, Any] | None = None,
) -> TwoArmReproduction:
    """Plan each hand's lane for the arm of its side, put both on one clock and run them in
    one scene (see the module docstring). ``trajs``: each hand's preprocessed trajectory
    (``lfd.preprocess(demo.one_hand(side), **PREPROCESSING)``); ``displace``: objects moved as
    ``lfd reproduce --displace`` moves them (``name -> (dx, dy[, turn_deg])``).

    Raises
    ------
    DemonstrationError, UsageError
        As :func:`plan_two_arms`, in one line.
    """
    from .aloha import aloha

    robot = robot or aloha()
    return run_two_arm_plan(
        plan_two_arms(trajs, hands, mode, robot=robot, displace=displace), robot
    )


def run_two_arm_plan(plan: TwoArmPlan, robot: TwoArmRobot) -> TwoArmReproduction:
    """Run both arms' plans in one scene and judge them, per arm and for the task."""
    from .measures import object_errors
    from .outcome import skill_results

    sides, programs, plans = plan.sides, plan.programs, plan.plans
    collisions: list[Collision] = []
    ex = execute_two(plans, plan.bases, plan.specs, robot, plan.yaws, collisions=collisions)
    any_ex = ex[sides[0]]
    frames = plan.planned[sides[0]][0]
    objs = object_errors(
        any_ex.object_names,
        any_ex.final_position,
        any_ex.final_quaternion,
        plan.expected,
        frames.size,
    )
    skills, executed = {}, {}
    for s in sides:
        others = set().union(*(_handled(programs[o]) for o in sides if o != s)) - _handled(
            programs[s]
        )
        keep = [j for j, n in enumerate(any_ex.object_names) if n not in others]
        e = ex[s]
        mine = Execution(
            tcp=e.tcp,
            planned_ik=e.planned_ik,
            object_names=[e.object_names[j] for j in keep],
            object_position=e.object_position[keep],
            object_quaternion=e.object_quaternion[keep],
            final_position=e.final_position[keep],
            final_quaternion=e.final_quaternion[keep],
        )
        executed[s] = plan.planned[s][2].program or programs[s]
        skills[s] = skill_results(executed[s], plans[s], mine, [objs[j] for j in keep])
    return TwoArmReproduction(
        plan.mode,
        plan.bases,
        plans,
        ex,
        objs,
        skills,
        wall_time_s=any_ex.wall_time_s,
        owners=plan.owners,
        collisions=collisions,
        programs=executed,
    )
