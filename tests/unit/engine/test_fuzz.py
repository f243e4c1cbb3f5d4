"""The engine fuzzer ``tests/fuzz/engine_fuzz.py``: it has a target for every public entry point
of ``lfd._hmmseg``, counts an abort and a hang without dying, and a short run of every target
finds nothing (seconds; the long runs are in the issue notes)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from typing import Any

import _paths

HARNESS = _paths.TESTS / "fuzz" / "engine_fuzz.py"


def _fuzz(*args: str, selftest: bool = False) -> tuple[int, dict[str, Any]]:
    env = {**os.environ, "RUST_BACKTRACE": "0", "LFD_FUZZ_SELFTEST": "1" if selftest else "0"}
    proc = subprocess.run(
        [sys.executable, str(HARNESS), *args], capture_output=True, text=True, timeout=300, env=env
    )
    assert proc.returncode in (0, 1), proc.stderr[-3000:]
    return proc.returncode, json.loads(proc.stdout.strip().splitlines()[-1])


def test_every_public_entry_point_is_a_fuzz_target() -> None:
    rc, doc = _fuzz("--check-coverage")
    assert (rc, doc["missing"]) == (0, []), doc


def test_aborts_and_hangs_are_counted_not_fatal() -> None:
    rc, doc = _fuzz(
        "--targets", "selftest.abort,selftest.hang,minmax", "--cases", "40", "--timeout", "1",
        selftest=True,
    )  # fmt: skip
    assert rc == 1
    kinds = doc["counts"]
    assert kinds["abort"] >= 1 and kinds["hang"] >= 1, doc
    assert kinds["abort"] + kinds["hang"] == len(doc["findings"])
    # every case was run: the worker restarted after each abort and hang
    assert doc["calls"] == {"selftest.abort": 40, "selftest.hang": 40, "minmax": 40}
    for f in doc["findings"]:
        assert f["target"] in ("selftest.abort", "selftest.hang"), f


def test_engine_fuzz_smoke() -> None:
    rc, doc = _fuzz("--cases", "25", "--seed", "7", "--timeout", "60")
    assert doc["findings"] == [], json.dumps(doc["findings"], indent=1)
    assert rc == 0
    assert min(doc["calls"].values()) == 25
