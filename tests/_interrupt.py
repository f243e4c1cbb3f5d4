"""Interrupt an ``lfd record`` run with SIGINT once it has written part of its recording, as a
user's Ctrl+C does (shared by the recording tests of every source)."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path


def partial_bytes(out: Path) -> int:
    """Bytes written so far to ``out``'s partial file (``.NAME.*.partial`` until it is closed)."""
    return sum(p.stat().st_size for p in out.parent.glob(f".{out.name}.*.partial"))


def interrupt_record(argv: list[str], out: Path, after_bytes: int) -> tuple[int, str]:
    """Run ``lfd ARGV`` (writing ``out``), send SIGINT once ``after_bytes`` are written, and
    return its exit status and stderr. The process starts with SIGINT ignored, as a shell
    starts a background job, which Python would keep: the command must catch it anyway."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "lfd.cli", *argv],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN),
    )
    deadline = time.time() + 120
    while time.time() < deadline and partial_bytes(out) < after_bytes and proc.poll() is None:
        time.sleep(0.2)
    assert proc.poll() is None, proc.communicate()[1].decode()
    assert not out.exists()
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    return proc.returncode, err.decode()
