"""A command needing an optional extra that is not installed says which, in one line, exit 2.

Each case blocks one module of an extra (``sys.modules[name] = None``: what Python does for a
module that is not installed) in a fresh interpreter and runs one command that needs it. The
same commands run on a real install without extras in tests/e2e/test_fresh_install.py (slow).
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import _paths
import pytest
from lfd import _extras
from lfd.errors import LfdError, MissingExtraError

ROOT = _paths.ROOT
REC = ROOT / "recordings"
EXP1, EXP2 = str(REC / "exp1.mcap"), str(REC / "exp2.mcap")
BAG, BAG_MAP = str(REC / "ros" / "exp1.bag"), str(REC / "ros" / "exp1.toml")
WEIGHTS = str(ROOT / "python" / "lfd" / "data" / "hand_depth.pt")

BLOCK_AND_RUN = (
    "import sys\n"
    "for m in sys.argv[1].split(','): sys.modules[m] = None  # as if not installed\n"
    "from lfd.cli import main\n"
    "sys.exit(main(sys.argv[2:]))\n"
)

INSTALL_LINE = re.compile(r"^lfd (\w+): error: .+: pip install 'lfd\[[a-z,]+\]'")

CASES: list[tuple[str, str, tuple[str, ...]]] = [
    # (blocked module, extra named, command line)
    ("mujoco", "sim", ("simulate", "exp1", "-o", "x.mcap")),
    ("mujoco", "sim", ("reproduce", EXP1)),
    # found missing only late before: the QP solver at the first IK step, the DMPs in dmp mode
    ("daqp", "sim", ("reproduce", EXP1, "--mode", "skills")),
    ("movement_primitives", "sim", ("reproduce", EXP1)),
    ("movement_primitives", "sim", ("reproduce", EXP1, "--mode", "dmp")),
    ("pytransform3d", "sim", ("reproduce", EXP1, "--mode", "dmp")),
    ("cv2", "sim", ("record", "--source", "sim:exp1", "-o", "x.mcap", "--duration", "1")),
    ("torch", "perception", ("record", "--source", "sim:exp1", "-o", "x.mcap", "--duration", "1")),
    ("ai_edge_litert", "perception", ("perception", "hands", str(ROOT / "docs" / "rerun.png"))),
    ("cv2", "perception", ("perception", "hands", str(ROOT / "docs" / "rerun.png"))),
    ("torch", "perception", ("perception", "train", "-o", "h.pt", "--samples", "10")),
    ("mujoco", "sim", ("perception", "eval", "--hand-model", WEIGHTS, "--samples", "5")),
    ("lerobot", "lerobot", ("export", "lerobot", EXP1, "-o", "ds")),
    ("datasets", "lerobot", ("export", "lerobot", EXP1, "-o", "ds")),
    ("rosbags", "ros", ("import", "ros", BAG, "--map", BAG_MAP, "-o", "x.mcap")),
    ("rosbags", "ros", ("segment", BAG, "--map", BAG_MAP)),
    ("rerun", "viz", ("segment", EXP1, "--rerun-save", "x.rrd")),
    ("rerun", "viz", ("simulate", "exp1", "-o", "x.mcap", "--rerun-save", "x.rrd")),
    ("ray", "ray", ("segment", EXP1, EXP2, "--ray")),
]


def assert_install_line(proc: subprocess.CompletedProcess[str], command: str, extra: str) -> str:
    """One stderr line, ``lfd COMMAND: error: ...: pip install 'lfd[...EXTRA...]'``, exit 2."""
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert proc.returncode == 2, proc.stderr
    assert len(lines) == 1, proc.stderr
    m = INSTALL_LINE.match(lines[0])
    assert m and m.group(1) == command, lines[0]
    assert re.search(rf"lfd\[([a-z]+,)*{extra}(,[a-z]+)*\]", lines[0]), lines[0]
    return lines[0]


@pytest.mark.parametrize(
    ("module", "extra", "argv"),
    CASES,
    ids=["-".join([*(a for a in argv[:2] if not a.startswith("/")), m]) for m, _, argv in CASES],
)
def test_missing_extra_is_one_line(
    module: str, extra: str, argv: tuple[str, ...], tmp_path: Path
) -> None:
    proc = subprocess.run(
        [sys.executable, "-c", BLOCK_AND_RUN, module, *argv],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        timeout=300,
        check=False,
    )
    assert "Traceback" not in proc.stderr, proc.stderr
    assert_install_line(proc, argv[0], extra)
    assert list(tmp_path.iterdir()) == [], "a refused command left a file behind"


def test_the_reproduce_message_is_the_simulators() -> None:
    """The line ``lfd simulate`` gave before: reproduce now gives the same one."""
    assert _extras.message("sim") == "this command needs the simulator: pip install 'lfd[sim]'"


def test_every_extra_is_in_pyproject() -> None:
    import tomllib

    declared = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    extras = declared["project"]["optional-dependencies"]
    for name, extra in _extras.EXTRAS.items():
        assert name in extras, name
        for listed in re.findall(r"lfd\[([a-z,]+)\]", extra.install):
            assert set(listed.split(",")) <= set(extras), extra.install


def test_require_and_message_for(monkeypatch: pytest.MonkeyPatch) -> None:
    assert _extras.missing("sim") is None  # the test environment has every extra
    monkeypatch.setitem(sys.modules, "daqp", None)
    assert _extras.missing("sim") == "daqp"
    assert _extras.missing("sim", ("mujoco",)) is None
    with pytest.raises(MissingExtraError, match=r"needs the simulator: pip install 'lfd\[sim\]'"):
        _extras.require("sim")
    try:
        _extras.require("sim", who="lfd.reproduce")
    except MissingExtraError as err:
        assert isinstance(err, LfdError)
        assert (err.extra, err.module) == ("sim", "daqp")
        assert str(err).startswith("lfd.reproduce needs the simulator")
    assert _extras.message_for("movement_primitives.dmp") == _extras.message("sim")
    assert _extras.message_for("torch", ("lerobot",)) == _extras.message("lerobot", "torch")
    assert "torch is missing" in _extras.message_for("torch", ("lerobot",))  # type: ignore[operator]
    assert _extras.message_for("torch") == _extras.message("perception")
    assert _extras.message_for("not_an_extra_module") is None


def test_library_reproduce_checks_before_running(monkeypatch: pytest.MonkeyPatch) -> None:
    """``lfd.reproduce.reproduce`` refuses before planning when the QP solver is missing (it
    raised qpsolvers' SolverNotFound at the first IK step)."""
    from lfd.reproduce import reproduce

    monkeypatch.setitem(sys.modules, "daqp", None)
    with pytest.raises(MissingExtraError, match=r"lfd\.reproduce needs the simulator"):
        reproduce(None, None, "skills")  # type: ignore[arg-type]
