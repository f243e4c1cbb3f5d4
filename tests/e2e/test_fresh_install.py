"""The README's first command on a fresh virtual environment: the plain install (no extras)
segments a shipped recording, and the commands that need an extra say so in one line."""

from __future__ import annotations

import os
import subprocess
import venv
from pathlib import Path

import _paths
import pytest

ROOT = _paths.ROOT


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
@pytest.mark.parametrize(
    "args",
    [
        ("simulate", "exp1", "-o", "demo.mcap"),
        ("reproduce", str(ROOT / "recordings" / "exp1.mcap")),
        ("record", "--source", "sim:exp1", "-o", "seen.mcap"),
        ("segment", str(ROOT / "recordings" / "exp1.mcap"), "--rerun-save", "x.rrd"),
        ("perception", "hands", str(ROOT / "docs" / "rerun.png")),
        ("export", "lerobot", str(ROOT / "recordings" / "exp1.mcap"), "-o", "dataset"),
    ],
)
def test_missing_extra_is_one_line(fresh_venv: Path, tmp_path: Path, args: tuple[str, ...]) -> None:
    proc = _run(fresh_venv, "lfd", *args, cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith(f"lfd {args[0]}: error:") and "pip install" in lines[0], lines
    assert not list(tmp_path.iterdir()), "a failed command left a file behind"
