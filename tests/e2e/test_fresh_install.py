"""The README's first command on a fresh virtual environment: the plain install (no extras)
segments a shipped recording, every command's --help works, the commands of the plain install
run, and the commands that need an extra say which in one line (``pip install 'lfd[EXTRA]'``).
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import venv
from pathlib import Path

import _paths
import pytest

ROOT = _paths.ROOT
REC = ROOT / "recordings"
EXP1 = str(REC / "exp1.mcap")
BAG, BAG_MAP = str(REC / "ros" / "exp1.bag"), str(REC / "ros" / "exp1.toml")
INSTALL_LINE = re.compile(r"^lfd (\w+): error: .+: pip install 'lfd\[[a-z,]+\]'")


def _commands() -> list[tuple[str, ...]]:
    """``lfd`` itself (``()``) and every command and subcommand (``("segment",)``,
    ``("export", "lerobot")``)."""
    from lfd.cli import build_parser

    def walk(parser: argparse.ArgumentParser, prefix: tuple[str, ...]) -> list[tuple[str, ...]]:
        out = [prefix]
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for name, sub in action.choices.items():
                    out += walk(sub, (*prefix, name))
        return out

    return walk(build_parser(), ())


@pytest.fixture(scope="module")
def fresh_venv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A new venv with ``pip install ROOT`` (the package and its required dependencies only)."""
    env_dir = tmp_path_factory.mktemp("venv") / "env"
    venv.create(env_dir, with_pip=True, symlinks=True)
    py = env_dir / "bin" / "python"
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    proc = subprocess.run(
        [str(py), "-m", "pip", "install", "-q", str(ROOT)],
        capture_output=True,
        text=True,
        env=env,
        timeout=1800,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr[-4000:]
    return env_dir


def _run(env_dir: Path, *args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["PATH"] = f"{env_dir / 'bin'}{os.pathsep}{env.get('PATH', '')}"
    return subprocess.run(
        list(args), capture_output=True, text=True, cwd=cwd, env=env, timeout=600, check=False
    )


@pytest.mark.slow
def test_plain_install_segments_a_shipped_recording(fresh_venv: Path, tmp_path: Path) -> None:
    extras = _run(
        fresh_venv,
        "python",
        "-c",
        "import importlib.util as u; print([m for m in ('mujoco', 'torch', 'rerun', 'cv2') "
        "if u.find_spec(m)])",
        cwd=tmp_path,
    )
    assert extras.stdout.strip() == "[]", "the plain install pulled in an extra"
    proc = _run(fresh_venv, "lfd", "segment", str(ROOT / "recordings" / "exp1.mcap"), cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert "pick_up" in proc.stdout and "move_with" in proc.stdout
    assert "Traceback" not in proc.stderr


@pytest.mark.slow
@pytest.mark.parametrize("command", _commands(), ids=lambda c: " ".join(("lfd", *c)))
def test_every_help_works(fresh_venv: Path, tmp_path: Path, command: tuple[str, ...]) -> None:
    proc = _run(fresh_venv, "lfd", *command, "--help", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.startswith(f"usage: lfd {' '.join(command)}"), proc.stdout[:200]
    assert proc.stderr == ""


@pytest.mark.slow
def test_plain_install_commands_run(fresh_venv: Path, tmp_path: Path) -> None:
    """Every command of the plain install, once, as a user would chain them."""
    skills = ("pick_up", "place", "locate", "stack", "push", "move", "move_with")
    templates = [str(REC / "templates" / f"{s}_0.mcap") for s in skills]
    shutil.copy(EXP1, tmp_path / "mine.mcap")
    steps: list[tuple[str, ...]] = [
        ("info", "mine.mcap"),
        ("info", "mine.mcap", "--check"),
        ("info", "default"),
        ("segment", "mine.mcap", "--json", "seg.json"),
        ("label", "mine.mcap", "--from", "seg.json", "-o", "labelled.mcap"),
        ("eval", "labelled.mcap", "--methods", "dp,paper,changepoint"),
        ("templates", "train", *templates, "-o", "mine.json"),
        ("segment", "mine.mcap", "--templates", "mine.json"),
    ]
    for step in steps:
        proc = _run(fresh_venv, "lfd", *step, cwd=tmp_path)
        assert proc.returncode == 0, f"lfd {' '.join(step)}\n{proc.stderr}"
        assert "Traceback" not in proc.stderr, proc.stderr
        assert proc.stdout.strip(), f"lfd {' '.join(step)} printed nothing"
    for name in ("seg.json", "labelled.mcap", "mine.json"):
        assert (tmp_path / name).stat().st_size > 0, name


@pytest.mark.slow
@pytest.mark.parametrize(
    ("extra", "args"),
    [
        ("sim", ("simulate", "exp1", "-o", "demo.mcap")),
        ("sim", ("reproduce", EXP1)),
        ("sim", ("reproduce", EXP1, "--mode", "dmp")),
        ("sim", ("record", "--source", "sim:exp1", "-o", "seen.mcap")),
        ("viz", ("segment", EXP1, "--rerun-save", "x.rrd")),
        ("perception", ("perception", "hands", str(ROOT / "docs" / "rerun.png"))),
        ("perception", ("perception", "train", "-o", "hand.pt", "--samples", "10")),
        ("perception", ("perception", "eval", "--hand-model", "hand.pt")),
        ("lerobot", ("export", "lerobot", EXP1, "-o", "dataset")),
        ("ros", ("import", "ros", BAG, "--map", BAG_MAP, "-o", "x.mcap")),
        ("ros", ("segment", BAG, "--map", BAG_MAP)),
        ("ray", ("segment", EXP1, str(REC / "exp2.mcap"), "--ray")),
    ],
    ids=lambda v: v if isinstance(v, str) else "-".join(a for a in v[:2] if "/" not in a),
)
def test_missing_extra_is_one_line(
    fresh_venv: Path, tmp_path: Path, extra: str, args: tuple[str, ...]
) -> None:
    if args[:2] == ("perception", "eval"):  # an existing weights file: the check before torch
        (tmp_path / "hand.pt").write_bytes(b"")
    before = set(tmp_path.iterdir())
    proc = _run(fresh_venv, "lfd", *args, cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, proc.stderr
    m = INSTALL_LINE.match(lines[0])
    assert m and m.group(1) == args[0], lines
    assert re.search(rf"lfd\[([a-z]+,)*{extra}(,[a-z]+)*\]", lines[0]), lines
    assert set(tmp_path.iterdir()) == before, "a failed command left a file behind"
