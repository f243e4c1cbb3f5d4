"""Every command line and Python snippet in the README and the docs works as shown.

The lines are read from the documents themselves (fenced code blocks), so a changed or added
line is tested without touching this file: one test per command line, ``DOC:LINE`` in its id.
A line runs exactly as written, in a scratch directory per document holding a copy of
``recordings/`` (so regenerating recordings cannot touch the shipped ones), after the lines
before it in the same document (run first if the selection left them out). The few lines that
cannot run as written in a test are listed below with the reason and what runs instead; a listed
line that no longer appears in the documents fails the test, so the list cannot go stale.

Lines that take long (regenerating recordings or templates, driving the robot, rendering,
training) are listed in :data:`SLOW` and marked ``slow``: the default run replays the quick
lines of every document, ``-m slow`` the rest. A quick line never needs a slow line's output.
Where a document shows what a line gives (a skill sequence, a figure, a file's content),
:data:`CHECKS` asserts it, quoting the document; a quote the document no longer holds fails.
"""

from __future__ import annotations

import json
import os
import re
import shlex
import shutil
import signal
import subprocess
import sys
import textwrap
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import _paths
import pytest
from _signals import ctrl_c_as_from_a_terminal

ROOT = _paths.ROOT
DOCUMENTS = [
    "README.md",
    *sorted(f"docs/{p.name}" for p in (ROOT / "docs").glob("*.md")),
    "recordings/README.md",
]
COMMAND_PREFIXES = ("lfd ", "MUJOCO_GL=egl lfd ", "pip ", "python", "make ")

NOT_RUN: dict[str, str] = {
    # prefix of a command line -> why this test does not run it
    "pip install": "installation: tests/e2e/test_fresh_install.py installs into a fresh venv",
    "python3 -m pytest": "the test suite itself",
    "make ": "developer shortcuts for the install, lint and test commands (make check is CI)",
    "python benches/": "benchmarks: minutes to hours; their figures are in the README",
    "lfd record --source camera:0": "needs a camera: the camera source is tested with an RGB-D "
    "reader plug-in in tests/e2e/test_record_realhands.py",
    "lfd record --source video:demo.mp4": "needs a video of a demonstration: the video source "
    "runs on a video of real-hand frames in tests/e2e/test_record_realhands.py",
    "lfd segment webcam.mcap": "needs webcam.mcap from a camera or a video (the lines above)",
    "python docs/examples/realsense_reader.py": "needs a RealSense (the module is compiled below)",
    "lfd perception calibrate board": "needs photos or a video of a printed board: the command "
    "runs on views rendered through a known camera in tests/unit/perception/test_calibration.py",
    "lfd segment /shared/": "needs a Ray cluster (docs/batch.md); a local Ray runs in tests/unit/segmentation/test_batch.py",
    "lfd templates train /shared/": "needs a Ray cluster (docs/batch.md)",
}

RUN_AS: dict[str, tuple[str, str]] = {
    # exact command line (without its comment) -> (what runs instead, why)
    "lfd perception train -o hand.pt --samples 30000 --epochs 40 --data hand_train.npz": (
        "lfd perception train -o hand.pt --samples 80 --epochs 1 --val-samples 10 "
        "--data hand_train.npz",
        "the documented run trains for hours; the same command at a tiny size",
    ),
    "lfd perception train -o hand.pt --epochs 40 --resume": (
        "lfd perception train -o hand.pt --samples 80 --epochs 1 --val-samples 10 "
        "--data hand_train.npz --resume",
        "resumes the tiny run above from its checkpoint (same epochs and data, as documented)",
    ),
    "lfd perception train -o hand2.pt --init hand.pt --samples 3000 --epochs 10": (
        "lfd perception train -o hand2.pt --init hand.pt --samples 80 --epochs 1 "
        "--val-samples 10 --data hand_train.npz",
        "fine-tuning at a tiny size",
    ),
    "lfd templates train recordings/templates recordings/templates/natural -o "
    "python/lfd/data/templates.json": (
        "lfd templates train recordings/templates recordings/templates/natural -o templates.json",
        "the documented run rewrites the package's shipped templates; the test writes a copy",
    ),
    "lfd perception hands photo.jpg --json hands.json": (
        f"lfd perception hands {ROOT.parent / 'shared' / 'realhands' / 'tfjs_hands.jpg'} "
        "--json hands.json",
        "a real photograph of hands from ../shared/realhands",
    ),
    "lfd perception eval --hand-model hand.pt": (
        "lfd perception eval --hand-model hand.pt --samples 20",
        "20 held-out renders instead of 300",
    ),
}

SHARED_DATA: dict[str, Path] = {
    "lfd perception hands photo.jpg --json hands.json": ROOT.parent
    / "shared"
    / "realhands"
    / "tfjs_hands.jpg",
}
"""Lines that read real data beside the repository (never shipped): skipped where it is absent,
and not run before the lines after them (which do not need their output)."""


def _data_missing(line: Line) -> bool:
    need = SHARED_DATA.get(line.command)
    return need is not None and not need.exists()


HARDWARE_MODULES = ("pyrealsense2",)
"""Snippets that drive a camera through its vendor SDK are only compiled."""

VIEWER_LINES = ("--rerun-serve", "--rerun ")
"""Lines that open a viewer keep running until Ctrl+C: they must do their work, keep serving,
and stop cleanly on SIGINT."""


@dataclass
class Line:
    document: str
    lineno: int
    command: str

    def __str__(self) -> str:
        return f"{self.document}:{self.lineno}: {self.command}"


def _strip_comment(line: str) -> str:
    """The command without a trailing ``# comment`` (a # after whitespace, outside quotes)."""
    quote = None
    for i, ch in enumerate(line):
        if ch in "'\"" and quote in (None, ch):
            quote = None if quote == ch else ch
        elif ch == "#" and quote is None and (i == 0 or line[i - 1].isspace()):
            return line[:i].rstrip()
    return line.rstrip()


def _documents() -> list[Path]:
    return [ROOT / name for name in DOCUMENTS]


def code_blocks(path: Path) -> list[tuple[str, int, list[str]]]:
    """(language, first line number, lines) of every fenced block."""
    blocks, lang, start, body = [], None, 0, []
    for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        m = re.match(r"^\s*```(\w*)", line)
        if m and lang is None:
            lang, start, body = m.group(1), n + 1, []
        elif m:
            blocks.append((lang, start, body))
            lang = None
        elif lang is not None:
            body.append(line)
    return blocks


def command_lines(path: Path) -> list[Line]:
    out = []
    for lang, start, body in code_blocks(path):
        if lang not in ("", "bash", "sh", "console"):
            continue
        for k, raw in enumerate(body):
            cmd = _strip_comment(raw.strip())
            if cmd.startswith(COMMAND_PREFIXES):
                out.append(Line(str(path.relative_to(ROOT)), start + k, cmd))
    return out


def python_snippets(path: Path) -> list[tuple[int, str]]:
    return [(start, "\n".join(body)) for lang, start, body in code_blocks(path) if lang == "python"]


def test_every_listed_line_still_appears_in_the_documents() -> None:
    commands = {ln.command for p in _documents() for ln in command_lines(p)}
    stale = [c for c in RUN_AS if c not in commands]
    assert not stale, f"RUN_AS lists lines no document has any more: {stale}"
    assert any(c.startswith("lfd segment") for c in commands)


def _scratch(tmp_path: Path) -> Path:
    work = tmp_path / "work"
    work.mkdir()
    shutil.copytree(ROOT / "recordings", work / "recordings")
    return work


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env.update(MUJOCO_GL=env.get("MUJOCO_GL", "egl"), RERUN_TELEMETRY="0", PYTHONUNBUFFERED="1")
    env.pop("DISPLAY", None)  # the viewer lines serve the web viewer, as on a headless machine
    return env


def _run(args: list[str], cwd: Path, timeout: float) -> subprocess.CompletedProcess[str]:
    """Run a documented command or snippet as a user would, output captured."""
    return subprocess.run(
        args, cwd=cwd, env=_env(), capture_output=True, text=True, timeout=timeout, check=False
    )


def _run_viewer_line(cmd: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    """Start a viewer line, let it do its work, then stop it with SIGINT as a user would.

    Its stdin is a terminal, as for a user at a shell (a command whose stdin is not a terminal
    does not keep serving)."""
    import pty

    _, terminal = pty.openpty()
    proc = subprocess.Popen(
        ["bash", "-c", f"exec {cmd}"],
        cwd=cwd,
        env=_env(),
        stdin=terminal,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        preexec_fn=ctrl_c_as_from_a_terminal,
    )
    deadline = time.monotonic() + 300
    try:
        while time.monotonic() < deadline and proc.poll() is None:
            time.sleep(2)
            # the work is done once the command waits for the viewer: nothing left to compute
            if _idle(proc.pid):
                break
        assert proc.poll() is None, f"{cmd} stopped instead of serving"
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    assert proc.returncode in (0, 130), err
    assert "Traceback" not in err, err
    assert out.strip(), f"{cmd} printed nothing before it was stopped"
    return subprocess.CompletedProcess(cmd, proc.returncode, out, err)


def _idle(pid: int) -> bool:
    """Whether a process used (almost) no CPU over the last second."""

    def ticks() -> int:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        return int(fields[11]) + int(fields[12])

    try:
        before = ticks()
        time.sleep(1.0)
        return ticks() - before <= 2
    except (OSError, IndexError):
        return True


SLOW: dict[str, str] = {
    # prefix of a command line (as written in the document) -> why it is left to `-m slow`
    "lfd reproduce": "drives the simulated robot through a whole demonstration (~50 s a line)",
    "lfd simulate --set": "simulates a whole set of demonstrations (the eval set: 24, ~80 s)",
    "MUJOCO_GL=egl lfd simulate --set": "regenerates the shipped recordings (minutes)",
    "lfd simulate exp5 --style natural": "a 24 s natural demonstration with repeated lifts",
    "lfd segment lifts.mcap": "needs lifts.mcap from the line above",
    "lfd record --source sim": "renders every frame and runs the hand network on it",
    "MUJOCO_GL=egl lfd record --source sim": "renders and perceives exp1 (the shipped copy)",
    "lfd segment seen.mcap": "needs seen.mcap from lfd record above",
    "lfd eval eval_demos": "needs the eval set from lfd simulate --set eval",
    "lfd templates train": "trains the templates' HMMs on many recordings",
    "lfd perception ": "torch: trains or evaluates the hand network, or runs the hand models",
    "lfd export lerobot": "imports lerobot and torch and encodes a dataset",
    "MUJOCO_GL=egl lfd export robot-data": "drives the robot in every layout and encodes them",
    "lfd eval mine_": "leave-one-out: trains templates once per recording",
    "lfd segment mine_1.mcap --templates": "needs mine_templates.json from lfd templates train",
    "lfd segment recordings --jobs": "segments every shipped recording in worker processes",
    "lfd eval recordings --methods": "evaluates every shipped recording in worker processes",
}


def _slow_reason(command: str) -> str | None:
    if any(v in command + " " for v in VIEWER_LINES):
        return "serves a viewer until it is idle, then Ctrl+C"
    return next((why for prefix, why in SLOW.items() if command.startswith(prefix)), None)


def _runnable(document: str) -> list[Line]:
    return [
        ln
        for ln in command_lines(ROOT / document)
        if not any(ln.command.startswith(p) for p in NOT_RUN)
    ]


LINES = [ln for document in DOCUMENTS for ln in _runnable(document)]


@dataclass
class Replay:
    """One document's scratch directory and the lines already run in it (this session)."""

    work: Path
    ran: dict[int, subprocess.CompletedProcess[str]] = field(default_factory=dict)


@pytest.fixture(scope="session")
def replays(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Replay]:
    """document -> its replay, created on first use."""
    return {}


def _replay(
    replays: dict[str, Replay], document: str, tmp_path_factory: pytest.TempPathFactory
) -> Replay:
    if document not in replays:
        replays[document] = Replay(_scratch(tmp_path_factory.mktemp("doc")))
    return replays[document]


def _execute(
    line: Line, replay: Replay, lfd_main: Callable[..., subprocess.CompletedProcess[str]]
) -> subprocess.CompletedProcess[str]:
    """Run ``line`` (or what :data:`RUN_AS` runs instead) in the document's directory; it must
    exit 0 without a traceback. Quick plain ``lfd`` lines run in this process, the others (slow,
    or with pipes, redirections, ``&&``, environment variables) through bash as written."""
    cmd = RUN_AS.get(line.command, (line.command, ""))[0]
    if any(v in cmd + " " for v in VIEWER_LINES):
        proc = _run_viewer_line(cmd, replay.work)
    else:
        plain = re.fullmatch(r"lfd [^|&;<>$`*]*", cmd) and not _slow_reason(line.command)
        if plain:
            proc = lfd_main(shlex.split(cmd)[1:], cwd=replay.work)
        else:
            proc = _run(["bash", "-c", cmd], replay.work, timeout=900)
        assert proc.returncode == 0, f"{line}\nexit {proc.returncode}\n{proc.stderr[-3000:]}"
        assert "Traceback" not in proc.stderr, f"{line}\n{proc.stderr[-3000:]}"
    replay.ran[line.lineno] = proc
    return proc


@pytest.mark.parametrize(
    "line",
    [
        pytest.param(
            ln,
            id=f"{ln.document}:{ln.lineno}",
            marks=[pytest.mark.slow] if _slow_reason(ln.command) else [],
        )
        for ln in LINES
    ],
)
def test_command_line_works_as_shown(
    line: Line,
    replays: dict[str, Replay],
    tmp_path_factory: pytest.TempPathFactory,
    lfd_main: Callable[..., subprocess.CompletedProcess[str]],
) -> None:
    if _data_missing(line):
        pytest.skip(f"no {SHARED_DATA[line.command]}")
    replay = _replay(replays, line.document, tmp_path_factory)
    slow = _slow_reason(line.command) is not None
    for earlier in _runnable(line.document):
        if earlier.lineno >= line.lineno:
            break
        if _data_missing(earlier):
            continue
        # the lines before it, as a reader runs them; a quick line needs no slow line's output
        if earlier.lineno not in replay.ran and (slow or not _slow_reason(earlier.command)):
            _execute(earlier, replay, lfd_main)
    proc = _execute(line, replay, lfd_main)
    for shown, check in CHECKS.get(line.command, []):
        assert shown in (ROOT / line.document).read_text(encoding="utf-8"), (
            f"{line.document} no longer shows {shown!r}: update CHECKS"
        )
        check(proc, replay.work)


def test_every_slow_prefix_and_check_names_a_line() -> None:
    commands = [ln.command for ln in LINES]
    assert not [p for p in SLOW if not any(c.startswith(p) for c in commands)]
    assert not [c for c in CHECKS if c not in commands]


# --- what the documents show ---------------------------------------------------------------------
Check = Callable[[subprocess.CompletedProcess[str], Path], None]


def _printed_skills(stdout: str) -> list[str]:
    """The skill column of the first table ``lfd segment`` prints (its segmentation)."""
    skills = []
    for row in stdout.split("ground truth")[0].splitlines():
        m = re.match(r"^│\s*\d+\s*│\s*(\w+)\s*│", row)
        if m:
            skills.append(m.group(1))
    return skills


def _truth(recording: Path) -> list[str]:
    import lfd

    return lfd.load(recording).skill_sequence


def _segments_as_exp1(proc: subprocess.CompletedProcess[str], work: Path) -> None:
    """ "It segments to the same skills as exp1.mcap" (ros.md): the printed sequence is what
    lfd.segment gives on the shipped recording, which is its ground truth."""
    assert _printed_skills(proc.stdout) == _truth(ROOT / "recordings" / "exp1.mcap"), proc.stdout


def _segments_demo_exactly(proc: subprocess.CompletedProcess[str], work: Path) -> None:
    """The quickstart's demonstration: skills found, as the ground truth has them, and the Rerun
    recording written."""
    seg = json.loads((work / "seg.json").read_text())
    skills = [s["skill"] for s in seg["segments"]]
    assert skills == _printed_skills(proc.stdout) == _truth(work / "demo.mcap"), proc.stdout
    assert (work / "seg.rrd").stat().st_size > 10_000


def _info_tables(proc: subprocess.CompletedProcess[str], work: Path) -> None:
    """ "channels, rates, objects, ground-truth skills" (README)."""
    for title in ("channels", "rate Hz", "objects", "ground-truth skills"):
        assert title in proc.stdout, proc.stdout
    assert "sequence: pick_up -> move_with -> place" in proc.stdout, proc.stdout


def _greedy(proc: subprocess.CompletedProcess[str], work: Path) -> None:
    assert "greedy segmentation" in proc.stdout and _printed_skills(proc.stdout), proc.stdout


def _three_lines(proc: subprocess.CompletedProcess[str], work: Path) -> None:
    assert len(proc.stdout.splitlines()) == 3 and proc.stdout.startswith("{"), proc.stdout


def _json_segments_as_exp1(proc: subprocess.CompletedProcess[str], work: Path) -> None:
    seg = json.loads((work / "seg.json").read_text())
    assert [s["skill"] for s in seg["segments"]] == _truth(ROOT / "recordings" / "exp1.mcap")


def _batch_of_two(proc: subprocess.CompletedProcess[str], work: Path) -> None:
    """A batch's --json: one document per recording, in input order."""
    docs = json.loads((work / "batch.json").read_text())
    assert [Path(d["recording"]).name for d in docs] == ["exp1.mcap", "exp2.mcap"], docs
    assert all(d["segments"] for d in docs)


def _shown_json(document: str) -> dict:  # type: ignore[type-arg]
    """The (first) ```json block of ``document``."""
    block = next(b for lang, _, b in code_blocks(ROOT / document) if lang == "json")
    return json.loads("\n".join(block))


def _segments_as_shown(proc: subprocess.CompletedProcess[str], work: Path) -> None:
    """own-recordings.md shows mine_1.json (an example of its format: the keys, the first
    segments' skills and objects; the times are the example's own)."""
    shown = _shown_json("docs/own-recordings.md")
    got = json.loads((work / "mine_1.json").read_text())
    assert set(shown) <= set(got) and got["origin_ns"] > 0
    for want, have in zip(shown["segments"], got["segments"], strict=False):
        assert set(want) <= set(have)
        assert (have["skill"], have["object"]) == (want["skill"], want["object"]), have
        assert 0 <= have["start_s"] < have["end_s"], have


def _labelled_as_segmented(proc: subprocess.CompletedProcess[str], work: Path) -> None:
    """lfd label writes the segments into the recording as its ground truth."""
    got = json.loads((work / "mine_1.json").read_text())
    assert _truth(work / "mine_1.mcap") == [s["skill"] for s in got["segments"]]


def _eval_set(proc: subprocess.CompletedProcess[str], work: Path) -> None:
    """ "4 experiments x 6 demos" (segmentation.md)."""
    assert len(list((work / "eval_demos").glob("*.mcap"))) == 24


def _samples_regenerated(proc: subprocess.CompletedProcess[str], work: Path) -> None:
    """ "deterministic: same seed" (recordings/README.md): the regenerated sample recordings hold
    the shipped ones' demonstrations (the file layout may differ between library versions)."""
    import lfd
    import numpy as np

    for name in ("exp1", "exp2", "exp3", "exp4"):
        new, old = (
            lfd.load(d / f"{name}.mcap") for d in (work / "recordings", ROOT / "recordings")
        )
        assert new.labels == old.labels, name
        np.testing.assert_array_equal(new.hand.t_ns, old.hand.t_ns)
        np.testing.assert_allclose(new.hand.keypoints, old.hand.keypoints, atol=1e-9)


CHECKS: dict[str, list[tuple[str, Check]]] = {
    # command line -> [(what the document shows, quoted; the check of it)]
    "lfd info demo.mcap": [("channels, rates, objects, ground-truth skills", _info_tables)],
    "lfd segment demo.mcap --json seg.json --rerun-save seg.rrd": [
        ("skills, with a Rerun recording", _segments_demo_exactly)
    ],
    "lfd segment demo.mcap --paper": [("the paper's greedy loop", _greedy)],
    "lfd segment recordings/exp1.mcap --paper": [("the paper: greedy loop", _greedy)],
    "lfd segment recordings/ros/exp1.bag --map recordings/ros/exp1.toml": [
        ("It segments to the same skills as `exp1.mcap`", _segments_as_exp1)
    ],
    "lfd segment exp1_from_ros.mcap": [
        ("It segments to the same skills as `exp1.mcap`", _segments_as_exp1)
    ],
    "lfd info recordings/exp1.mcap --json - | head -3": [("--json - | head -3", _three_lines)],
    "lfd segment recordings/exp1.mcap --json - > seg.json": [
        ("--json - > seg.json", _json_segments_as_exp1)
    ],
    "lfd segment recordings/exp1.mcap recordings/exp2.mcap --json batch.json": [
        ("in input order", _batch_of_two)
    ],
    "lfd segment mine_1.mcap --json mine_1.json": [
        (
            '{"skill": "pick_up", "start_s": 0.0, "end_s": 1.67, "object": "box_2"}',
            _segments_as_shown,
        )
    ],
    "lfd label mine_1.mcap --from mine_1.json": [
        ("writes the segments into the recording as ground truth", _labelled_as_segmented)
    ],
    "lfd simulate --set eval -o eval_demos": [("4 experiments x 6 demos", _eval_set)],
    "MUJOCO_GL=egl lfd simulate --set samples -o recordings": [
        ("deterministic: same seed", _samples_regenerated)
    ],
}


SLOW_SNIPPETS = {
    "docs/export.md": "writes a LeRobot dataset with video, twice (lerobot, torch: ~45 s)",
}


@pytest.mark.parametrize(
    "document",
    [pytest.param(d, marks=[pytest.mark.slow] if d in SLOW_SNIPPETS else []) for d in DOCUMENTS],
)
def test_python_snippets_work_twice_in_a_fresh_interpreter(document: str, tmp_path: Path) -> None:
    path = ROOT / document
    for start, code in python_snippets(path):
        code = textwrap.dedent(code)
        if any(f"import {m}" in code or f", {m}" in code for m in HARDWARE_MODULES):
            compile(code, f"{document}:{start}", "exec")  # needs the device's SDK: syntax only
            continue
        # a viewer cannot be spawned in a test: the snippet saves to a file instead
        code = code.replace("spawn=True", f"save={str(tmp_path / 'snippet.rrd')!r}")
        # every call works more than once
        proc = _run([sys.executable, "-c", code + "\n\n" + code], ROOT, timeout=600)
        assert proc.returncode == 0, f"{document}:{start}\n{proc.stderr[-3000:]}"


def test_example_modules_compile_and_offer_the_plugin_factory() -> None:
    """docs/examples/*.py (the RealSense reader) need hardware: compiled, and the factory the
    docs name is there."""
    import ast

    examples = sorted((ROOT / "docs" / "examples").glob("*.py"))
    assert examples
    for path in examples:
        tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
        compile(tree, str(path), "exec")
        names = {n.name for n in tree.body if isinstance(n, ast.FunctionDef | ast.ClassDef)}
        assert "make_reader" in names, path
