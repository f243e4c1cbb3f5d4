"""The package installs with its compiled engine and its console script."""

import subprocess
import sys

import lfd
from lfd import _hmmseg


def test_engine_version_matches_package() -> None:
    assert _hmmseg.__version__ == lfd.__version__


def test_cli_version() -> None:
    out = subprocess.run(
        [sys.executable, "-m", "lfd.cli", "--version"], capture_output=True, text=True, check=True
    )
    assert out.stdout.strip() == f"lfd {lfd.__version__}"
