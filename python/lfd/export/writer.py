"""The LeRobot dataset writer: prepared episodes written through lerobot's own API.

``LeRobotDataset.create``, ``add_frame``, ``save_episode``, ``finalize`` (tested with lerobot
0.4.4, dataset format v3.0), so the layout is right by construction; one writer per dataset,
episodes added one after the other. Beside lerobot's files it writes the subtask table, the
task programs (``meta/lfd_program.json``) and the skill segments as per-episode annotations.
"""

from __future__ import annotations

import json
import os
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import DemonstrationError
from ..skills import SKILLS
from .episode import COLOR_KEY, NO_SKILL, SCALAR_KEYS, Episode

LEROBOT_VERSION = "0.4.4"
"""The lerobot version the export is tested with."""
INSTALL_HINT = "pip install 'lfd[lerobot]' && pip install --no-deps lerobot==0.4.4"
PROGRAM_PATH = "meta/lfd_program.json"
SUBTASKS_PATH = "meta/subtasks.parquet"
"""The table lerobot 0.4.4 reads for ``subtask_index`` (``LeRobotDataset.__getitem__``)."""
PROGRAM_FORMAT = 1
DEFAULT_VCODEC = "libsvtav1"
"""lerobot's default codec (AV1, the smallest files)."""
VCODECS: tuple[str, ...] = ("libsvtav1", "h264")
"""The software codecs lerobot accepts that encode quietly (its ``hevc``, x265, prints its
settings to stderr and is the slowest)."""


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
        schema = (ep.fps, tuple(ep.object_names), shape, tuple(ep.lanes))
        if self._schema is None:
            self._schema = schema
            return
        fps, names, image, lanes = self._schema
        if tuple(ep.lanes) != lanes:
            have = f"{len(ep.lanes) or 1} hand(s)"
            raise DemonstrationError(
                f"{ep.recording}: {have}, the dataset's episodes have {len(lanes) or 1}; export "
                "one-hand and two-hand recordings into different datasets"
            )
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
        for name in [*ep.subtask, *(n for lane in ep.lanes.values() for n in lane.subtask)]:
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
                for side, lane in ep.lanes.items():
                    if lane.pose is not None:
                        frame[f"observation.state.{side}"] = lane.pose.state[i]
                        frame[f"observation.hand_keypoints.{side}"] = lane.pose.keypoints[i]
                        frame[f"observation.valid.{side}"] = lane.pose.valid[i : i + 1]
                        frame[f"action.{side}"] = lane.pose.action[i]
                    frame[f"skill_index.{side}"] = lane.skill_index[i : i + 1]
                    frame[f"object_index.{side}"] = lane.object_index[i : i + 1]
                    frame[f"subtask_index.{side}"] = np.array(
                        [self.subtasks[lane.subtask[i]]], dtype=np.int64
                    )
                if ep.color is not None and ep.color_index is not None:
                    frame[COLOR_KEY] = ep.color[ep.color_index[i]]
                ds.add_frame(frame)
            # lerobot keeps a (1,)-shaped feature as a scalar column, and its own (frame_index,
            # ...) as scalars in the buffer; ours are validated as (1,) arrays above but must be
            # scalars too, as numpy >= 2.4 no longer converts a (1,) array to int
            for key in [*SCALAR_KEYS, *(f"{k}.{s}" for s in ep.lanes for k in SCALAR_KEYS)]:
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
        from .._version import __version__

        with _quiet():
            self._dataset.finalize()
        write_subtasks(self.root, list(self.subtasks))
        doc = {
            "format": PROGRAM_FORMAT,
            "lfd_version": __version__,
            "skills": list(SKILLS),
            "no_skill": NO_SKILL,
            "episodes": self.episodes,
        }
        (self.root / PROGRAM_PATH).write_text(json.dumps(doc, indent=2) + "\n")
        write_annotations(self.root, self._annotations)
        remove_empty_images(self.root)


def remove_empty_images(root: Path) -> None:
    """Remove ``images/`` of a finished video dataset when nothing but empty directories is
    left in it: lerobot writes each frame there as PNG until the episode is encoded, then
    deletes the frames but keeps ``images/<camera>/``. The dataset is read from ``videos/``
    (lerobot's own recorder removes the empty ``images/`` too); a PNG left there is kept."""
    images = root / "images"
    inside = list(images.rglob("*")) if images.is_dir() and not images.is_symlink() else None
    if inside is None or any(p.is_symlink() or not p.is_dir() for p in inside):
        return
    for d in sorted(inside, key=lambda p: len(p.parts), reverse=True):
        d.rmdir()
    images.rmdir()


def write_subtasks(root: Path, names: list[str]) -> None:
    """The subtask table lerobot reads for ``subtask_index`` (:data:`SUBTASKS_PATH`): row
    ``names[i]`` has index ``i``."""
    import pandas as pd

    table = pd.DataFrame({"subtask_index": range(len(names))}, index=names)
    table.to_parquet(root / SUBTASKS_PATH)


def write_annotations(root: Path, annotations: dict[int, dict[str, list[Any]]]) -> None:
    """The skill segments as per-episode columns of ``meta/episodes``: ``sparse_subtask_*``
    and the unprefixed ``subtask_*``, as lerobot's SARM annotation tool writes them (its
    reward model reads them); lerobot's loader keeps the extra columns. ``annotations``:
    per episode index, :meth:`~.episode.Episode.annotation`."""
    import pandas as pd

    for path in sorted((root / "meta" / "episodes").glob("chunk-*/file-*.parquet")):
        table = pd.read_parquet(path)
        for key in next(iter(annotations.values())):
            for column in (f"sparse_{key}", key):
                table[column] = [annotations[int(e)][key] for e in table["episode_index"]]
        table.to_parquet(path, engine="pyarrow", compression="snappy")


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
