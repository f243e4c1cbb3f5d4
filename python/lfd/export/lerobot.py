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
:func:`~.episode.prepare_episode` (load, preprocess, labels; no lerobot: :mod:`.episode`) and
:meth:`~.writer.LeRobotWriter.add` (sequential: a dataset has one writer; :mod:`.writer`);
:func:`export_recording` does both, :func:`export_lerobot` every recording (this module).
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..errors import LfdError, UsageError
from .episode import (
    COLOR_KEY,
    LABEL_SOURCES,
    NO_SKILL,
    STATE_NAMES,
    Episode,
    LabelSource,
    frame_labels,
    prepare_episode,
    subtask_name,
)
from .writer import (
    DEFAULT_VCODEC,
    INSTALL_HINT,
    LEROBOT_VERSION,
    PROGRAM_FORMAT,
    PROGRAM_PATH,
    SUBTASKS_PATH,
    VCODECS,
    LeRobotWriter,
    import_lerobot,
)

if TYPE_CHECKING:
    from ..segmentation import Method

__all__ = [
    "COLOR_KEY",
    "DEFAULT_VCODEC",
    "INSTALL_HINT",
    "LABEL_SOURCES",
    "LEROBOT_VERSION",
    "NO_SKILL",
    "PROGRAM_FORMAT",
    "PROGRAM_PATH",
    "STATE_NAMES",
    "SUBTASKS_PATH",
    "VCODECS",
    "Episode",
    "ExportReport",
    "LabelSource",
    "LeRobotWriter",
    "RecordingResult",
    "export_lerobot",
    "export_recording",
    "frame_labels",
    "import_lerobot",
    "prepare_episode",
    "subtask_name",
]


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
    method: Method | None = None,
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
        ep = prepare_episode(recording, labels=labels, method=method, video=video)
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
    method: Method | str | os.PathLike[str] | None = None,
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
    labels, method, templates, video
        See :func:`prepare_episode`: the method that labels recordings without ground truth
        (``--labels segment``), a :class:`~lfd.segmentation.Method`, a name or a template
        file (read once, here; the output may not replace it), or ``templates``.
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
    if isinstance(method, (str, os.PathLike)) and str(method) not in ("default", "paper"):
        reads.append(method)
    from ..segmentation import resolve_method

    chosen = resolve_method(templates, method)  # read and checked once, here
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
    prepared = _prepare_all(paths, labels, chosen, video, jobs, ray_address) if parallel else None
    with created_parents(dest), atomic_directory(dest, **replace) as root:
        writer = LeRobotWriter(root, repo, vcodec=vcodec)
        try:
            for i, path in enumerate(paths):
                if prepared is None:
                    result = export_recording(
                        writer, path, labels=labels, method=chosen, video=video
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


def _prepare_all(
    paths: list[Path],
    labels: LabelSource,
    method: Method,
    video: bool,
    jobs: int | None,
    ray_address: str | None,
) -> list[Any]:
    """Every recording's episode (or its error), prepared in parallel, in input order (the
    method goes to the workers pickled, :meth:`~lfd.segmentation.Method.portable`)."""
    from functools import partial

    from ..batch import run_batch

    task = partial(prepare_episode, labels=labels, method=method, video=video)
    return run_batch(task, [str(p) for p in paths], jobs=jobs, ray_address=ray_address)


def _add_prepared(writer: LeRobotWriter, where: str, res: Any) -> RecordingResult:
    """Write one prepared episode (a :class:`lfd.batch.ItemResult`) as :func:`export_recording`
    does."""
    if not res.ok:
        return RecordingResult(where, error=" ".join(str(res.error).split()), seconds=res.seconds)
    return _write_episode(writer, where, res.value, res.seconds)
