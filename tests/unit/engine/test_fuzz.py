"""A short smoke run of the engine fuzzers: the hypothesis harness over the Python API in a
subprocess (an abort shows as its exit status) — the long runs are in the issue notes."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import _paths
import pytest

pytest.importorskip("hypothesis")

HARNESS = _paths.TESTS / "fuzz" / "engine_fuzz.py"


def test_python_api_fuzz_smoke() -> None:
    env = {**os.environ, "RUST_BACKTRACE": "0"}
    proc = subprocess.run(
        [sys.executable, str(HARNESS), "--examples", "150", "--seed", "7"],
        capture_output=True,
        text=True,
        timeout=600,
        env=env,
    )
    assert proc.returncode in (0, 1), f"the engine crashed the interpreter:\n{proc.stderr[-3000:]}"
    doc = json.loads(proc.stdout.strip().splitlines()[-1])
    assert doc["total"] >= 150 * 9
    assert doc["findings"] == [], json.dumps(doc["findings"], indent=1)
