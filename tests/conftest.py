"""Test session setup and fixtures shared by every test directory.

The tests are arranged by kind: ``unit/<area>`` (the library in this process), ``cli`` (the
command line's contract), ``docs`` (every command and snippet of the documents), ``e2e`` (whole
pipelines, installs, browsers). Helper modules (``_paths``, ``_synthetic``, ``_rosbags``, ...)
stay in ``tests/``, which is on ``pythonpath`` (pyproject.toml). Tests marked ``slow`` run with
``-m slow`` only.
"""

from __future__ import annotations

import contextlib
import os
import stat
import subprocess
import warnings
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path

# Headless OpenGL for MuJoCo and no telemetry from Rerun, before either library is imported.
import lfd._gl  # noqa: F401
import pytest

os.environ.setdefault("RERUN_TELEMETRY", "0")

LfdMain = Callable[..., "subprocess.CompletedProcess[str]"]


def _null_is_a_device() -> bool:
    try:
        return stat.S_ISCHR(os.stat(os.devnull).st_mode)
    except OSError:
        return False


@pytest.fixture(autouse=True)
def _devnull_stays_a_device() -> Iterator[None]:
    """A test that replaces /dev/null with a regular file (a rename onto it, as root) breaks
    every later program that reads it (cargo's rustc probe read build-script errors from it):
    such a test fails here, by name."""
    before = _null_is_a_device()
    yield
    if before and not _null_is_a_device():
        pytest.fail(f"{os.devnull} is no longer a character device after this test")


@pytest.fixture
def lfd_main(capfd: pytest.CaptureFixture[str]) -> LfdMain:
    """``lfd ARGS`` through :func:`lfd.cli.main` in this process (the console script's entry
    point, without a new interpreter's start-up): ``lfd_main(argv, cwd=None)`` gives the exit
    status, stdout and stderr (file descriptors 1 and 2 included) as ``subprocess.run`` would.

    Warnings show as the command shows them, not as the session's errors; an exception that
    escapes ``main`` fails the test with its traceback, as a subprocess would print it."""
    from lfd.cli import main

    def run(argv: Sequence[str], cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
        capfd.readouterr()
        with contextlib.chdir(cwd or Path.cwd()), warnings.catch_warnings():
            warnings.simplefilter("default")
            try:
                status = main([str(a) for a in argv])
            except SystemExit as stop:  # argparse: the message is printed, the code is the status
                status = stop.code if isinstance(stop.code, int) else int(stop.code is not None)
        out, err = capfd.readouterr()
        return subprocess.CompletedProcess(list(argv), status, out, err)

    return run
