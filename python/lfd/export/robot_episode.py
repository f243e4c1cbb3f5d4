"""One robot run made ready for a LeRobot dataset: the simulation sampled at the dataset's rate.

:func:`robot_episode` takes a :class:`~lfd.reproduce.Reproduction` (its
:class:`~lfd.reproduce.controller.Execution` keeps ``qpos`` at the start of every 10 ms control
tick, the commanded set points ``ctrl`` and the scene's MJCF) and samples every
``100 / fps``-th tick: the frame's observation is the simulation's state at the start of that
tick, its action the command given at that tick (what the servos were told to reach), its
subtask the task-program segment the tick belongs to (a dwell tick, the gripper closing or
opening, the segment's before it: :func:`held`), its image rendered from ``qpos`` by a
camera fixed for the whole dataset (:class:`Camera`). The columns (docs/export.md):

``observation.state``             (j+1,) float32  the arm's joint positions (rad), gripper opening (m)
``action``                        (j+1,) float32  the commanded joint positions, gripper opening
``observation.environment_state`` (7k,)  float32  per object: x, y, z (m), quaternion x, y, z, w
``observation.images.<camera>``   video           the rendered scene
``skill_index``, ``object_index``, ``subtask_index`` (1,) int64  as the human export's

The arm's joints are the actuated hinge joints of the scene, the gripper its actuated slide
joints (the fingers): the opening is their sum, as the command is.
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

TICK_HZ = 100
"""Control ticks per second of the simulation (``lfd.reproduce.controller.TICK``)."""
ENV_KEY = "observation.environment_state"
IMAGE_PREFIX = "observation.images."
SCALAR_KEYS = ("skill_index", "object_index", "subtask_index")


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

    ``state``, ``action`` (n, j+1), ``environment`` (n, 7k) float32; ``images`` (n, H, W, 3)
    uint8; ``skill_index``, ``object_index``, ``segment`` (n,) int64 (-1: no skill; ``segment``
    numbers the program's segments); ``subtask`` the frames' subtask names; ``joint_names`` the
    state's columns; ``ticks`` (n,) the control tick of every frame."""

    fps: int
    task: str
    joint_names: list[str]
    object_names: list[str]
    state: np.ndarray
    action: np.ndarray
    environment: np.ndarray
    images: np.ndarray
    skill_index: np.ndarray
    object_index: np.ndarray
    segment: np.ndarray
    subtask: list[str]
    ticks: np.ndarray

    def __len__(self) -> int:
        return int(self.state.shape[0])

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
        for key in SCALAR_KEYS:
            feats[key] = {"dtype": "int64", "shape": (1,), "names": None}
        return feats

    def save(self, path: Path | BinaryIO) -> None:
        """Write to ``path`` (``.npz``, no pickles)."""
        arrays = {k: getattr(self, k) for k in _ARRAYS}
        np.savez(
            path,
            **arrays,
            subtask=np.array(self.subtask, dtype=str),
            joint_names=np.array(self.joint_names, dtype=str),
            object_names=np.array(self.object_names, dtype=str),
            fps_task=np.array([str(self.fps), self.task], dtype=str),
        )

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
                subtask=[str(v) for v in z["subtask"]],
                **{k: z[k] for k in _ARRAYS},
            )


_ARRAYS = (
    "state",
    "action",
    "environment",
    "images",
    "skill_index",
    "object_index",
    "segment",
    "ticks",
)


def robot_episode(run: Reproduction, *, fps: int, camera: Camera, task: str) -> RobotEpisode:
    """The frames of a reproduction at ``fps`` (:func:`check_fps`), rendered by ``camera``."""
    import mujoco

    ex, program = run.execution, run.program
    if ex is None or ex.qpos is None or ex.ctrl is None or program is None:
        raise ValueError("a reproduction without its execution's qpos, ctrl and program")
    model = mujoco.MjModel.from_xml_string(ex.scene)
    ticks = np.arange(0, ex.qpos.shape[0], TICK_HZ // check_fps(fps))
    arm, grip = _actuated(model)
    qadr = model.jnt_qposadr
    qpos = ex.qpos[ticks]
    ctrl = ex.ctrl[ticks]
    state = np.concatenate([qpos[:, qadr[arm]], qpos[:, qadr[grip]].sum(1, keepdims=True)], 1)
    act_arm = [int(np.flatnonzero(model.actuator_trnid[:, 0] == j)[0]) for j in arm]
    act_grip = [int(np.flatnonzero(model.actuator_trnid[:, 0] == j)[0]) for j in grip]
    action = np.concatenate([ctrl[:, act_arm], ctrl[:, act_grip].sum(1, keepdims=True)], 1)
    env = []
    for name in ex.object_names:
        a = int(qadr[model.joint(name).id])  # the object's free joint: x y z, qw qx qy qz
        env.append(
            np.concatenate([qpos[:, a : a + 3], qpos[:, a + 4 : a + 7], qpos[:, a + 3 : a + 4]], 1)
        )
    segs = program.segments
    seg = held(np.asarray(run.segment))[ticks].astype(np.int64)
    names = list(ex.object_names)
    skill = [SKILLS.index(segs[s].skill) if s >= 0 else -1 for s in seg]
    obj = [names.index(segs[s].object) if s >= 0 and segs[s].object in names else -1 for s in seg]
    return RobotEpisode(
        fps=fps,
        task=task,
        joint_names=[*(model.joint(j).name for j in arm), "gripper.opening"],
        object_names=names,
        state=state.astype(np.float32),
        action=action.astype(np.float32),
        environment=np.concatenate(env, 1).astype(np.float32),
        images=render(model, qpos, camera),
        skill_index=np.array(skill, dtype=np.int64),
        object_index=np.array(obj, dtype=np.int64),
        segment=seg,
        subtask=[subtask_name(segs[s].skill, segs[s].object) if s >= 0 else NO_SKILL for s in seg],
        ticks=ticks.astype(np.int64),
    )


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
