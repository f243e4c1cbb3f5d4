"""Robot data from one human demonstration: randomised layouts run on the robot, the successful
runs written as the episodes of one LeRobot dataset (``lfd export robot-data``, docs/export.md).

:func:`export_robot_data` takes a recording and its task program (the ground-truth labels, or
the segmentation's), draws ``layouts`` randomised layouts (:func:`lfd.reproduce.random_layouts`:
every object shifted and turned, reachable, collision-free; the same layouts as ``lfd reproduce
--randomise N --seed S`` drawn for the one mode), runs the program on the robot in each
(:func:`lfd.reproduce.reproduce`), keeps the successful runs and writes each as a robot episode
(:mod:`.robot_episode`: joint positions, commanded joints, object poses, rendered images, the
skill of every frame as the subtask). A two-hand recording on a two-arm robot (``robot``
``aloha``): each hand's lane on the arm of its side, both arms' joints in the state and action
(:mod:`.robot_sources` says where the episodes come from: one arm or two).

Resumable: the work lives in ``.<name>.robot-data`` beside the output until the dataset is
written: ``state.json`` (the settings, every tried layout's outcome) and one ``.npz`` per
successful layout, each written atomically as its layout finishes. Run again with the same
settings, an interrupted export skips the layouts it finished; the dataset itself is written at
the end, atomically (:func:`lfd.outputs.atomic_directory`), with ``meta/lfd_layouts.json``: every
tried layout, whether it succeeded and why not, and the yield.
"""

from __future__ import annotations

import json
import os
import shutil
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import DemonstrationError, UsageError
from .robot_episode import IMAGE_PREFIX, Camera, RobotEpisode, check_fps, check_image_size
from .robot_sources import OneArm, TwoArms, robot_source
from .writer import DEFAULT_VCODEC, VCODECS

LAYOUTS_PATH = "meta/lfd_layouts.json"
"""Every tried layout and the yield, in the dataset."""
WORK_SUFFIX = ".robot-data"
STATE_FORMAT = 2
"""2: an episode's skill and subtask columns by name (one arm or two)."""
ROBOT_LABELS: tuple[str, ...] = ("ground-truth", "segment")
DEFAULT_FPS = 10
DEFAULT_IMAGE_SIZE = (160, 120)


@dataclass
class LayoutResult:
    """One tried layout: did the robot achieve the task there, and if not, why not."""

    index: int
    displace: dict[str, list[float]]
    success: bool
    failures: list[str]
    seconds: float
    frames: int = 0
    error: str | None = None
    resumed: bool = False
    """Finished by an earlier, interrupted run (not redone)."""

    def to_json(self) -> dict[str, Any]:
        return {
            "index": self.index,
            "displace": self.displace,
            "success": self.success,
            "failures": self.failures,
            "error": self.error,
            "frames": self.frames,
            "seconds": self.seconds,
        }

    @classmethod
    def from_json(cls, doc: dict[str, Any]) -> LayoutResult:
        """What :meth:`to_json` wrote; a malformed entry raises KeyError, TypeError,
        ValueError or AttributeError."""
        if not isinstance(doc.get("index"), int) or doc["index"] < 0:
            raise ValueError(f"index must be an integer >= 0, got {doc.get('index')!r}")
        if not isinstance(doc["failures"], list):
            raise ValueError(f"failures must be a list, got {doc['failures']!r}")
        return cls(
            int(doc["index"]),
            {k: [float(x) for x in v] for k, v in doc["displace"].items()},
            bool(doc["success"]),
            list(doc["failures"]),
            float(doc["seconds"]),
            int(doc["frames"]),
            doc.get("error"),
            resumed=True,
        )


@dataclass
class RobotDataReport:
    """What :func:`export_robot_data` did."""

    root: Path
    repo_id: str
    layouts: list[LayoutResult] = field(default_factory=list)
    write_seconds: float = 0.0
    seconds: float = 0.0

    @property
    def succeeded(self) -> list[LayoutResult]:
        return [r for r in self.layouts if r.success]

    @property
    def yield_(self) -> float:
        """Successful layouts / tried layouts."""
        return len(self.succeeded) / max(len(self.layouts), 1)

    @property
    def size_bytes(self) -> int:
        """The dataset's size on disk."""
        return sum(f.stat().st_size for f in self.root.rglob("*") if f.is_file())

    def to_json(self) -> dict[str, Any]:
        return {
            "tried": len(self.layouts),
            "succeeded": len(self.succeeded),
            "yield": self.yield_,
            "layouts": [r.to_json() for r in self.layouts],
        }


def work_dir(output: Path) -> Path:
    """Where an export to ``output`` keeps its finished layouts until the dataset is written."""
    return output.parent / f".{output.name}{WORK_SUFFIX}"


def _check(layouts: int, mode: str, labels: str, vcodec: str) -> None:
    from ..reproduce import MODES
    from ..reproduce.randomise import check_layout_count

    try:
        check_layout_count(layouts)
    except UsageError as err:
        raise UsageError(str(err).replace("--randomise", "--layouts", 1)) from None
    if mode not in MODES or mode == "replay":
        raise UsageError(f"--mode {mode}: choose skills or dmp (replay is not re-grounded)")
    if labels not in ROBOT_LABELS:
        raise UsageError(f"--labels must be one of {', '.join(ROBOT_LABELS)}, got {labels!r}")
    if vcodec not in VCODECS:
        raise UsageError(f"--vcodec must be one of {', '.join(VCODECS)}, got {vcodec!r}")


def export_robot_data(
    recording: str | os.PathLike[str],
    output: str | os.PathLike[str],
    *,
    layouts: int,
    seed: int = 0,
    mode: str = "skills",
    labels: str = "ground-truth",
    fps: int = DEFAULT_FPS,
    image_size: tuple[int, int] = DEFAULT_IMAGE_SIZE,
    vcodec: str = DEFAULT_VCODEC,
    repo_id: str | None = None,
    overwrite: bool = False,
    max_shift: float | None = None,
    max_turn_deg: float | None = None,
    robot: str = "kuka_lwr4",
    progress: Callable[[LayoutResult, int], None] | None = None,
) -> RobotDataReport:
    """Robot episodes from one human demonstration, as one LeRobot dataset at ``output``.

    Parameters
    ----------
    recording : path
        A one-hand recording (``.mcap``), or a two-hand one with a two-arm ``robot``.
    layouts : int
        How many randomised layouts to try (1-100000); the successful runs are the episodes.
    seed : int
        The layouts' seed (``lfd reproduce --randomise N --seed S``).
    mode : {"skills", "dmp"}
    labels : {"ground-truth", "segment"}
        The task program: the recording's labels, or lfd's segmentation of it.
    fps : int
        Frames per second (a divisor of the 100 Hz control ticks).
    image_size : (width, height)
        The rendered camera images (``observation.images.table``).
    vcodec, repo_id, overwrite
        As :func:`~.lerobot.export_lerobot`'s.
    max_shift, max_turn_deg
        How far the layouts move and turn the objects (default: ``lfd reproduce``'s).
    robot : str
        The arm (:data:`lfd.reproduce.ROBOTS`; ``lfd reproduce --robot``): its joints are the
        state and action, ``robot_type`` is ``lfd_<robot>``. A two-arm robot
        (:data:`lfd.reproduce.robots.TWO_ARM_ROBOTS`, ``aloha``) takes a two-hand recording
        and its ground-truth labels: both arms' joints, each arm's skill columns.
    progress : callable (layout result, number of layouts)
        Called after every layout, in order (also for those an earlier run finished).

    Raises
    ------
    UsageError
        Bad settings or output, a two-hand recording on one arm or a one-hand recording on
        two, no reachable layout, an interrupted export with other settings waiting in
        :func:`work_dir`.
    DemonstrationError
        No labels, no layout succeeded (the layouts stay in :func:`work_dir`).
    """
    from ..inputs import check_input_file
    from ..io.reads import read_paths
    from ..outputs import check_output_dir
    from ..reproduce import MAX_SHIFT, MAX_TURN_DEG
    from ..reproduce.robots import any_robot
    from .lerobot import not_a_dataset
    from .writer import import_lerobot

    _check(layouts, mode, labels, vcodec)
    arm = any_robot(robot)  # an unknown robot, or its package missing: one line, first
    check_fps(fps)
    size = check_image_size(*image_size)
    rec = Path(recording)
    check_input_file(rec, "recording")
    if not rec.is_file():
        raise UsageError(f"{rec} does not exist; give a recording")
    replace: dict[str, Any] = {"overwrite": overwrite, "replaceable": not_a_dataset}
    dest = check_output_dir(output, inputs=read_paths([rec]), parents=True, **replace)
    repo = repo_id or f"lfd/{dest.resolve().name}"
    if repo.count("/") != 1 or not all(repo.split("/")):
        raise UsageError(f"--repo-id must look like OWNER/NAME, got {repo!r}")
    start = time.perf_counter()
    source = robot_source(rec, labels, arm)
    settings = {
        "recording": str(rec.resolve()),
        "recording_bytes": rec.stat().st_size,
        "seed": seed,
        "mode": mode,
        "labels": labels,
        "fps": fps,
        "image_size": list(size),
        "max_shift_m": MAX_SHIFT if max_shift is None else max_shift,
        "max_turn_deg": MAX_TURN_DEG if max_turn_deg is None else max_turn_deg,
        "robot": arm.name,
    }
    work = _Work(work_dir(dest), settings)  # a damaged one refused before any work
    from .._extras import require
    from ..reproduce import SIM_MODULES

    # what every layout runs on, checked once (a missing module is not a failed layout)
    require("sim", SIM_MODULES + (("movement_primitives",) if mode == "dmp" else ()), who=__name__)
    source.check(rec, mode)
    import_lerobot()
    camera = source.camera(size)
    report = RobotDataReport(dest, repo)
    report.layouts = _run_layouts(source, layouts, settings, camera, work, progress)
    if not report.succeeded:
        kinds = sorted({f for r in report.layouts for f in r.failures})
        raise DemonstrationError(
            f"none of the {layouts} layouts succeeded ({'; '.join(kinds)[:300]}); their "
            f"outcomes are in {work.path / 'state.json'}"
        )
    t = time.perf_counter()
    _write_dataset(dest, repo, report, work, camera, vcodec, overwrite)
    report.write_seconds = time.perf_counter() - t
    shutil.rmtree(work.path, ignore_errors=True)
    report.seconds = time.perf_counter() - start
    return report


class _Work:
    """The work directory of a resumable export: its settings and finished layouts.

    A damaged one (``state.json`` not what :meth:`finish` writes, a finished layout's ``.npz``
    unreadable) is refused up front, before any layout is run, and never deleted: the user
    removes it (:func:`_damaged`)."""

    def __init__(self, path: Path, settings: dict[str, Any]) -> None:
        self.path = path
        self.settings = settings
        self.done: dict[int, LayoutResult] = {}
        if path.exists() and not path.is_dir():
            raise UsageError(
                f"{path}, where an interrupted export keeps its work, is not a directory; "
                "remove it to start again"
            )
        state = path / "state.json"
        if not os.path.lexists(state):
            return
        doc = _read_state(state)
        if doc.get("format") != STATE_FORMAT or doc.get("settings") != settings:
            raise UsageError(
                f"{path} holds an interrupted export with other settings "
                f"({_differs(doc.get('settings') or {}, settings)}); rerun it with the same "
                "options, or remove that directory to start again"
            )
        for k, item in enumerate(doc["layouts"]):
            try:
                r = LayoutResult.from_json(item)
            except (KeyError, TypeError, ValueError, AttributeError) as err:
                raise _damaged(path, f"state.json: layouts[{k}] is malformed ({err})") from None
            episode = self.episode_path(r.index)
            if r.success and os.path.lexists(episode):
                problem = RobotEpisode.problem(episode)
                if problem is not None:
                    raise _damaged(path, f"{episode.name}: {problem}")
            if not r.success or episode.is_file():
                self.done[r.index] = r

    def episode_path(self, index: int) -> Path:
        return self.path / f"layout_{index:06d}.npz"

    def finish(self, result: LayoutResult, episode: RobotEpisode | None) -> None:
        """Keep a layout's episode and outcome (each file written atomically, the episode
        first: a layout is finished once the state names it)."""
        from ..outputs import atomic_output, atomic_write_text

        self.path.mkdir(parents=True, exist_ok=True)  # -o a/b/ds: a/b may not exist yet
        if episode is not None:
            with atomic_output(self.episode_path(result.index)) as tmp, open(tmp, "wb") as f:
                episode.save(f)
        self.done[result.index] = result
        doc = {
            "format": STATE_FORMAT,
            "settings": self.settings,
            "layouts": [self.done[i].to_json() for i in sorted(self.done)],
        }
        atomic_write_text(self.path / "state.json", json.dumps(doc, indent=1) + "\n")


def _damaged(path: Path, why: str) -> UsageError:
    """The error of a damaged work directory ``path``: what is wrong, and what to do."""
    return UsageError(
        f"{path} holds a damaged interrupted export ({' '.join(why.split())[:200]}); remove that "
        "directory to start again"
    )


def _read_state(state: Path) -> dict[str, Any]:
    """``state.json`` of a work directory, checked to be what :meth:`_Work.finish` writes (an
    object with ``format``, ``settings`` and a list of ``layouts``), else :func:`_damaged`."""
    try:
        doc = json.loads(state.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as err:
        raise _damaged(state.parent, f"state.json is not readable JSON: {err}") from None
    if not (
        isinstance(doc, dict)
        and {"format", "settings", "layouts"} <= set(doc)
        and isinstance(doc["settings"], dict)
        and isinstance(doc["layouts"], list)
    ):
        raise _damaged(state.parent, "state.json is not an export state")
    return doc


def _differs(old: dict[str, Any], new: dict[str, Any]) -> str:
    keys = [k for k in new if old.get(k) != new[k]]
    return ", ".join(f"{k} {old.get(k)} -> {new[k]}" for k in keys) or "another format"


def _run_layouts(
    source: OneArm | TwoArms,
    n: int,
    settings: dict[str, Any],
    camera: Camera,
    work: _Work,
    progress: Callable[[LayoutResult, int], None] | None,
) -> list[LayoutResult]:
    """Every layout's outcome, running those ``work`` has not finished."""
    out: list[LayoutResult] = []
    t = time.perf_counter()
    for lay in _layouts(source.layouts(n, settings)):
        displace = {k: [float(x) for x in v] for k, v in lay.displace.items()}
        done = work.done.get(lay.index)
        if done is not None and done.displace != displace:
            raise UsageError(
                f"{work.path}: layout {lay.index} differs from the one drawn before (the "
                "recording changed?); remove that directory to start again"
            )
        if done is None:
            done = _run_one(source, lay, camera, work, time.perf_counter() - t)
        out.append(done)
        if progress is not None:
            progress(done, n)
        t = time.perf_counter()
    return out


def _layouts(draws: Any) -> Any:
    """The drawn layouts; a layout that cannot be drawn is refused as ``--layouts``'."""
    try:
        yield from draws
    except UsageError as err:
        raise UsageError(str(err).replace("--randomise", "--layouts", 1)) from None


def _run_one(
    source: OneArm | TwoArms, lay: Any, camera: Camera, work: _Work, drawn_s: float
) -> LayoutResult:
    """Run one layout, keep its episode when it succeeded."""
    from ..errors import LfdError

    t = time.perf_counter()
    displace = {k: [float(x) for x in v] for k, v in lay.displace.items()}
    try:
        run = source.run(lay.displace, work.settings["mode"])
    except LfdError as err:
        msg = " ".join(str(err).split())
        result = LayoutResult(lay.index, displace, False, [msg], 0.0, error=msg)
        work.finish(result, None)
        return result
    episode = source.episode(run, int(work.settings["fps"]), camera) if run.success else None
    frames = len(episode) if episode is not None else 0
    failures = [] if run.success else source.failures(run)
    result = LayoutResult(lay.index, displace, run.success, failures, 0.0, frames)
    result.seconds = round(drawn_s + time.perf_counter() - t, 3)
    work.finish(result, episode)
    return result


def _write_dataset(
    dest: Path,
    repo: str,
    report: RobotDataReport,
    work: _Work,
    camera: Camera,
    vcodec: str,
    overwrite: bool,
) -> None:
    """The successful layouts' episodes as one dataset, written atomically at ``dest``."""
    from ..outputs import atomic_directory, created_parents, signals_held
    from .lerobot import not_a_dataset

    replace: dict[str, Any] = {"overwrite": overwrite, "replaceable": not_a_dataset}
    with created_parents(dest), atomic_directory(dest, **replace) as root:
        writer = RobotWriter(root, repo, camera.name, vcodec=vcodec, robot=work.settings["robot"])
        try:
            for r in report.succeeded:
                writer.add(_episode(work, r.index), r.index)
            writer.close()
        except BaseException:
            with signals_held():
                writer.abort()
            raise
        doc = {
            "settings": work.settings,
            "camera": camera.__dict__,
            **report.to_json(),
            "episodes": [writer.layouts[e] for e in sorted(writer.layouts)],
        }
        (root / LAYOUTS_PATH).write_text(json.dumps(doc, indent=1) + "\n")


def _episode(work: _Work, index: int) -> RobotEpisode:
    """A finished layout's episode; one damaged past the up-front check (a bad array inside a
    readable archive) is refused as :func:`_damaged`."""
    import zipfile

    path = work.episode_path(index)
    try:
        return RobotEpisode.load(path)
    except (OSError, EOFError, KeyError, ValueError, zipfile.BadZipFile) as err:
        raise _damaged(work.path, f"{path.name}: not a readable episode ({err})") from None


class RobotWriter:
    """A LeRobot dataset of robot episodes, written episode by episode (lerobot's API, as
    :class:`~.writer.LeRobotWriter`); :meth:`close` finalises it and writes the subtask
    table and the per-episode skill annotations."""

    def __init__(
        self, root: Path, repo_id: str, camera: str, *, vcodec: str, robot: str = "kuka_lwr4"
    ) -> None:
        self.root, self.repo_id, self.camera, self.vcodec = root, repo_id, camera, vcodec
        self.robot_type = f"lfd_{robot}"
        self._dataset: Any = None
        self.subtasks: dict[str, int] = {}
        self._annotations: dict[int, dict[str, list[Any]]] = {}
        self.layouts: dict[int, int] = {}
        """Episode index -> layout index."""

    def add(self, ep: RobotEpisode, layout: int) -> int:
        from .writer import _quiet, import_lerobot

        if self._dataset is None:
            self._dataset = import_lerobot().create(
                self.repo_id,
                ep.fps,
                ep.features(self.camera),
                root=self.root,
                robot_type=self.robot_type,
                use_videos=True,
                vcodec=self.vcodec,
                video_backend="pyav",
            )
        ds = self._dataset
        for names in ep.subtasks.values():
            for name in names:
                self.subtasks.setdefault(name, len(self.subtasks))
        image = IMAGE_PREFIX + self.camera
        try:
            for i in range(len(ep)):
                frame: dict[str, Any] = {
                    "observation.state": ep.state[i],
                    "action": ep.action[i],
                    "observation.environment_state": ep.environment[i],
                    image: ep.images[i],
                    "task": ep.task,
                }
                for key, column in ep.labels.items():
                    frame[key] = column[i : i + 1]
                for key, names in ep.subtasks.items():
                    frame[key] = np.array([self.subtasks[names[i]]], dtype=np.int64)
                ds.add_frame(frame)
            for key in ep.scalar_keys:  # scalars: as writer's
                ds.episode_buffer[key] = [np.int64(v[0]) for v in ds.episode_buffer[key]]
        except BaseException:
            ds.clear_episode_buffer()
            raise
        index = int(ds.meta.total_episodes)
        with _quiet():
            ds.save_episode()
        self._annotations[index] = ep.annotation()
        self.layouts[index] = layout
        return index

    def abort(self) -> None:
        from .writer import LeRobotWriter

        LeRobotWriter.abort(self)  # type: ignore[arg-type]

    def close(self) -> None:
        from .writer import _quiet, remove_empty_images, write_annotations, write_subtasks

        if self._dataset is None:
            return
        with _quiet():
            self._dataset.finalize()
        write_subtasks(self.root, list(self.subtasks))
        write_annotations(self.root, self._annotations)
        remove_empty_images(self.root)
