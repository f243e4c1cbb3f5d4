"""One robot run made ready for a LeRobot dataset: the simulation sampled at the dataset's rate.

:func:`robot_episode` (one arm: a :class:`~lfd.reproduce.Reproduction`) and
:func:`two_arm_episode` (two: a :class:`~lfd.reproduce.two_arms.TwoArmReproduction`) read the
run's :class:`~lfd.reproduce.controller.Execution` (``qpos`` at the start of every 10 ms control
tick, the commanded set points ``ctrl`` and the scene's MJCF) and :func:`episode_of` samples
every ``100 / fps``-th tick: the frame's observation is the simulation's state at the start of
that tick, its action the command given at that tick (what the servos were told to reach), its
subtask the task-program segment the tick belongs to (a dwell tick, the gripper closing or
opening, the segment's before it: :func:`held`), its image rendered from ``qpos`` by a camera
fixed for the whole dataset (:class:`Camera`). The columns (docs/export.md):

``observation.state``             (d,)   float32  each arm's joint positions (rad), gripper opening (m)
``action``                        (d,)   float32  the commanded joint positions, gripper opening
``observation.environment_state`` (7k,)  float32  per object: x, y, z (m), quaternion x, y, z, w
``observation.images.<camera>``   video           the rendered scene
``skill_index``, ``object_index``, ``subtask_index`` (1,) int64  as the human export's (one arm)
``skill_index.<side>``, ``object_index.<side>``, ``subtask_index.<side>``, ``subtask_index``
                                  (1,) int64  two arms: each arm's, and both arms' subtask

An arm's joints are its actuated hinge joints in the scene, its gripper its actuated slide
joints (the fingers): the opening is their sum, as the command is. Two arms: the left arm's
columns first, named as ALOHA's (``left_waist`` ... ``left_gripper``, ``right_waist`` ...).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, BinaryIO

import numpy as np

from .. import _gl  # noqa: F401  (selects the headless GL backend before mujoco loads)
from ..errors import UsageError
from ..skills import SKILLS
from .episode import NO_SKILL, segment_annotation, subtask_name

if TYPE_CHECKING:
    from ..reproduce import Reproduction
    from ..reproduce.two_arms import TwoArmReproduction

TICK_HZ = 100
"""Control ticks per second of the simulation (``lfd.reproduce.controller.TICK``)."""
ENV_KEY = "observation.environment_state"
IMAGE_PREFIX = "observation.images."
SUBTASK_KEY = "subtask_index"


@dataclass(frozen=True)
class Camera:
    """The dataset's camera: fixed in the demonstration's frame, looking at ``lookat`` (the
    centre of the demonstration's objects at the start) from ``distance`` m, ``azimuth`` and
    ``elevation`` deg (MuJoCo's free camera); one per dataset, whatever the layout."""

    name: str
    lookat: tuple[float, float, float]
    width: int
    height: int
    distance: float = 1.1
    azimuth: float = -90.0
    elevation: float = -55.0


def check_fps(fps: int) -> int:
    """``fps`` as a frame rate of robot data: a whole divisor of the 100 Hz control ticks."""
    if isinstance(fps, bool) or not isinstance(fps, int) or fps < 1 or TICK_HZ % fps:
        raise UsageError(f"--fps {fps}: must divide {TICK_HZ} (e.g. 5, 10, 20, 25)")
    return fps


def check_image_size(width: int, height: int) -> tuple[int, int]:
    """An image size from 16 to 1280 x 960 pixels (the scene's offscreen buffer)."""
    if not (16 <= width <= 1280 and 16 <= height <= 960):
        raise UsageError(f"--image-size {width}x{height}: must be 16x16 to 1280x960 pixels")
    return width, height


@dataclass
class RobotEpisode:
    """One successful robot run at the dataset's rate (``n`` frames).

    ``state``, ``action`` (n, d), ``environment`` (n, 7k) float32; ``images`` (n, H, W, 3)
    uint8; ``labels`` the skill and object columns, (n,) int64 each (-1: none):
    ``skill_index``, ``object_index`` of one arm, ``skill_index.<side>``,
    ``object_index.<side>`` of two; ``subtasks`` the subtask columns' frame names
    (``subtask_index``; of two arms also ``subtask_index.<side>``, ``subtask_index`` naming
    both: ``"right: pick_up bar | left: move"``); ``segment`` (n,) int64 numbers the runs of
    the same subtask (the episode's annotation); ``joint_names`` the state's columns;
    ``ticks`` (n,) the control tick of every frame."""

    fps: int
    task: str
    joint_names: list[str]
    object_names: list[str]
    state: np.ndarray
    action: np.ndarray
    environment: np.ndarray
    images: np.ndarray
    labels: dict[str, np.ndarray]
    subtasks: dict[str, list[str]]
    segment: np.ndarray
    ticks: np.ndarray

    def __len__(self) -> int:
        return int(self.state.shape[0])

    @property
    def subtask(self) -> list[str]:
        """Every frame's subtask (``subtask_index``'s names)."""
        return self.subtasks[SUBTASK_KEY]

    @property
    def scalar_keys(self) -> list[str]:
        """The one-value columns: ``labels``' and ``subtasks``'."""
        return [*self.labels, *self.subtasks]

    def annotation(self) -> dict[str, list[Any]]:
        """Lerobot's per-episode subtask annotation (:func:`~.episode.segment_annotation`)."""
        return segment_annotation(self.segment, self.subtask, self.fps)

    def features(self, camera: str) -> dict[str, dict[str, Any]]:
        """The lerobot feature specification of these columns."""
        pose = ("x", "y", "z", "qx", "qy", "qz", "qw")
        d = len(self.joint_names)
        h, w = self.images.shape[1:3]
        feats: dict[str, dict[str, Any]] = {
            "observation.state": {"dtype": "float32", "shape": (d,), "names": self.joint_names},
            "action": {"dtype": "float32", "shape": (d,), "names": self.joint_names},
            ENV_KEY: {
                "dtype": "float32",
                "shape": (7 * len(self.object_names),),
                "names": [f"{o}.{c}" for o in self.object_names for c in pose],
            },
            IMAGE_PREFIX + camera: {
                "dtype": "video",
                "shape": (h, w, 3),
                "names": ["height", "width", "channels"],
            },
        }
        for key in self.scalar_keys:
            feats[key] = {"dtype": "int64", "shape": (1,), "names": None}
        return feats

    def save(self, path: Path | BinaryIO) -> None:
        """Write to ``path`` (``.npz``, no pickles)."""
        arrays: dict[str, np.ndarray] = {k: getattr(self, k) for k in _ARRAYS}
        arrays |= {_LABEL + k: v for k, v in self.labels.items()}
        arrays |= {_SUBTASK + k: np.array(v, dtype=str) for k, v in self.subtasks.items()}
        arrays["joint_names"] = np.array(self.joint_names, dtype=str)
        arrays["object_names"] = np.array(self.object_names, dtype=str)
        arrays["fps_task"] = np.array([str(self.fps), self.task], dtype=str)
        np.savez(path, **arrays)  # type: ignore[arg-type]

    @staticmethod
    def problem(path: Path) -> str | None:
        """What makes ``path`` unreadable as an episode :meth:`save` wrote (None: nothing
        found). Cheap: the archive is opened and its array names checked, no array is read."""
        import zipfile

        try:
            with zipfile.ZipFile(path) as z:  # what np.savez writes: one NAME.npy per array
                names = {n.removesuffix(".npy") for n in z.namelist()}
        except (OSError, EOFError, zipfile.BadZipFile) as err:
            return f"not a readable episode ({err})"
        needed = (*_ARRAYS, "joint_names", "object_names", "fps_task")
        missing = [k for k in needed if k not in names]
        if missing:
            return f"not an episode: no {', '.join(missing)}"
        return None

    @classmethod
    def load(cls, path: Path) -> RobotEpisode:
        """What :meth:`save` wrote."""
        with np.load(path, allow_pickle=False) as z:
            fps, task = (str(v) for v in z["fps_task"])
            return cls(
                fps=int(fps),
                task=task,
                joint_names=[str(v) for v in z["joint_names"]],
                object_names=[str(v) for v in z["object_names"]],
                labels={k[len(_LABEL) :]: z[k] for k in z.files if k.startswith(_LABEL)},
                subtasks={
                    k[len(_SUBTASK) :]: [str(v) for v in z[k]]
                    for k in z.files
                    if k.startswith(_SUBTASK)
                },
                **{k: z[k] for k in _ARRAYS},
            )


_ARRAYS = ("state", "action", "environment", "images", "segment", "ticks")
_LABEL, _SUBTASK = "label:", "subtask:"


@dataclass
class ArmTicks:
    """One arm of a run, as an episode reads it: its joints in the scene (the actuated hinges,
    the fingers' slides), its column names, its plan's segment per tick and the segments
    of the program that plan runs. ``side``: ``""`` for one arm, else ``left`` or ``right``."""

    side: str
    joints: list[int]
    fingers: list[int]
    names: list[str]
    segment: np.ndarray
    segments: list[Any]


def robot_episode(run: Reproduction, *, fps: int, camera: Camera, task: str) -> RobotEpisode:
    """The frames of a one-arm reproduction at ``fps`` (:func:`check_fps`), rendered by
    ``camera``."""
    import mujoco

    ex, program = run.execution, run.program
    if ex is None or ex.qpos is None or ex.ctrl is None or program is None:
        raise ValueError("a reproduction without its execution's qpos, ctrl and program")
    model = mujoco.MjModel.from_xml_string(ex.scene)
    arm, grip = _actuated(model)
    names = [*(model.joint(j).name for j in arm), "gripper.opening"]
    one = ArmTicks("", arm, grip, names, np.asarray(run.segment), list(program.segments))
    return episode_of(model, ex, [one], fps=fps, camera=camera, task=task)


def two_arm_episode(
    run: TwoArmReproduction, *, fps: int, camera: Camera, task: str
) -> RobotEpisode:
    """The frames of a two-arm reproduction at ``fps``: both arms' joints in one state and one
    action, the left arm's first, as ALOHA names them (``left_waist`` ...
    ``left_wrist_rotate``, ``left_gripper``, then the right's); each arm's skill columns
    (``skill_index.<side>``, ...) and both arms' subtask. An arm whose plan has ended holds its
    last pose, its last segment."""
    import mujoco

    ex = run.executions[next(iter(run.executions))]
    if ex.qpos is None or ex.ctrl is None or not run.programs:
        raise ValueError("a reproduction without its execution's qpos, ctrl and programs")
    model = mujoco.MjModel.from_xml_string(ex.scene)
    arm, grip = _actuated(model)
    n = ex.qpos.shape[0]
    arms = []
    for side in sorted(run.plans):  # left, right (ALOHA's order)
        mine = [j for j in arm if model.joint(j).name.startswith(side + "/")]
        fingers = [j for j in grip if model.joint(j).name.startswith(side + "/")]
        names = [model.joint(j).name.replace("/", "_", 1) for j in mine] + [f"{side}_gripper"]
        seg = np.full(n, -1, dtype=np.int64)
        plan_seg = np.asarray(run.plans[side].segment)[:n]
        seg[: len(plan_seg)] = plan_seg
        arms.append(ArmTicks(side, mine, fingers, names, seg, list(run.programs[side].segments)))
    return episode_of(model, ex, arms, fps=fps, camera=camera, task=task)


def episode_of(
    model: Any, ex: Any, arms: list[ArmTicks], *, fps: int, camera: Camera, task: str
) -> RobotEpisode:
    """The episode of an execution (its ``qpos``, ``ctrl`` per tick in ``model``'s scene)
    with ``arms``: every ``100 / fps``-th tick, each arm's joints and opening, every object's
    pose, each arm's skill, the image."""
    ticks = np.arange(0, ex.qpos.shape[0], TICK_HZ // check_fps(fps))
    qadr = model.jnt_qposadr
    qpos, ctrl = ex.qpos[ticks], ex.ctrl[ticks]
    state, action = [], []
    for a in arms:
        state += [qpos[:, qadr[a.joints]], qpos[:, qadr[a.fingers]].sum(1, keepdims=True)]
        act = [_actuator(model, j) for j in a.joints]
        fingers = [_actuator(model, j) for j in a.fingers]
        action += [ctrl[:, act], ctrl[:, fingers].sum(1, keepdims=True)]
    env = []
    for name in ex.object_names:
        a0 = int(qadr[model.joint(name).id])  # the object's free joint: x y z, qw qx qy qz
        q = qpos[:, a0 : a0 + 7]
        env.append(np.concatenate([q[:, :3], q[:, 4:7], q[:, 3:4]], 1))
    objects = list(ex.object_names)
    labels: dict[str, np.ndarray] = {}
    subtasks: dict[str, list[str]] = {}
    per_arm = []
    for a in arms:
        seg = held(a.segment)[ticks].astype(np.int64)
        per_arm.append(seg)
        segs, dot = a.segments, f".{a.side}" if a.side else ""
        labels["skill_index" + dot] = np.array(
            [SKILLS.index(segs[s].skill) if s >= 0 else -1 for s in seg], dtype=np.int64
        )
        labels["object_index" + dot] = np.array(
            [
                objects.index(segs[s].object) if s >= 0 and segs[s].object in objects else -1
                for s in seg
            ],
            dtype=np.int64,
        )
        subtasks[SUBTASK_KEY + dot] = [
            subtask_name(segs[s].skill, segs[s].object) if s >= 0 else NO_SKILL for s in seg
        ]
    if len(arms) > 1:  # both arms' subtasks in one: the right's first, as a lane's lines
        sides = sorted((a.side for a in arms), key=lambda s: s != "right")
        subtasks[SUBTASK_KEY] = [
            " | ".join(f"{s}: {subtasks[f'{SUBTASK_KEY}.{s}'][i]}" for s in sides)
            for i in range(len(ticks))
        ]
    return RobotEpisode(
        fps=fps,
        task=task,
        joint_names=[n for a in arms for n in a.names],
        object_names=objects,
        state=np.concatenate(state, 1).astype(np.float32),
        action=np.concatenate(action, 1).astype(np.float32),
        environment=np.concatenate(env, 1).astype(np.float32),
        images=render(model, qpos, camera),
        labels=labels,
        subtasks=subtasks,
        segment=_runs(np.stack(per_arm, 1)),
        ticks=ticks.astype(np.int64),
    )


def _actuator(model: Any, joint: int) -> int:
    """The actuator of ``joint`` (its position servo)."""
    return int(np.flatnonzero(model.actuator_trnid[:, 0] == joint)[0])


def _runs(segments: np.ndarray) -> np.ndarray:
    """(n,) the number of each frame's run of the same segments (n, arms) in time order, -1
    where no arm is in a segment (one arm: a new number at every change of segment)."""
    n = segments.shape[0]
    change = np.ones(n, dtype=bool)
    change[1:] = (segments[1:] != segments[:-1]).any(axis=1)
    out = np.cumsum(change) - 1
    return np.where((segments < 0).all(axis=1), -1, out).astype(np.int64)


def held(segment: np.ndarray) -> np.ndarray:
    """``segment`` (the plan's segment per tick) with every dwell tick (-1: the gripper
    closing after a grasp, opening after a release) given the segment before it (the first
    segment's to the ticks before it): every frame of a run is in a skill."""
    out = np.asarray(segment, dtype=np.int64).copy()
    ok = np.flatnonzero(out >= 0)
    if not len(ok):
        return out
    last = np.maximum.accumulate(np.where(out >= 0, np.arange(len(out)), -1))
    out = np.where(last >= 0, out[np.maximum(last, 0)], out[ok[0]])
    return out


def _actuated(model: Any) -> tuple[list[int], list[int]]:
    """The actuated joints: hinges (the arm) and slides (the gripper's fingers), in actuator
    order."""
    import mujoco

    joints = [int(j) for j in model.actuator_trnid[:, 0]]
    arm = [j for j in joints if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE]
    grip = [j for j in joints if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_SLIDE]
    return arm, grip


def render(model: Any, qpos: np.ndarray, camera: Camera) -> np.ndarray:
    """The scene at each row of ``qpos`` as seen by ``camera``: (n, H, W, 3) uint8 (no
    shadows or reflections: a small image renders in ~2 ms)."""
    import mujoco

    data = mujoco.MjData(model)
    cam = mujoco.MjvCamera()
    cam.lookat[:] = camera.lookat
    cam.distance, cam.azimuth, cam.elevation = camera.distance, camera.azimuth, camera.elevation
    out = np.zeros((qpos.shape[0], camera.height, camera.width, 3), dtype=np.uint8)
    renderer = mujoco.Renderer(model, camera.height, camera.width)
    try:
        for i, q in enumerate(qpos):
            data.qpos[:] = q
            mujoco.mj_forward(model, data)
            renderer.update_scene(data, cam)
            renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = 0
            renderer.scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = 0
            out[i] = renderer.render()
    finally:
        renderer.close()
    return out
