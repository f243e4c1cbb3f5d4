"""Run a task with the simulated demonstrator and record it like a real demonstration.

The plan (:mod:`lfd.sim.skills`) is simulated at ``10 x object_rate_hz`` (300 Hz by default):
finger drift and tremor are added, the hand's forward kinematics gives the 21 keypoints, and
the objects follow the hand (grasp), slide in front of it (push) or rest. The streams are then
sampled like the paper's sensors: object poses at every camera frame (30 Hz) with tag noise and
dropout bursts, hand keypoints at ~5 Hz on camera frames (the estimator takes every 5th-7th
frame) with keypoint noise and outliers. Ground truth (noise-free streams at 30 Hz) is returned
alongside.

The ``natural`` style (:class:`~lfd.sim.Variability`) swaps in the fast grasping skills of
:mod:`lfd.sim.natural`, draws the cube sizes (5-9 cm) per demonstration and records like motion
capture: keypoints on every frame (30 Hz by default), small noise, almost no dropouts.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from ..demo import CameraInfo, Demonstration, SkillLabel
from ..errors import DemonstrationError, UsageError
from . import natural as nat
from .hand import HandKinematics
from .motion import Plan, rotation
from .planner import Attach, Detach, ObjectPose, Planner, Push
from .results import BASE_TIME_NS, SIM_VERSION, SimResult, Truth, hand_motion, quat_wxyz
from .scene import DEFAULT_OBJECTS, ObjectSpec, build_scene
from .skills import (
    locate,
    locate_entry,
    move,
    move_with,
    pick_up,
    pick_up_entry,
    place,
    push,
    push_entry,
    rest_pose,
    stack,
)
from .tasks import BIMANUAL_TASKS, TEMPLATE_TASKS, Step, check_task, place_objects, task_steps
from .variability import Variability

_MAX_ATTEMPTS = 10


def _entry(P: Planner, step: Step, roles: dict[str, str], *, first: bool = False) -> Any:
    name = roles[step.role] if step.role else None
    if step.skill == "pick_up" and name:
        if P.var.style == "natural":
            return nat.pick_up_entry(P, name)
        return pick_up_entry(P, name, first=first)
    if step.skill == "push" and name:
        return push_entry(P, name)
    if step.skill == "locate" and name:
        return locate_entry(P, name)
    return rest_pose(P)


def _execute(P: Planner, steps: tuple[Step, ...], roles: dict[str, str]) -> None:
    P.hand = _entry(P, steps[0], roles, first=True)
    P.hold(float(P.rng.uniform(0.3, 0.8)))
    natural = P.var.style == "natural"
    for i, step in enumerate(steps):
        name = roles[step.role] if step.role else None
        if step.skill == "move":
            nxt = steps[i + 1] if i + 1 < len(steps) else None
            target = _entry(P, nxt, roles) if nxt else rest_pose(P)
            if natural:
                reach = nxt is not None and nxt.skill == "pick_up"
                nat.move(P, target, name, reach=reach, leave=step.leave)
            else:
                move(P, target, name)
        elif step.skill == "pick_up":
            if natural:  # a re-grasp (place, move, pick up of one object) does not turn it
                before = [(s.skill, s.role) for s in steps[max(0, i - 2) : i]]
                again = len(before) == 2 and before[0][0] in ("place", "stack")
                again = again and before == [(before[0][0], step.role), ("move", step.role)]
                nat.pick_up(P, str(name), turn=not again)
            else:
                pick_up(P, str(name))
        elif step.skill == "move_with":
            onto = roles[step.onto] if step.onto else None
            if natural:
                nat.move_with(
                    P, str(name), onto, repeat=step.repeat, quick=step.quick, turn=step.turn
                )
            else:
                move_with(P, str(name), onto)
        elif natural and step.skill in ("place", "stack"):
            # the hand lingers when the next skills re-grasp the same object
            regrasp = [(s.skill, s.role, s.leave) for s in steps[i + 1 : i + 3]]
            linger = regrasp == [("move", step.role, ""), ("pick_up", step.role, "")]
            nat.put_down(P, str(name), step.skill, linger=linger)
        elif step.skill == "place":
            place(P, str(name))
        elif step.skill == "stack":
            stack(P, str(name))
        elif step.skill == "push":
            push(P, str(name))
        elif step.skill == "locate":
            locate(P, str(name))
    P.hold(float(P.rng.uniform(0.3, 0.8)))
    last = P.labels[-1]
    P.labels[-1] = type(last)(last.skill, last.t0, P.t, last.object)


def _objects_motion(
    P: Planner, initial: dict[str, ObjectPose], t: np.ndarray, tcp: np.ndarray, yaw_h: np.ndarray
) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Object centre (n, 3) and yaw (n,) on the fine grid from the grasp/push events."""
    positions, yaws = {}, {}
    for name, pose0 in initial.items():
        pos = np.empty((t.size, 3))
        yaw = np.empty(t.size)
        cur = pose0.copy()
        i_cur = 0
        events = [e for e in P.events if e.name == name]
        k = 0
        while k < len(events):
            ev = events[k]
            if isinstance(ev, Attach):
                det = events[k + 1] if k + 1 < len(events) else None
                assert det is None or isinstance(det, Detach)
                ia = int(np.searchsorted(t, ev.t))
                idt = int(np.searchsorted(t, det.t)) if det else t.size
                pos[i_cur:ia], yaw[i_cur:ia] = cur.pos, cur.yaw
                c, s = np.cos(-yaw_h[ia]), np.sin(-yaw_h[ia])
                d = cur.pos - tcp[ia]
                rel = np.array([c * d[0] - s * d[1], s * d[0] + c * d[1], d[2]])
                rel_yaw = cur.yaw - yaw_h[ia]
                R = rotation(yaw_h[ia:idt], np.zeros(idt - ia), np.zeros(idt - ia))
                pos[ia:idt] = tcp[ia:idt] + R @ rel
                yaw[ia:idt] = yaw_h[ia:idt] + rel_yaw
                if det is None:
                    positions[name], yaws[name] = pos, yaw
                    break
                last = pos[idt - 1] if idt > ia else cur.pos
                cur = ObjectPose(np.array([last[0], last[1], det.pose.pos[2]]), det.pose.yaw)
                i_cur = idt
                k += 2
            elif isinstance(ev, Push):
                i0, i1 = np.searchsorted(t, [ev.t0, ev.t1])
                pos[i_cur:i0], yaw[i_cur:i0] = cur.pos, cur.yaw
                disp = np.maximum.accumulate(
                    np.maximum(0.0, (tcp[i0:i1] - ev.contact) @ ev.direction)
                )
                pos[i0:i1] = cur.pos + np.outer(disp, ev.direction)
                yaw[i0:i1] = cur.yaw
                cur = ObjectPose(cur.pos + ev.direction * (disp[-1] if disp.size else 0.0), cur.yaw)
                i_cur = int(i1)
                k += 1
            else:  # a Detach without Attach cannot be planned
                raise RuntimeError(f"unexpected event {ev}")
        else:
            pos[i_cur:], yaw[i_cur:] = cur.pos, cur.yaw
            positions[name], yaws[name] = pos, yaw
    return positions, yaws


NATURAL_CUBE_SIZES = (0.05, 0.09)
"""Range of the cube sides (m) the natural style draws per demonstration."""


def natural_objects(rng: np.random.Generator) -> tuple[ObjectSpec, ...]:
    """:data:`DEFAULT_OBJECTS` as cubes with sides drawn from :data:`NATURAL_CUBE_SIZES`."""
    return tuple(
        replace(o, size=(side, side, side))
        for o, side in zip(
            DEFAULT_OBJECTS, rng.uniform(*NATURAL_CUBE_SIZES, len(DEFAULT_OBJECTS)), strict=True
        )
    )


def simulate(
    task: str,
    seed: int = 0,
    variability: Variability | None = None,
    *,
    objects: tuple[ObjectSpec, ...] | None = None,
    hand_rate_hz: float | None = None,
    object_rate_hz: float = 30.0,
) -> SimResult:
    """Simulate one demonstration of ``task`` (see :data:`lfd.sim.tasks.TASKS`).

    Parameters
    ----------
    task : str
        Task name (``exp1`` ... ``exp6`` or a skill name for its template task).
    seed : int
        Seed of ``numpy.random.default_rng``; the same seed gives identical output.
    variability : Variability, optional
        Human variability and sensor imperfection (defaults: :class:`Variability`, the careful
        style); its ``style`` selects the demonstrator.
    objects : tuple of ObjectSpec, optional
        The boxes (default :data:`DEFAULT_OBJECTS`; for the natural style, cubes of 5-9 cm drawn
        per demonstration by :func:`natural_objects`).
    hand_rate_hz, object_rate_hz : float
        Hand-pose estimator rate (keypoints; default 5 Hz, 30 Hz for the natural style) and
        camera / tag tracking rate (object poses).
    """
    from .sampling import sample_streams

    check_task(task)
    style = (variability or Variability()).style
    if hand_rate_hz is None:
        hand_rate_hz = 30.0 if style == "natural" else 5.0
    if not 0.5 <= hand_rate_hz <= object_rate_hz <= 120:
        raise UsageError(
            f"need 0.5 <= hand rate <= object (camera) rate <= 120 Hz, got hand rate "
            f"{hand_rate_hz} Hz and object rate {object_rate_hz} Hz"
        )
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise UsageError(f"seed must be an integer >= 0, got {seed!r}")
    if task in BIMANUAL_TASKS:
        from .bimanual import simulate_two_hands

        return simulate_two_hands(
            task, seed, variability, hand_rate_hz=hand_rate_hz, object_rate_hz=object_rate_hz
        )
    rng = np.random.default_rng(seed)
    var = (variability or Variability()).resolve(rng)
    steps = task_steps(task, rng)
    if objects is None:
        objects = natural_objects(rng) if style == "natural" else DEFAULT_OBJECTS
    scene = build_scene(objects, hand_scale=float(var.hand_scale or 1.0))
    kin = HandKinematics(scene.compile())
    P, roles, initial = _perform(rng, var, kin, objects, steps)
    plan = Plan(P.segments)
    truth = _motion(rng, var, kin, P, plan, initial, object_rate_hz)
    hand, tracks = sample_streams(rng, truth, scene, var, hand_rate_hz, object_rate_hz)
    end_ns = int(truth.t_ns[-1])
    labels = []
    for lab in P.labels:
        start = BASE_TIME_NS + round(lab.t0 * 1e9)
        stop = min(BASE_TIME_NS + round(lab.t1 * 1e9), end_ns)
        labels.append(SkillLabel(lab.skill, start, stop, lab.object))
    cam = scene.camera
    camera = CameraInfo(cam.width, cam.height, cam.intrinsics(), cam.world_T_camera())
    metadata = _metadata(task, int(seed), var, P, roles, initial, hand_rate_hz, object_rate_hz)
    demo = Demonstration(hand=hand, objects=tracks, labels=labels, camera=camera, metadata=metadata)
    return SimResult(demo=demo, truth=truth, scene=scene, plan=plan, variability=var)


def _perform(
    rng: np.random.Generator,
    var: Any,
    kin: HandKinematics,
    objects: tuple[ObjectSpec, ...],
    steps: tuple[Step, ...],
) -> tuple[Planner, dict[str, str], dict[str, ObjectPose]]:
    """Plan the demonstration's steps on a random layout: the planner (segments, labels, log),
    the roles (A, B, C -> object names) and the objects' initial poses."""
    names = [o.name for o in objects]
    for attempt in range(_MAX_ATTEMPTS):
        # a layout in which a step is impossible (no free spot, no room to push) is re-drawn
        # from the same random stream, so the result stays a function of the seed
        order = rng.permutation(len(names))
        roles = {role: names[int(i)] for role, i in zip("ABC", order, strict=False)}
        initial = {n: ObjectPose(p, y) for n, (p, y) in place_objects(rng, objects).items()}
        P = Planner(
            rng, var, kin, {o.name: o for o in objects}, {n: p.copy() for n, p in initial.items()}
        )
        try:
            _execute(P, steps, roles)
            break
        except DemonstrationError:
            if attempt == _MAX_ATTEMPTS - 1:
                raise
    return P, roles, initial


def _motion(
    rng: np.random.Generator,
    var: Any,
    kin: HandKinematics,
    P: Planner,
    plan: Plan,
    initial: dict[str, ObjectPose],
    object_rate_hz: float,
) -> Truth:
    """The hand's and objects' true motion at the camera frames: the plan on a fine grid with
    finger drift and tremor, the keypoints, the objects moved by the hand."""
    # fine simulation grid: camera frames are every `sub`-th step
    sub = 10
    n_frames = int(np.floor(plan.duration * object_rate_hz + 1e-9)) + 1
    t = np.arange((n_frames - 1) * sub + 1) / (object_rate_hz * sub)
    m = hand_motion(rng, var, kin, P, plan, t)
    tcp, R, q, keypoints, wrist = m["tcp"], m["R"], m["q"], m["keypoints"], m["wrist"]
    obj_pos, obj_yaw = _objects_motion(P, initial, t, tcp, m["yaw"])

    frames = np.arange(n_frames) * sub
    t_ns = BASE_TIME_NS + np.round(np.arange(n_frames) * (1e9 / object_rate_hz)).astype(np.int64)
    return Truth(
        t_ns=t_ns,
        tcp=tcp[frames],
        keypoints=keypoints[frames],
        wrist_pos=wrist[frames],
        wrist_quat=quat_wxyz(R[frames]),
        q=q[frames],
        object_pos={n: p[frames] for n, p in obj_pos.items()},
        object_yaw={n: y[frames] for n, y in obj_yaw.items()},
    )


def _metadata(
    task: str,
    seed: int,
    var: Any,
    P: Planner,
    roles: dict[str, str],
    initial: dict[str, ObjectPose],
    hand_rate_hz: float,
    object_rate_hz: float,
) -> dict[str, Any]:
    """The simulated demonstration's metadata: task, seed, variability, layout, what was done."""
    metadata: dict[str, Any] = {
        "task": task,
        "seed": seed,
        "source": "simulation",
        "simulator": "lfd.sim",
        "simulator_version": SIM_VERSION,
        "variability": var.as_dict(),
        "roles": roles,
        "hand_rate_hz": hand_rate_hz,
        "object_rate_hz": object_rate_hz,
        "initial_objects": {
            n: {"position": p.pos.round(6).tolist(), "yaw": round(p.yaw, 6)}
            for n, p in initial.items()
        },
        "skill_sequence": [lab.skill for lab in P.labels],
        "style": var.style,
        "grasps": [g for g in P.grasps if not g.get("table_turn")],
        "pushes": [e for e in P.log if "push" in e],
        "stacks": [e for e in P.log if "stack" in e],
    }
    if var.style == "natural":
        metadata["table_turns"] = [e for e in P.log if "table_turn" in e]
        metadata["hovers"] = [e for e in P.log if "hover" in e]
    if task in TEMPLATE_TASKS:
        metadata["target_skill"] = task
    return metadata


def crop(result: SimResult, seconds: float) -> SimResult:
    """Keep only the first ``seconds`` of a simulated demonstration (streams, labels, truth).

    Raises :class:`~lfd.errors.UsageError` unless ``seconds`` is a finite number > 0, at most
    :data:`lfd.inputs.MAX_DURATION_S`, that keeps at least two hand samples.
    """
    from ..inputs import check_duration

    seconds = check_duration(seconds)
    demo, truth = result.demo, result.truth
    end = int(truth.t_ns[0] + round(seconds * 1e9))
    if np.count_nonzero(demo.hand.t_ns <= end) < 2:
        raise UsageError(
            f"a duration of {seconds} s keeps fewer than two hand samples; give a longer one"
        )
    keep = truth.t_ns <= end
    for which in ("hand", "other_hand"):
        hand = getattr(demo, which)
        if hand is None:
            continue
        h = hand.t_ns <= end
        setattr(
            demo,
            which,
            type(hand)(
                hand.t_ns[h], hand.keypoints[h], hand.confidence[h], hand.side, hand.visible[h]
            ),
        )
    for name, tr in list(demo.objects.items()):
        k = tr.t_ns <= end
        demo.objects[name] = type(tr)(
            tr.name, tr.tag_id, tr.size, tr.t_ns[k], tr.position[k], tr.quaternion[k], tr.visible[k]
        )
    last = int(truth.t_ns[keep][-1])
    demo.labels = [
        SkillLabel(lab.skill, lab.start_ns, min(lab.end_ns, last), lab.object, hand=lab.hand)
        for lab in demo.labels
        if lab.start_ns < last
    ]
    demo.handovers = [
        replace(h, end_ns=min(h.end_ns, last)) for h in demo.handovers if h.start_ns < last
    ]
    demo.metadata["cropped_s"] = seconds
    if demo.other_hand is None:
        demo.metadata["skill_sequence"] = [lab.skill for lab in demo.labels]
    else:
        demo.metadata["skill_sequences"] = {
            s: [x.skill for x in demo.labels_of(s)] for s in demo.sides
        }
    result.truth = Truth(
        t_ns=truth.t_ns[keep],
        tcp=truth.tcp[keep],
        keypoints=truth.keypoints[keep],
        wrist_pos=truth.wrist_pos[keep],
        wrist_quat=truth.wrist_quat[keep],
        q=truth.q[keep],
        object_pos={n: p[keep] for n, p in truth.object_pos.items()},
        object_yaw={n: y[keep] for n, y in truth.object_yaw.items()},
        other=None if truth.other is None else _cropped(truth.other, keep),
    )
    return result


def _cropped(truth: Truth, keep: np.ndarray) -> Truth:
    """A hand's truth at the frames ``keep``."""
    return Truth(
        t_ns=truth.t_ns[keep],
        tcp=truth.tcp[keep],
        keypoints=truth.keypoints[keep],
        wrist_pos=truth.wrist_pos[keep],
        wrist_quat=truth.wrist_quat[keep],
        q=truth.q[keep],
        object_pos={n: p[keep] for n, p in truth.object_pos.items()},
        object_yaw={n: y[keep] for n, y in truth.object_yaw.items()},
    )


def truth_demonstration(
    result: SimResult, hand_t_ns: np.ndarray | None = None, other_t_ns: np.ndarray | None = None
) -> Demonstration:
    """The demonstration a perfect observer would record: noise-free hand keypoints and object
    poses from the simulator's ground truth, with the labels, handovers, camera and metadata of
    ``result``.

    ``hand_t_ns`` picks the hand sample times (default: those of the simulated hand stream), so
    a perceived recording can be compared with the truth at its own estimator times; objects
    are sampled at every camera frame. ``other_t_ns`` does the same for the left hand of a
    two-hand demonstration. This is what "segmenting the true keypoints" means.
    """
    from ..demo import HandTrack, ObjectTrack
    from .sampling import yaw_quat

    truth, demo = result.truth, result.demo

    def track(keypoints: np.ndarray, times: np.ndarray | None, sampled: HandTrack) -> HandTrack:
        t = sampled.t_ns if times is None else np.asarray(times, np.int64)
        idx = np.searchsorted(truth.t_ns, t)
        if idx.size == 0 or idx.max() >= truth.t_ns.size or np.any(truth.t_ns[idx] != t):
            raise DemonstrationError("hand_t_ns must be camera frame times of the simulation")
        return HandTrack(t, keypoints[idx].copy(), np.ones((t.size, 21)), sampled.side)

    hand = track(truth.keypoints, hand_t_ns, demo.hand)
    other = None
    if truth.other is not None and demo.other_hand is not None:
        other = track(truth.other.keypoints, other_t_ns, demo.other_hand)
    objects = {}
    for spec in result.scene.objects:
        yaw = truth.object_yaw[spec.name]
        quat = yaw_quat(yaw)
        objects[spec.name] = ObjectTrack(
            name=spec.name,
            tag_id=spec.tag_id,
            size=np.array(spec.size),
            t_ns=truth.t_ns.copy(),
            position=truth.object_pos[spec.name].copy(),
            quaternion=quat,
            visible=np.ones(yaw.size, dtype=bool),
        )
    return Demonstration(
        hand=hand,
        other_hand=other,
        objects=objects,
        labels=list(demo.labels),
        camera=demo.camera,
        metadata={**demo.metadata, "source": "simulation ground truth"},
        handovers=list(demo.handovers),
    )
