"""Every command line and Python snippet in the README and the docs works as shown.

The lines are read from the documents themselves (fenced code blocks), so a changed or added
line is tested without touching this file. A line runs exactly as written, in a scratch
directory holding a copy of ``recordings/`` (so regenerating recordings cannot touch the shipped
ones), after the lines before it in the same document. The few lines that cannot run as written
in a test are listed below with the reason and what runs instead; a listed line that no longer
appears in the documents fails the test, so the list cannot go stale.
"""

from __future__ import annotations

import os
import re
import shutil
import signal
import subprocess
import sys
import textwrap
import time
from dataclasses import dataclass
from pathlib import Path

import _paths
import pytest

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
    "python docs/examples/realsense_reader.py": "needs a RealSense (the module is compiled below)",
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


def _run_viewer_line(cmd: str, cwd: Path) -> None:
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


@pytest.mark.slow
@pytest.mark.parametrize("document", DOCUMENTS)
def test_command_lines_work_as_shown(document: str, tmp_path: Path) -> None:
    path = ROOT / document
    lines = command_lines(path)
    work = _scratch(tmp_path)
    ran = 0
    for line in lines:
        if any(line.command.startswith(p) for p in NOT_RUN):
            continue
        cmd = RUN_AS.get(line.command, (line.command, ""))[0]
        if any(v in cmd + " " for v in VIEWER_LINES):
            _run_viewer_line(cmd, work)
            ran += 1
            continue
        proc = _run(["bash", "-c", cmd], work, timeout=900)
        assert proc.returncode == 0, f"{line}\nexit {proc.returncode}\n{proc.stderr[-3000:]}"
        assert "Traceback" not in proc.stderr, f"{line}\n{proc.stderr[-3000:]}"
        ran += 1
    assert ran or not lines


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
