"""Recordings -> one LeRobot dataset, one episode per recording, skill labels frame by frame.

The dataset is written through the ``lerobot`` package's own API (``LeRobotDataset.create``,
``add_frame``, ``save_episode``, ``finalize``; tested with lerobot 0.4.4, dataset format v3.0),
so its layout is right by construction; ``LeRobotDataset(repo_id, root=DIR)`` loads it back.

One frame per sample of the preprocessed trajectory (:func:`lfd.preprocess`: every stream on
one 30 Hz clock, the hand mapped to a gripper), so the dataset's ``fps`` is the trajectory rate.
The columns (docs/export.md):

``observation.state``      (8,)  float32  TCP x, y, z (m), gripper quaternion x, y, z, w, opening (m)
``observation.hand_keypoints`` (63,) float32  the 21 keypoints x, y, z (m), reference-marker frame
``observation.objects``    (7k,) float32  per object: x, y, z (m), quaternion x, y, z, w
``observation.valid``      (1+k,) bool    hand, then each object: tracked (False inside long gaps,
                                           where the values are interpolated)
``action``                 (8,)  float32  the next frame's ``observation.state`` (the last frame:
                                           its own)
``skill_index``            (1,)  int64    index into :data:`lfd.skills.SKILLS`, -1: no skill
``object_index``           (1,)  int64    index into the episode's objects, -1: none
``subtask_index``          (1,)  int64    row of ``meta/subtasks.parquet`` ("pick_up box_2");
                                           lerobot adds ``item["subtask"]`` when loading
``task`` (lerobot's own)                  the episode's skill program as one sentence
``observation.images.color`` video        colour frames, when the recording has them (the latest
                                           image at or before each frame)

``meta/lfd_program.json`` holds each episode's task program (:class:`lfd.reproduce.TaskProgram`
JSON), its recording, label source and time origin.

The work per recording is split so a batch runner can parallelise the expensive half:
:func:`prepare_episode` (load, preprocess, labels; no lerobot) and :meth:`LeRobotWriter.add`
(sequential: a dataset has one writer); :func:`export_recording` does both.
"""

from __future__ import annotations

import json
import os
import time
import warnings
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from ..demo import KEYPOINT_NAMES, Demonstration, SkillLabel
from ..errors import DemonstrationError, LfdError, UsageError
from ..skills import SKILLS

LabelSource = Literal["auto", "ground-truth", "segment"]
LABEL_SOURCES: tuple[str, ...] = ("auto", "ground-truth", "segment")
"""``auto``: the recording's ground-truth labels when it has them, else the segmentation."""

LEROBOT_VERSION = "0.4.4"
"""The lerobot version the export is tested with."""
INSTALL_HINT = "pip install 'lfd[lerobot]' && pip install --no-deps lerobot==0.4.4"
PROGRAM_PATH = "meta/lfd_program.json"
SUBTASKS_PATH = "meta/subtasks.parquet"
"""The table lerobot 0.4.4 reads for ``subtask_index`` (``LeRobotDataset.__getitem__``)."""
PROGRAM_FORMAT = 1
NO_SKILL = "none"
"""The subtask of frames no label covers (``skill_index`` -1)."""
COLOR_KEY = "observation.images.color"
DEFAULT_VCODEC = "libsvtav1"
"""lerobot's default codec (AV1, the smallest files)."""
VCODECS: tuple[str, ...] = ("libsvtav1", "h264")
"""The software codecs lerobot accepts that encode quietly (its ``hevc``, x265, prints its
settings to stderr and is the slowest)."""

SCALAR_KEYS = ("skill_index", "object_index", "subtask_index")

STATE_NAMES: tuple[str, ...] = ("tcp.x", "tcp.y", "tcp.z", "gripper.qx", "gripper.qy",
                                "gripper.qz", "gripper.qw", "opening")  # fmt: skip


def import_lerobot() -> Any:
    """The ``LeRobotDataset`` class, or an :class:`LfdError` saying how to install it."""
    try:
        from lerobot.datasets.lerobot_dataset import LeRobotDataset
    except ModuleNotFoundError as err:
        from ..errors import MissingExtraError

        raise MissingExtraError(
            f"the LeRobot export needs lerobot ({err.name} is missing): {INSTALL_HINT}",
            extra="lerobot",
            module=err.name,
        ) from None
    return LeRobotDataset


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

    def __len__(self) -> int:
        return int(self.state.shape[0])

    def annotation(self) -> dict[str, list[Any]]:
        """The episode's skill segments as lerobot's per-episode subtask annotation: names,
        first and last frame (inclusive) and their times in seconds, one entry per labelled
        segment in time order (the layout of lerobot's SARM annotations)."""
        names: list[str] = []
        first: list[int] = []
        last: list[int] = []
        for i, seg in enumerate(self.segment.tolist()):
            if seg < 0:
                continue
            if i == 0 or self.segment[i - 1] != seg:
                names.append(self.subtask[i])
                first.append(i)
                last.append(i)
            last[-1] = i
        return {
            "subtask_names": names,
            "subtask_start_times": [f / self.fps for f in first],
            "subtask_end_times": [f / self.fps for f in last],
            "subtask_start_frames": first,
            "subtask_end_frames": last,
        }

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


def subtask_name(skill: str | None, obj: str | None) -> str:
    """The subtask text of a frame: ``"pick_up box_2"``, ``"move"``, or :data:`NO_SKILL`."""
    if skill is None:
        return NO_SKILL
    return f"{skill} {obj}" if obj else skill


def prepare_episode(
    recording: str | os.PathLike[str] | Demonstration,
    *,
    labels: LabelSource = "auto",
    templates: Any = None,
    video: bool = True,
    name: str | None = None,
) -> Episode:
    """Load (when given a path), preprocess and label one recording (no lerobot needed).

    Parameters
    ----------
    recording : path or Demonstration
    labels : {"auto", "ground-truth", "segment"}
        Where the skill labels come from: ``auto`` takes the recording's ground truth when it
        has any, else segments it (:func:`lfd.segment` with ``templates``).
    templates : Templates or str, optional
        Templates for the segmentation (default: the shipped ones).
    video : bool
        Keep the colour images (when the recording has them).
    name : str, optional
        How the episode names its recording (default: the path).

    Raises
    ------
    UsageError
        An unknown label source.
    DemonstrationError
        ``ground-truth`` asked for a recording without labels; too short; no hand or objects.
    """
    from ..io import load
    from ..preprocessing import preprocess
    from ..reproduce.program import from_labels, from_segmentation

    if labels not in LABEL_SOURCES:
        raise UsageError(f"labels must be one of {', '.join(LABEL_SOURCES)}, got {labels!r}")
    if isinstance(recording, Demonstration):
        demo, where = recording, name or "<demonstration>"
    else:
        demo, where = load(recording), name or str(recording)
    from ..segmentation import resolve_method

    method = resolve_method(templates)
    traj = preprocess(demo, **method.preprocessing)  # once: the segmentation takes it as it is
    n = len(traj)
    if n < 2:
        raise DemonstrationError(f"{where}: too short to export ({n} preprocessed samples)")
    rate = float(traj.meta.get("rate_hz", 1.0 / traj.dt))
    fps = round(rate)
    if fps < 1 or abs(rate - fps) > 1e-6 * rate:
        raise DemonstrationError(f"{where}: LeRobot needs a whole frame rate, got {rate:g} Hz")
    t0 = int(traj.t_ns[0])

    if labels == "ground-truth" and not demo.labels:
        raise DemonstrationError(
            f"{where} has no ground-truth labels; use --labels segment (or auto)"
        )
    if labels == "ground-truth" or (labels == "auto" and demo.labels):
        source, skill_labels = "ground-truth", list(demo.labels)
        program = from_labels(skill_labels, t0)
    else:
        from ..segmentation import segment

        seg = segment(traj, method=method)
        source, skill_labels = "segment", [s.to_label() for s in seg.segments]
        program = from_segmentation(seg, t0)

    names = list(traj.object_names)
    skill_labels = sorted(skill_labels, key=lambda lab: lab.start_ns)
    per_frame = frame_labels(skill_labels, traj.t_ns)
    number = {id(lab): k for k, lab in enumerate(skill_labels)}
    seg_number = np.array([number[id(lab)] if lab else -1 for lab in per_frame], dtype=np.int64)
    skill_index = np.array(
        [SKILLS.index(lab.skill) if lab else -1 for lab in per_frame], dtype=np.int64
    )
    object_index = np.array(
        [names.index(lab.object) if lab and lab.object in names else -1 for lab in per_frame],
        dtype=np.int64,
    )
    subtask = [subtask_name(lab.skill, lab.object) if lab else NO_SKILL for lab in per_frame]

    state = _fill(np.concatenate([traj.tcp, _quaternions(traj.rotation), traj.opening[:, None]], 1))
    _fill_quaternions(state, 3)
    k = len(names)
    objects = np.concatenate([traj.object_position, traj.object_quaternion], axis=2)  # (k, n, 7)
    objects = _fill(objects.transpose(1, 0, 2).reshape(n, 7 * k))
    for j in range(k):
        _fill_quaternions(objects, 7 * j + 3)
    keypoints = _fill(traj.keypoints.reshape(n, 63))
    valid = np.concatenate([traj.hand_valid[:, None], traj.object_valid.T], axis=1).astype(bool)
    # a gripper or object NaN the preprocessing left outside its long-gap masks is untracked too
    valid[:, 0] &= np.isfinite(traj.tcp).all(axis=1)
    valid[:, 1:] &= np.isfinite(traj.object_position).all(axis=2).T
    state32 = state.astype(np.float32)

    color = color_index = None
    if video and demo.color is not None and len(demo.color):
        frames = np.asarray(demo.color.frames)
        if frames.ndim != 4 or frames.shape[3] != 3 or frames.dtype != np.uint8:
            raise DemonstrationError(
                f"{where}: colour images must be uint8 RGB, got {frames.dtype} {frames.shape}"
            )
        color = frames
        idx = np.searchsorted(demo.color.t_ns, traj.t_ns, side="right") - 1
        color_index = np.clip(idx, 0, len(demo.color) - 1).astype(np.int64)

    steps = [subtask_name(s.skill, s.object) for s in program.segments]
    return Episode(
        recording=where,
        fps=fps,
        t0_ns=t0,
        object_names=names,
        state=state32,
        action=np.concatenate([state32[1:], state32[-1:]], axis=0),
        keypoints=keypoints.astype(np.float32),
        objects=objects.astype(np.float32),
        valid=valid,
        skill_index=skill_index,
        object_index=object_index,
        subtask=subtask,
        segment=seg_number,
        task=", ".join(steps),
        label_source=source,
        program=program.to_json(),
        color=color,
        color_index=color_index,
    )


class LeRobotWriter:
    """One LeRobot dataset being written, episode by episode (one writer per dataset).

    The first episode fixes the schema (objects, frame rate, camera image size); a later one
    that differs is refused with a :class:`DemonstrationError` before anything of it is written.
    :meth:`close` finalises the dataset and writes the subtask table and the task programs.
    """

    def __init__(
        self, root: str | os.PathLike[str], repo_id: str, *, vcodec: str = DEFAULT_VCODEC
    ) -> None:
        self.root = Path(root)
        self.repo_id = repo_id
        self.vcodec = vcodec
        self._dataset: Any = None
        self._schema: tuple[Any, ...] | None = None
        self.subtasks: dict[str, int] = {}
        self.episodes: list[dict[str, Any]] = []
        self._annotations: dict[int, dict[str, list[Any]]] = {}

    def _check(self, ep: Episode) -> None:
        shape = None if ep.color is None else tuple(ep.color.shape[1:])
        schema = (ep.fps, tuple(ep.object_names), shape)
        if self._schema is None:
            self._schema = schema
            return
        fps, names, image = self._schema
        if ep.fps != fps:
            raise DemonstrationError(f"{ep.recording}: {ep.fps} Hz, the dataset has {fps} Hz")
        if tuple(ep.object_names) != names:
            raise DemonstrationError(
                f"{ep.recording}: objects {', '.join(ep.object_names)} differ from the "
                f"dataset's {', '.join(names)}; export it into another dataset"
            )
        if shape != image:
            have = "no colour images" if shape is None else f"colour images {shape}"
            want = "none" if image is None else f"{image}"
            raise DemonstrationError(
                f"{ep.recording}: {have}, the dataset's are {want}; export it into another "
                "dataset (or use --no-video)"
            )

    def add(self, ep: Episode) -> int:
        """Write one episode; returns its index."""
        self._check(ep)
        if self._dataset is None:
            LeRobotDataset = import_lerobot()
            self._dataset = LeRobotDataset.create(
                self.repo_id,
                ep.fps,
                ep.features(),
                root=self.root,
                robot_type="human_hand",
                use_videos=ep.color is not None,
                vcodec=self.vcodec,
                video_backend="pyav",
            )
        ds = self._dataset
        for name in ep.subtask:
            self.subtasks.setdefault(name, len(self.subtasks))
        try:
            for i in range(len(ep)):
                frame: dict[str, Any] = {
                    "observation.state": ep.state[i],
                    "observation.hand_keypoints": ep.keypoints[i],
                    "observation.objects": ep.objects[i],
                    "observation.valid": ep.valid[i],
                    "action": ep.action[i],
                    "skill_index": ep.skill_index[i : i + 1],
                    "object_index": ep.object_index[i : i + 1],
                    "subtask_index": np.array([self.subtasks[ep.subtask[i]]], dtype=np.int64),
                    "task": ep.task,
                }
                if ep.color is not None and ep.color_index is not None:
                    frame[COLOR_KEY] = ep.color[ep.color_index[i]]
                ds.add_frame(frame)
            # lerobot keeps a (1,)-shaped feature as a scalar column, and its own (frame_index,
            # ...) as scalars in the buffer; ours are validated as (1,) arrays above but must be
            # scalars too, as numpy >= 2.4 no longer converts a (1,) array to int
            for key in SCALAR_KEYS:
                ds.episode_buffer[key] = [np.int64(v[0]) for v in ds.episode_buffer[key]]
        except BaseException:
            ds.clear_episode_buffer()
            raise
        index = int(ds.meta.total_episodes)
        with _quiet():
            ds.save_episode()
        self.episodes.append(
            {
                "episode_index": index,
                "recording": ep.recording,
                "labels": ep.label_source,
                "t0_ns": ep.t0_ns,
                "frames": len(ep),
                "objects": ep.object_names,
                "task": ep.task,
                "program": ep.program,
            }
        )
        self._annotations[index] = ep.annotation()
        return index

    def abort(self) -> None:
        """Stop writing (a failed or interrupted export): close lerobot's writers and drop its
        buffered metadata, which it would otherwise write when the dataset object is
        collected, recreating the dataset's directories after they were removed."""
        import contextlib

        ds, self._dataset = self._dataset, None
        if ds is None:
            return
        with contextlib.suppress(Exception):
            ds.stop_image_writer()
        for obj in (ds, ds.meta):
            with contextlib.suppress(Exception):
                if hasattr(obj, "metadata_buffer"):
                    obj.metadata_buffer.clear()
                obj._close_writer()

    def close(self) -> None:
        """Finalise the dataset (parquet footers) and write the subtask and program tables."""
        if self._dataset is None:
            return
        import pandas as pd

        from .._version import __version__

        with _quiet():
            self._dataset.finalize()
        names = list(self.subtasks)
        table = pd.DataFrame({"subtask_index": range(len(names))}, index=names)
        table.to_parquet(self.root / SUBTASKS_PATH)
        doc = {
            "format": PROGRAM_FORMAT,
            "lfd_version": __version__,
            "skills": list(SKILLS),
            "no_skill": NO_SKILL,
            "episodes": self.episodes,
        }
        (self.root / PROGRAM_PATH).write_text(json.dumps(doc, indent=2) + "\n")
        self._write_annotations()

    def _write_annotations(self) -> None:
        """The skill segments as per-episode columns of ``meta/episodes``: ``sparse_subtask_*``
        and the unprefixed ``subtask_*``, as lerobot's SARM annotation tool writes them (its
        reward model reads them); lerobot's loader keeps the extra columns."""
        import pandas as pd

        for path in sorted((self.root / "meta" / "episodes").glob("chunk-*/file-*.parquet")):
            table = pd.read_parquet(path)
            for key in next(iter(self._annotations.values())):
                for column in (f"sparse_{key}", key):
                    table[column] = [self._annotations[int(e)][key] for e in table["episode_index"]]
            table.to_parquet(path, engine="pyarrow", compression="snappy")


@dataclass
class RecordingResult:
    """What became of one recording: an episode, or an error."""

    recording: str
    episode_index: int | None = None
    frames: int = 0
    labels: str | None = None
    seconds: float = 0.0
    error: str | None = None


def export_recording(
    writer: LeRobotWriter,
    recording: str | os.PathLike[str],
    *,
    labels: LabelSource = "auto",
    templates: Any = None,
    video: bool = True,
) -> RecordingResult:
    """Prepare one recording and add it to ``writer`` as an episode.

    A user-caused failure (unreadable file, missing labels, a schema that does not fit the
    dataset) is returned as ``RecordingResult.error`` and nothing of the recording is written;
    anything else propagates.
    """
    start = time.perf_counter()
    where = str(recording)
    try:
        ep = prepare_episode(recording, labels=labels, templates=templates, video=video)
    except (LfdError, OSError) as err:
        return RecordingResult(
            where, error=_one_line(err, where), seconds=time.perf_counter() - start
        )
    return _write_episode(writer, where, ep, time.perf_counter() - start)


def _one_line(err: BaseException, where: str) -> str:
    if isinstance(err, OSError):
        return f"{err.filename or where}: {err.strerror or err}"
    return " ".join(str(err).split())


def _write_episode(writer: LeRobotWriter, where: str, ep: Episode, spent: float) -> RecordingResult:
    """Add a prepared episode to ``writer`` (``spent``: seconds it took to prepare)."""
    start = time.perf_counter()
    try:
        index = writer.add(ep)
    except (LfdError, OSError) as err:
        return RecordingResult(where, error=_one_line(err, where), seconds=spent)
    return RecordingResult(
        where, index, len(ep), ep.label_source, spent + time.perf_counter() - start
    )


@dataclass
class ExportReport:
    """The result of :func:`export_lerobot`."""

    root: Path
    repo_id: str
    results: list[RecordingResult] = field(default_factory=list)
    seconds: float = 0.0

    @property
    def exported(self) -> list[RecordingResult]:
        return [r for r in self.results if r.error is None]

    @property
    def failed(self) -> list[RecordingResult]:
        return [r for r in self.results if r.error is not None]


DATASET_ENTRIES = frozenset({"meta", "data", "videos", "images"})
"""What a LeRobot dataset directory holds at its top (``images``: lerobot's frame files)."""


def not_a_dataset(root: Path) -> str | None:
    """Why ``--overwrite`` may not delete the directory ``root`` (it is not a LeRobot dataset,
    or holds something else too), or None when it is one (``meta/info.json``, and nothing but
    :data:`DATASET_ENTRIES` at its top)."""
    if not (root / "meta" / "info.json").is_file():
        return "it is not a LeRobot dataset (no meta/info.json)"
    other = sorted(e.name for e in root.iterdir() if e.name not in DATASET_ENTRIES)
    if other:
        return f"it holds {other[0]}, which is not part of a LeRobot dataset"
    return None


def recording_paths(inputs: Iterable[str | os.PathLike[str]]) -> list[Path]:
    """Files as given, directories as their ``*.mcap`` files (sorted); refuses an empty list."""
    from ..batch import mcap_files

    out: list[Path] = []
    for item in inputs:
        found = [Path(f) for f in mcap_files([item])]
        if not found:  # an empty directory
            raise UsageError(f"{item}: no .mcap recordings in this directory")
        out.extend(found)
    if not out:
        raise UsageError("no recordings given")
    return out


def export_lerobot(
    inputs: Iterable[str | os.PathLike[str]],
    output: str | os.PathLike[str],
    *,
    labels: LabelSource = "auto",
    overwrite: bool = False,
    repo_id: str | None = None,
    video: bool = True,
    vcodec: str = DEFAULT_VCODEC,
    templates: Any = None,
    on_result: Callable[[RecordingResult], None] | None = None,
    jobs: int | None = 1,
    ray_address: str | None = None,
) -> ExportReport:
    """Export recordings into one LeRobot dataset at ``output``, one episode per recording.

    Parameters
    ----------
    inputs : paths
        ``.mcap`` files and directories (every ``*.mcap`` in them, sorted).
    output : path
        The dataset directory: missing or empty, or, with ``overwrite``, a dataset to replace
        (:func:`not_a_dataset`: a directory holding anything else is never deleted). It is
        written in a temporary directory beside it and renamed at the end, so a failed or
        interrupted export leaves the old directory (or none); a directory that appeared there
        meanwhile (another export) is kept, and this export refused, unless ``overwrite``.
        Missing parent directories are created (and removed again if the export fails).
    labels, templates, video
        See :func:`prepare_episode`; ``templates`` may also be the path of a template file
        (read once, here; the output may not replace it).
    repo_id : str, optional
        The dataset's ``repo_id`` (default ``lfd/<output name>``).
    vcodec : str
        Video codec for the colour frames (:data:`VCODECS`).
    on_result : callable, optional
        Called with each recording's :class:`RecordingResult`, in order, as it finishes.
    jobs, ray_address
        Where the recordings are read, preprocessed and labelled (:func:`prepare_episode`,
        in parallel: :func:`lfd.batch.run_batch`); the episodes are written one after the
        other, in input order, in this process. ``jobs=1`` without Ray: one recording at a
        time.

    Raises
    ------
    UsageError
        Bad output directory or options, no recordings.
    LfdError
        No recording could be exported (each one's reason is in its result), or lerobot
        is missing.
    """
    from ..outputs import atomic_directory, check_output_dir, created_parents, signals_held

    if labels not in LABEL_SOURCES:
        raise UsageError(f"--labels must be one of {', '.join(LABEL_SOURCES)}, got {labels!r}")
    if vcodec not in VCODECS:
        raise UsageError(f"--vcodec must be one of {', '.join(VCODECS)}, got {vcodec!r}")
    paths = recording_paths(inputs)
    reads: list[Any] = [*paths]
    if isinstance(templates, (str, os.PathLike)) and str(templates) not in ("default", "paper"):
        from ..segmentation import Templates

        reads.append(templates)
        templates = Templates.load(os.fspath(templates))
    replace: dict[str, Any] = {"overwrite": overwrite, "replaceable": not_a_dataset}
    from ..io.reads import read_paths

    dest = check_output_dir(
        output, inputs=read_paths(reads), what="output", parents=True, **replace
    )
    repo = repo_id or f"lfd/{dest.resolve().name}"
    if repo.count("/") != 1 or not all(repo.split("/")):
        raise UsageError(f"--repo-id must look like OWNER/NAME, got {repo!r}")
    import_lerobot()
    start = time.perf_counter()
    report = ExportReport(dest, repo)
    parallel = ray_address is not None or jobs != 1
    prepared = (
        _prepare_all(paths, labels, templates, video, jobs, ray_address) if parallel else None
    )
    with created_parents(dest), atomic_directory(dest, **replace) as root:
        writer = LeRobotWriter(root, repo, vcodec=vcodec)
        try:
            for i, path in enumerate(paths):
                if prepared is None:
                    result = export_recording(
                        writer, path, labels=labels, templates=templates, video=video
                    )
                else:
                    result = _add_prepared(writer, str(path), prepared[i])
                report.results.append(result)
                if on_result is not None:
                    on_result(result)
            if not report.exported:
                raise LfdError(f"no recording could be exported ({len(report.failed)} failed)")
            writer.close()
        except BaseException:
            with signals_held():  # before the temporary directory goes: nothing writes later
                writer.abort()
            raise
    report.seconds = time.perf_counter() - start
    return report


def prepare_file(
    path: str,
    *,
    labels: LabelSource = "auto",
    templates: str | None = None,
    video: bool = True,
) -> Episode:
    """:func:`prepare_episode` of one file as a batch worker runs it (``templates`` as
    :func:`~lfd.segmentation.files.portable_templates` gives them)."""
    from ..segmentation.files import worker_templates

    return prepare_episode(path, labels=labels, templates=worker_templates(templates), video=video)


def _prepare_all(
    paths: list[Path],
    labels: LabelSource,
    templates: Any,
    video: bool,
    jobs: int | None,
    ray_address: str | None,
) -> list[Any]:
    """Every recording's episode (or its error), prepared in parallel, in input order."""
    from functools import partial

    from ..batch import run_batch
    from ..segmentation.files import portable_templates

    task = partial(
        prepare_file, labels=labels, templates=portable_templates(templates), video=video
    )
    return run_batch(task, [str(p) for p in paths], jobs=jobs, ray_address=ray_address)


def _add_prepared(writer: LeRobotWriter, where: str, res: Any) -> RecordingResult:
    """Write one prepared episode (a :class:`lfd.batch.ItemResult`) as :func:`export_recording`
    does."""
    if not res.ok:
        return RecordingResult(where, error=" ".join(str(res.error).split()), seconds=res.seconds)
    return _write_episode(writer, where, res.value, res.seconds)


class _quiet:
    """Silence ``datasets``' progress bars and the video encoders' banners while writing (the
    command's stderr carries one line per problem)."""

    def __enter__(self) -> None:
        import av
        import datasets

        self._bars = datasets.utils.logging.is_progress_bar_enabled()
        datasets.utils.logging.disable_progress_bar()
        # libx264 prints its statistics when the encoder is freed, after lerobot restored
        # FFmpeg's own log callback: FFmpeg's level, not only PyAV's
        self._av_level = av.logging.get_level()
        av.logging.set_level(av.logging.ERROR)
        av.logging.set_libav_level(av.logging.ERROR)
        self._svt = os.environ.get("SVT_LOG")
        os.environ["SVT_LOG"] = "1"  # SVT-AV1: errors only (its banner goes to stderr)
        self._warnings = warnings.catch_warnings()
        self._warnings.__enter__()
        # lerobot's statistics of the boolean observation.valid (a histogram of 0/1: right)
        warnings.filterwarnings(
            "ignore", message="Converting input from bool", category=RuntimeWarning
        )

    def __exit__(self, *exc: object) -> None:
        import av
        import datasets

        self._warnings.__exit__(None, None, None)
        if self._svt is None:
            os.environ.pop("SVT_LOG", None)
        else:
            os.environ["SVT_LOG"] = self._svt
        av.logging.set_level(self._av_level)
        av.logging.set_libav_level(av.logging.INFO)  # FFmpeg's default
        if self._bars:
            datasets.utils.logging.enable_progress_bar()
