"""One recording made ready for a LeRobot dataset: every column at the dataset's frame rate.

:func:`prepare_episode` loads (when given a path), preprocesses and labels a recording (its
ground truth, or the segmentation by a :class:`~lfd.segmentation.Method`) into an
:class:`Episode`; no lerobot is needed (:mod:`.writer` writes it). The columns are described
in :mod:`lfd.export.lerobot` and docs/export.md.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from ..demo import KEYPOINT_NAMES, Demonstration, SkillLabel
from ..errors import DemonstrationError, UsageError
from ..skills import SKILLS

if TYPE_CHECKING:
    from ..reproduce.program import TaskProgram
    from ..segmentation import Method, Templates
    from ..segmentation.templates import TemplateChoice
    from ..trajectory import Trajectory

LabelSource = Literal["auto", "ground-truth", "segment"]
LABEL_SOURCES: tuple[str, ...] = ("auto", "ground-truth", "segment")
"""``auto``: the recording's ground-truth labels when it has them, else the segmentation."""

NO_SKILL = "none"
"""The subtask of frames no label covers (``skill_index`` -1)."""
COLOR_KEY = "observation.images.color"

STATE_NAMES: tuple[str, ...] = ("tcp.x", "tcp.y", "tcp.z", "gripper.qx", "gripper.qy",
                                "gripper.qz", "gripper.qw", "opening")  # fmt: skip


SCALAR_KEYS = ("skill_index", "object_index", "subtask_index")
"""The per-frame skill columns, one value each (a two-hand episode has them per hand too)."""

HAND_KEYS = ("observation.state", "observation.hand_keypoints", "action")
"""The per-frame columns of the hand (a two-hand episode has them per hand too, with
``observation.valid.<side>``)."""


@dataclass
class Lane:
    """One hand's columns of a two-hand episode (as :class:`Episode`'s): its skills and, when
    set, its pose (``observation.state``, ``.hand_keypoints``, ``.valid`` (1,), ``action``:
    the hand's own trajectory on the episode's frames)."""

    skill_index: np.ndarray
    object_index: np.ndarray
    subtask: list[str]
    pose: HandPose | None = None


@dataclass
class HandPose:
    """One hand's pose columns on an episode's frames: ``state``, ``action`` (n, 8),
    ``keypoints`` (n, 63) float32 and ``valid`` (n,) bool."""

    state: np.ndarray
    action: np.ndarray
    keypoints: np.ndarray
    valid: np.ndarray


def _lane(labels: Sequence[SkillLabel], t_ns: np.ndarray, names: list[str]) -> Lane:
    """The skill columns of ``labels`` at the frames ``t_ns`` (objects indexed in ``names``)."""
    per_frame = frame_labels(labels, t_ns)
    return Lane(
        skill_index=np.array(
            [SKILLS.index(lab.skill) if lab else -1 for lab in per_frame], dtype=np.int64
        ),
        object_index=np.array(
            [names.index(lab.object) if lab and lab.object in names else -1 for lab in per_frame],
            dtype=np.int64,
        ),
        subtask=[subtask_name(lab.skill, lab.object) if lab else NO_SKILL for lab in per_frame],
    )


@dataclass
class Episode:
    """One recording, ready to write: every column at the dataset's frame rate (``n`` frames).

    Attributes
    ----------
    recording : str
        Where it came from.
    fps : int
        Frames per second (the preprocessed trajectory's rate).
    t0_ns : int
        Recording time of frame 0; frame ``i`` is at ``t0_ns + i / fps``.
    object_names : list[str]
    state, action : array, shape (n, 8), float32
    keypoints : array, shape (n, 63), float32
    objects : array, shape (n, 7 * k), float32
    valid : array, shape (n, 1 + k), bool
    skill_index, object_index : array, shape (n,), int64 (-1: none)
    subtask : list[str]
        Per frame, ``"skill object"`` (or the skill alone, or :data:`NO_SKILL`).
    segment : array, shape (n,), int64
        Per frame, the number of its label (segment of the program) in time order, -1: none.
    task : str
        The episode's skill program as a sentence (lerobot's ``task``).
    label_source : str
        ``"ground-truth"`` or ``"segment"``.
    program : dict
        The task program (:meth:`lfd.reproduce.TaskProgram.to_json`).
    color : array, shape (m, H, W, 3), uint8, or None
        Colour images; ``color_index[i]`` is frame ``i``'s.
    color_index : array, shape (n,), int64, or None
    lanes : dict[str, Lane]
        A two-hand recording's columns per hand (``right``, ``left``):
        ``skill_index.<side>``, ``object_index.<side>``, ``subtask_index.<side>``,
        ``observation.state.<side>``, ``observation.hand_keypoints.<side>``,
        ``observation.valid.<side>`` and ``action.<side>``; empty for one hand. The unsuffixed
        columns and the program are the first (right) hand's.
    """

    recording: str
    fps: int
    t0_ns: int
    object_names: list[str]
    state: np.ndarray
    action: np.ndarray
    keypoints: np.ndarray
    objects: np.ndarray
    valid: np.ndarray
    skill_index: np.ndarray
    object_index: np.ndarray
    subtask: list[str]
    segment: np.ndarray
    task: str
    label_source: str
    program: dict[str, Any]
    color: np.ndarray | None = None
    color_index: np.ndarray | None = None
    lanes: dict[str, Lane] = field(default_factory=dict)

    def __len__(self) -> int:
        return int(self.state.shape[0])

    def annotation(self) -> dict[str, list[Any]]:
        """The episode's skill segments as lerobot's per-episode subtask annotation: names,
        first and last frame (inclusive) and their times in seconds, one entry per labelled
        segment in time order (the layout of lerobot's SARM annotations)."""
        return segment_annotation(self.segment, self.subtask, self.fps)

    def features(self) -> dict[str, dict[str, Any]]:
        """The lerobot feature specification of these columns."""
        k = len(self.object_names)
        axes = ("x", "y", "z")
        pose = ("x", "y", "z", "qx", "qy", "qz", "qw")
        feats: dict[str, dict[str, Any]] = {
            "observation.state": {"dtype": "float32", "shape": (8,), "names": list(STATE_NAMES)},
            "observation.hand_keypoints": {
                "dtype": "float32",
                "shape": (63,),
                "names": [f"{kp}.{a}" for kp in KEYPOINT_NAMES for a in axes],
            },
            "observation.objects": {
                "dtype": "float32",
                "shape": (7 * k,),
                "names": [f"{o}.{c}" for o in self.object_names for c in pose],
            },
            "observation.valid": {
                "dtype": "bool",
                "shape": (1 + k,),
                "names": ["hand", *self.object_names],
            },
            "action": {"dtype": "float32", "shape": (8,), "names": list(STATE_NAMES)},
            "skill_index": {"dtype": "int64", "shape": (1,), "names": None},
            "object_index": {"dtype": "int64", "shape": (1,), "names": None},
            "subtask_index": {"dtype": "int64", "shape": (1,), "names": None},
        }
        for side in self.lanes:
            for key in SCALAR_KEYS:
                feats[f"{key}.{side}"] = {"dtype": "int64", "shape": (1,), "names": None}
            if self.lanes[side].pose is None:
                continue
            for key in HAND_KEYS:
                feats[f"{key}.{side}"] = dict(feats[key])
            feats[f"observation.valid.{side}"] = {"dtype": "bool", "shape": (1,), "names": ["hand"]}
        if self.color is not None:
            h, w = self.color.shape[1:3]
            feats[COLOR_KEY] = {
                "dtype": "video",
                "shape": (h, w, 3),
                "names": ["height", "width", "channels"],
            }
        return feats


def _quaternions(rotation: np.ndarray) -> np.ndarray:
    """Rotation matrices (n, 3, 3) -> quaternions (n, 4) x, y, z, w with a continuous sign; NaN
    where the matrix is not finite."""
    from scipy.spatial.transform import Rotation

    q = np.full((rotation.shape[0], 4), np.nan)
    ok = np.isfinite(rotation).all(axis=(1, 2))
    if ok.any():
        q[ok] = Rotation.from_matrix(rotation[ok]).as_quat()
    prev = None
    for i in np.flatnonzero(ok):
        if prev is not None and float(np.dot(q[i], prev)) < 0:
            q[i] = -q[i]
        prev = q[i]
    return q


def _fill(values: np.ndarray) -> np.ndarray:
    """Columns of ``values`` (n, d) with their NaN runs linearly interpolated over the frame
    index (held at the ends); a column with no finite value becomes 0. Keeps lerobot's
    normalisation statistics finite; ``observation.valid`` says which frames were tracked."""
    out = np.array(values, dtype=np.float64)
    idx = np.arange(out.shape[0])
    for j in range(out.shape[1]):
        ok = np.isfinite(out[:, j])
        if ok.all():
            continue
        out[:, j] = np.interp(idx, idx[ok], out[ok, j]) if ok.any() else 0.0
    return out


def _fill_quaternions(values: np.ndarray, start: int) -> None:
    """Re-normalise the interpolated quaternions in columns ``start:start + 4`` in place."""
    q = values[:, start : start + 4]
    norm = np.linalg.norm(q, axis=1, keepdims=True)
    q[:] = np.where(norm > 1e-9, q / np.where(norm > 1e-9, norm, 1.0), [0.0, 0.0, 0.0, 1.0])


def frame_labels(labels: Sequence[SkillLabel], t_ns: np.ndarray) -> list[SkillLabel | None]:
    """The label covering each time: ``start_ns <= t < end_ns`` (the last label also at its
    end); None where no label does."""
    ordered = sorted(labels, key=lambda lab: lab.start_ns)
    starts = np.array([lab.start_ns for lab in ordered], dtype=np.int64)
    out: list[SkillLabel | None] = []
    for t in np.asarray(t_ns, dtype=np.int64):
        k = int(np.searchsorted(starts, t, side="right")) - 1
        lab = ordered[k] if k >= 0 else None
        if lab is not None and not (t < lab.end_ns or (k == len(ordered) - 1 and t == lab.end_ns)):
            lab = None
        out.append(lab)
    return out


def segment_annotation(segment: np.ndarray, subtask: Sequence[str], fps: int) -> dict[str, Any]:
    """Lerobot's per-episode subtask annotation of frames numbered by ``segment`` (-1: none)
    and named by ``subtask``: names, first and last frame (inclusive) and their times in
    seconds, one entry per run of a segment, in time order (:meth:`Episode.annotation`)."""
    names: list[str] = []
    first: list[int] = []
    last: list[int] = []
    for i, seg in enumerate(np.asarray(segment).tolist()):
        if seg < 0:
            continue
        if i == 0 or segment[i - 1] != seg:
            names.append(subtask[i])
            first.append(i)
            last.append(i)
        last[-1] = i
    return {
        "subtask_names": names,
        "subtask_start_times": [f / fps for f in first],
        "subtask_end_times": [f / fps for f in last],
        "subtask_start_frames": first,
        "subtask_end_frames": last,
    }


def subtask_name(skill: str | None, obj: str | None) -> str:
    """The subtask text of a frame: ``"pick_up box_2"``, ``"move"``, or :data:`NO_SKILL`."""
    if skill is None:
        return NO_SKILL
    return f"{skill} {obj}" if obj else skill


def prepare_episode(
    recording: str | os.PathLike[str] | Demonstration,
    *,
    labels: LabelSource = "auto",
    method: Method | str | os.PathLike[str] | None = None,
    video: bool = True,
    name: str | None = None,
    templates: Templates | TemplateChoice | None = None,
) -> Episode:
    """Load (when given a path), preprocess and label one recording (no lerobot needed).

    Parameters
    ----------
    recording : path or Demonstration
    labels : {"auto", "ground-truth", "segment"}
        Where the skill labels come from: ``auto`` takes the recording's ground truth when it
        has any, else segments it (:func:`lfd.segment` with ``method``).
    method : Method, name or template file, optional
        How to segment (:meth:`lfd.Method.load`; default: lfd's). Its preprocessing is the
        episode's, whatever the labels.
    video : bool
        Keep the colour images (when the recording has them).
    name : str, optional
        How the episode names its recording (default: the path).
    templates : Templates or {"default", "paper"}, optional
        Instead of ``method``: templates, with the method saved in them (as :func:`lfd.segment`
        takes them).

    Raises
    ------
    UsageError
        An unknown label source.
    DemonstrationError
        ``ground-truth`` asked for a recording without labels; too short; no hand or objects.
    """
    from ..io import load
    from ..preprocessing import preprocess
    from ..segmentation import resolve_method

    if labels not in LABEL_SOURCES:
        raise UsageError(f"labels must be one of {', '.join(LABEL_SOURCES)}, got {labels!r}")
    m = resolve_method(templates, method)
    if isinstance(recording, Demonstration):
        demo, where = recording, name or "<demonstration>"
    else:
        demo, where = load(recording), name or str(recording)
    traj = preprocess(demo, **m.preprocessing)  # once: the segmentation takes it as it is
    n = len(traj)
    if n < 2:
        raise DemonstrationError(f"{where}: too short to export ({n} preprocessed samples)")
    rate = float(traj.meta.get("rate_hz", 1.0 / traj.dt))
    fps = round(rate)
    if fps < 1 or abs(rate - fps) > 1e-6 * rate:
        raise DemonstrationError(f"{where}: LeRobot needs a whole frame rate, got {rate:g} Hz")
    t0 = int(traj.t_ns[0])
    source, lanes, program = _episode_labels(demo, traj, labels, m, where)
    skill_labels = lanes[demo.sides[0]]
    names = list(traj.object_names)
    per_frame = frame_labels(skill_labels, traj.t_ns)
    first = _lane(skill_labels, traj.t_ns, names)
    number = {id(lab): k for k, lab in enumerate(skill_labels)}
    state, keypoints, objects, valid = _pose_columns(traj)
    color, color_index = _color_frames(demo, traj, where) if video else (None, None)
    steps = [subtask_name(s.skill, s.object) for s in program.segments]
    return Episode(
        recording=where,
        fps=fps,
        t0_ns=t0,
        object_names=names,
        state=state,
        action=np.concatenate([state[1:], state[-1:]], axis=0),
        keypoints=keypoints,
        objects=objects,
        valid=valid,
        skill_index=first.skill_index,
        object_index=first.object_index,
        subtask=first.subtask,
        segment=np.array([number[id(lab)] if lab else -1 for lab in per_frame], dtype=np.int64),
        task=", ".join(steps),
        label_source=source,
        program=program.to_json(),
        color=color,
        color_index=color_index,
        lanes=_hand_lanes(demo, traj, lanes, m, (state, keypoints, valid[:, 0])),
    )


def _hand_lanes(
    demo: Demonstration,
    traj: Trajectory,
    lanes: dict[str, list[SkillLabel]],
    method: Method,
    first: tuple[np.ndarray, np.ndarray, np.ndarray],
) -> dict[str, Lane]:
    """Each hand's columns of a two-hand episode on ``traj``'s frames (``first``: the first
    hand's state, keypoints and validity, already computed); empty for one hand. Another hand
    is preprocessed on its own (as :func:`lfd.segment_hands` does) and sampled at the frames
    (linearly; invalid outside its span or where its nearest frame is)."""
    from ..preprocessing import preprocess

    if len(lanes) < 2:
        return {}
    names = list(traj.object_names)
    out: dict[str, Lane] = {}
    for k, (side, labels) in enumerate(lanes.items()):
        lane = _lane(labels, traj.t_ns, names)
        if k == 0:
            state, keypoints, valid = first
        else:
            own = preprocess(demo.one_hand(side), **method.preprocessing)
            state, keypoints, valid = _resampled(own, traj.t_ns)
        action = np.concatenate([state[1:], state[-1:]], axis=0)
        lane.pose = HandPose(state, action, keypoints, valid)
        out[side] = lane
    return out


def _resampled(own: Trajectory, t_ns: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A hand's state, keypoints and validity (:func:`_pose_columns`) of trajectory ``own``,
    sampled at ``t_ns`` (another hand's frames, on the same clock)."""
    state, keypoints, _, valid = _pose_columns(own)
    t = (own.t_ns - t_ns[0]).astype(np.float64)
    at = (t_ns - t_ns[0]).astype(np.float64)

    def interp(cols: np.ndarray) -> np.ndarray:
        return np.stack([np.interp(at, t, cols[:, j]) for j in range(cols.shape[1])], axis=1)

    s = interp(state.astype(np.float64))
    _fill_quaternions(s, 3)
    nearest = np.clip(np.searchsorted(t, at), 0, len(t) - 1)
    inside = (at >= t[0]) & (at <= t[-1])
    return (
        s.astype(np.float32),
        interp(keypoints.astype(np.float64)).astype(np.float32),
        valid[nearest, 0] & inside,
    )


def _episode_labels(
    demo: Demonstration, traj: Trajectory, labels: LabelSource, method: Method, where: str
) -> tuple[str, dict[str, list[SkillLabel]], TaskProgram]:
    """The episode's label source, each hand's skill labels in time order and the first
    (right) hand's task program: the ground truth, or the segmentation of ``traj`` by
    ``method`` (of both hands, :func:`lfd.segment_hands`, for two)."""
    from ..reproduce.program import from_labels, from_segmentation

    t0 = int(traj.t_ns[0])
    if labels == "ground-truth" and not demo.labels:
        raise DemonstrationError(
            f"{where} has no ground-truth labels; use --labels segment (or auto)"
        )
    first = demo.sides[0]
    if labels == "ground-truth" or (labels == "auto" and demo.labels):
        source = "ground-truth"
        lanes = {side: demo.labels_of(side) for side in demo.sides}
        program = from_labels(lanes[first], t0)
    elif len(demo.sides) > 1:
        from ..segmentation import segment_hands

        both = segment_hands(demo, method=method)
        source = "segment"
        lanes = {side: [s.to_label() for s in seg.segments] for side, seg in both.lanes.items()}
        program = from_segmentation(both.lanes[first], t0)
    else:
        from ..segmentation import segment

        seg = segment(traj, method=method)
        source, lanes = "segment", {first: [s.to_label() for s in seg.segments]}
        program = from_segmentation(seg, t0)
    return source, {s: sorted(v, key=lambda lab: lab.start_ns) for s, v in lanes.items()}, program


def _pose_columns(traj: Trajectory) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``observation.state``, ``.hand_keypoints``, ``.objects`` (float32, gaps filled) and
    ``.valid`` (bool) of every frame."""
    n, k = len(traj), len(traj.object_names)
    state = _fill(np.concatenate([traj.tcp, _quaternions(traj.rotation), traj.opening[:, None]], 1))
    _fill_quaternions(state, 3)
    objects = np.concatenate([traj.object_position, traj.object_quaternion], axis=2)  # (k, n, 7)
    objects = _fill(objects.transpose(1, 0, 2).reshape(n, 7 * k))
    for j in range(k):
        _fill_quaternions(objects, 7 * j + 3)
    keypoints = _fill(traj.keypoints.reshape(n, 63))
    valid = np.concatenate([traj.hand_valid[:, None], traj.object_valid.T], axis=1).astype(bool)
    # a gripper or object NaN the preprocessing left outside its long-gap masks is untracked too
    valid[:, 0] &= np.isfinite(traj.tcp).all(axis=1)
    valid[:, 1:] &= np.isfinite(traj.object_position).all(axis=2).T
    return (
        state.astype(np.float32),
        keypoints.astype(np.float32),
        objects.astype(np.float32),
        valid,
    )


def _color_frames(
    demo: Demonstration, traj: Trajectory, where: str
) -> tuple[np.ndarray | None, np.ndarray | None]:
    """The recording's colour images and each frame's (the latest at or before it), or
    ``(None, None)`` without images."""
    if demo.color is None or not len(demo.color):
        return None, None
    frames = np.asarray(demo.color.frames)
    if frames.ndim != 4 or frames.shape[3] != 3 or frames.dtype != np.uint8:
        raise DemonstrationError(
            f"{where}: colour images must be uint8 RGB, got {frames.dtype} {frames.shape}"
        )
    idx = np.searchsorted(demo.color.t_ns, traj.t_ns, side="right") - 1
    return frames, np.clip(idx, 0, len(demo.color) - 1).astype(np.int64)
