"""Ctrl+C in the middle of a write: the recording goes on and closes whole.

``lfd record`` catches Ctrl+C, writes what its hand model and skill observer still hold, and
closes the file. Python raises ``KeyboardInterrupt`` at whatever line is running, and the MCAP
writer is pure Python: a Ctrl+C inside it used to leave half a record in the open chunk, and the
closed file then had a damaged last chunk (CI, 2026-12-06: "a footer record of
2402107451248738304 bytes runs past its chunk")."""

from __future__ import annotations

import os
import signal
import sys
import threading
import warnings
from collections.abc import Iterator
from pathlib import Path
from types import FrameType
from typing import Any

import numpy as np
import pytest
from lfd.cli._options import sigterm_interrupts
from lfd.io import McapRecorder, load
from lfd.outputs import signals_held

MCAP_DIR = os.path.dirname(__import__("mcap").__file__)
FRAMES = 24


@pytest.fixture
def ctrl_c_handler() -> Iterator[None]:
    """SIGINT raises KeyboardInterrupt, as in ``lfd record``, whatever the runner left."""
    mask = signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    try:
        with sigterm_interrupts():
            yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)


def _ctrl_c_at_line(k: int) -> Any:
    """A tracer sending this process a real SIGINT at the ``k``-th line run inside ``mcap``."""
    seen = [0]

    def local(frame: FrameType, event: str, _arg: object) -> Any:
        if event == "line":
            seen[0] += 1
            if seen[0] == k:
                signal.raise_signal(signal.SIGINT)  # the handler runs here, at this line
        return local

    def tracer(frame: FrameType, _event: str, _arg: object) -> Any:
        return local if frame.f_code.co_filename.startswith(MCAP_DIR) else None

    return tracer, seen


def _record(path: Path, k: int) -> tuple[int | None, int]:
    """Record FRAMES hand and box samples with Ctrl+C at mcap line ``k``; go on after it as
    ``lfd record``'s wind-up does, and close. (the frame Ctrl+C came in, mcap lines run)"""
    kp = np.zeros((21, 3))
    tracer, seen = _ctrl_c_at_line(k)
    stopped = None
    rec = McapRecorder(path, objects=[("box", 3, (0.05, 0.05, 0.05))], chunk_size=600)
    sys.settrace(tracer)
    try:
        for i in range(FRAMES):
            t = (i + 1) * 33_000_000
            samples = (
                (rec.add_hand, (t, kp + 0.01 * i, np.ones(21), np.ones(21, bool))),
                (rec.add_object_pose, ("box", t, np.full(3, 0.01 * i), [1.0, 0, 0, 0])),
            )
            for add, args in samples:
                try:
                    add(*args)
                except KeyboardInterrupt:
                    stopped = i
        try:
            rec.close()
        except KeyboardInterrupt:  # after the file was closed whole
            stopped = FRAMES
    finally:
        sys.settrace(None)
    return stopped, seen[0]


def test_ctrl_c_at_any_line_of_the_mcap_writer_leaves_every_message(
    tmp_path: Path, ctrl_c_handler: None
) -> None:
    _, lines = _record(tmp_path / "count.mcap", 0)
    assert lines > 5000  # messages, chunks (chunk_size 600 bytes), the summary
    lines_at = np.sort(np.random.default_rng(0).choice(lines, 300, replace=False)) + 1
    for k in lines_at:
        path = tmp_path / f"k{k}.mcap"
        stopped, _ = _record(path, int(k))
        assert stopped is not None, k  # Ctrl+C came (and was raised) at every line tried
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # a damaged or unclosed file warns while recovering
            demo = load(path)
        # the sample being written when Ctrl+C came was written whole; none twice
        assert len(demo.hand.t_ns) == FRAMES, (k, stopped)
        assert len(demo.objects["box"].t_ns) == FRAMES, (k, stopped)
        np.testing.assert_allclose(demo.hand.keypoints[:, 0, 0], 0.01 * np.arange(FRAMES))
        path.unlink()


def test_a_held_signal_comes_after_the_block_from_any_thread(ctrl_c_handler: None) -> None:
    """The signal sent from another thread (the OS may hand it to any thread) is held by the
    outermost block and raised once, at its end; nested blocks do not deliver it early."""
    done = []
    with pytest.raises(KeyboardInterrupt):
        with signals_held():
            with signals_held():
                t = threading.Thread(target=os.kill, args=(os.getpid(), signal.SIGINT))
                t.start()
                t.join()
                for _ in range(10_000):  # time for the handler to have run, were it not held
                    pass
                done.append("inner")
            done.append("outer")
    assert done == ["inner", "outer"]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_a_file_that_cannot_start_leaves_nothing_behind(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """An error while the recording starts (its header or metadata cannot be written: a full
    disk) reaches the caller, the temporary file is closed and removed, nothing else written."""
    import lfd.io.writer as writer

    opened: list[Any] = []
    real_open = open

    def tracked(path: Any, mode: str = "r", *args: Any, **kw: Any) -> Any:
        fh = real_open(path, mode, *args, **kw)
        opened.append(fh)
        return fh

    def full_disk(self: Any, *args: Any, **kw: Any) -> None:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(writer, "open", tracked, raising=False)
    monkeypatch.setattr(writer._McapWriter, "add_metadata", full_disk)
    with pytest.raises(OSError, match="No space left"):
        McapRecorder(tmp_path / "x.mcap", objects=[("box", 3, (0.05, 0.05, 0.05))])
    assert list(tmp_path.iterdir()) == []
    assert len(opened) == 1 and opened[0].closed
