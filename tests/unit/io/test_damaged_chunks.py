"""A recording with one damaged chunk: ``lfd.load`` reads every other chunk, ``lfd info`` names
the damaged chunk and the messages lost in one plain warning line; a valid MCAP file without
message indexes and statistics is summarised too."""

from __future__ import annotations

import json
import struct
from collections.abc import Callable
from pathlib import Path
from typing import Any

import _paths
import lfd
import numpy as np
import pytest
import zstandard
from _mcapcopy import copy_records
from lfd.cli import main
from lfd.errors import RecoveredFileWarning
from lfd.io.mcapfile import read_summary
from mcap.reader import make_reader

EXP1 = _paths.RECORDINGS / "exp1.mcap"


def _chunk_indexes(path: Path) -> list[Any]:
    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    return sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset)


def _topics(path: Path) -> dict[int, str]:
    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    return {i: c.topic for i, c in summary.channels.items()}


def _chunk_messages(data: bytes, ci: Any) -> list[tuple[int, int]]:
    """``(channel id, log time)`` of every message in the chunk ``ci`` of ``data``, parsed here
    from the MCAP layout (independent of the reader under test)."""
    at = ci.chunk_start_offset + 9
    (clen,) = struct.unpack_from("<I", data, at + 28)
    compression = data[at + 32 : at + 32 + clen].decode()
    (rlen,) = struct.unpack_from("<Q", data, at + 32 + clen)
    records = data[at + 40 + clen : at + 40 + clen + rlen]
    if compression == "zstd":
        records = zstandard.ZstdDecompressor().decompress(
            records, max_output_size=ci.uncompressed_size
        )
    out, i = [], 0
    while i < len(records):
        op, n = records[i], struct.unpack_from("<Q", records, i + 1)[0]
        if op == 0x05:
            channel, _, t = struct.unpack_from("<HIQ", records, i + 9)
            out.append((channel, t))
        i += 9 + n
    return out


def _flip_chunk(data: bytes, ci: Any) -> bytes:
    b = bytearray(data)
    mid = ci.chunk_start_offset + ci.chunk_length // 2
    for i in range(mid, mid + 32):
        b[i] ^= 0x5A
    return bytes(b)


def _bad_length(data: bytes, ci: Any) -> bytes:
    b = bytearray(data)
    b[ci.chunk_start_offset + 1 : ci.chunk_start_offset + 9] = (2**32 - 1).to_bytes(8, "little")
    return bytes(b)


@pytest.mark.parametrize(("damage", "k"), [(_flip_chunk, 9), (_bad_length, 1)])
def test_load_reads_every_other_chunk(
    damage: Callable[[bytes, Any], bytes], k: int, tmp_path: Path
) -> None:
    data = EXP1.read_bytes()
    chunks = _chunk_indexes(EXP1)
    lost = _chunk_messages(data, chunks[k])
    topics = _topics(EXP1)
    path = tmp_path / "damaged.mcap"
    path.write_bytes(damage(data, chunks[k]))
    full = lfd.load(EXP1, images=False)
    with pytest.warns(RecoveredFileWarning) as caught:
        demo = lfd.load(path, images=False)
    text = " ".join(str(w.message) for w in caught)
    assert f"chunk {k + 1} of {len(chunks)} damaged" in text
    assert f"{len(lost)} messages lost" in text
    assert demo.metadata["load_report"]["damage"] is not None
    # the hand and every object: all samples but those of the damaged chunk
    lost_hand = {t for ch, t in lost if topics[ch] == "/hand/right/keypoints"}
    keep = ~np.isin(full.hand.t_ns, list(lost_hand))
    assert lost_hand and keep.sum() == len(demo.hand)
    np.testing.assert_array_equal(demo.hand.t_ns, full.hand.t_ns[keep])
    np.testing.assert_array_equal(demo.hand.keypoints, full.hand.keypoints[keep])
    for name, obj in full.objects.items():
        gone = {t for ch, t in lost if topics[ch] == f"/objects/{name}/pose"}
        keep = ~np.isin(obj.t_ns, list(gone))
        np.testing.assert_array_equal(demo.objects[name].t_ns, obj.t_ns[keep])
        np.testing.assert_array_equal(demo.objects[name].position, obj.position[keep])


def test_info_names_the_damaged_chunk_in_one_plain_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data = EXP1.read_bytes()
    chunks = _chunk_indexes(EXP1)
    lost = _chunk_messages(data, chunks[9])
    path = tmp_path / "damaged.mcap"
    path.write_bytes(_flip_chunk(data, chunks[9]))
    assert main(["info", str(path)]) == 0  # described, with a warning (docs/cli.md)
    out, err = capsys.readouterr()
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1, err
    assert lines[0].startswith("lfd info: warning: ")
    assert f"chunk 10 of {len(chunks)} damaged" in lines[0]
    assert f"{len(lost)} messages lost" in lines[0]
    assert "\x1b" not in err + out and "Traceback" not in err and "backtrace" not in err
    assert "damaged" in out and "complete" not in out.splitlines()[0]
    assert main(["info", str(path), "--json", "-"]) == 0
    s = json.loads(capsys.readouterr().out)
    assert s["complete"] is False and s["source"] == "summary"
    assert [d["chunks"] for d in s["damaged_chunks"]] == [[10]]
    assert s["damaged_chunks"][0]["messages"] == len(lost)
    honest = read_summary(EXP1)
    assert honest is not None and s["messages"] == honest.message_count - len(lost)


def test_info_of_a_bad_length_without_summary(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Cut before its summary: the damage is found by the full read, messages lost unknown."""
    data = EXP1.read_bytes()
    chunks = _chunk_indexes(EXP1)
    path = tmp_path / "damaged.mcap"
    path.write_bytes(_bad_length(data, chunks[3])[: chunks[-1].chunk_start_offset])
    assert main(["info", str(path), "--json", "-"]) == 0
    out, err = capsys.readouterr()
    s = json.loads(out)
    assert s["complete"] is False and s["source"] == "scan"
    assert "unknown messages lost" in s["damage"]
    lines = [line for line in err.splitlines() if line.startswith("lfd info:")]  # (tables too)
    assert len(lines) == 1 and "unknown messages lost" in lines[0], err


def test_info_reads_a_file_without_message_indexes_or_statistics(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from mcap.writer import IndexType, Writer

    path = tmp_path / "unindexed.mcap"
    with open(EXP1, "rb") as f, open(path, "wb") as out:
        reader = make_reader(f)
        writer = Writer(out, index_types=IndexType.NONE, use_statistics=False)
        writer.start(profile="", library="test")
        copy_records(reader, writer)
        writer.finish()
    assert main(["info", str(EXP1), "--json", "-"]) == 0
    want = json.loads(capsys.readouterr().out)
    assert main(["info", str(path), "--json", "-"]) == 0
    out, err = capsys.readouterr()
    s = json.loads(out)
    assert s["complete"] is True and s["error"] is None and s["warnings"] == [], err
    assert s["messages"] == want["messages"]
    assert s["channels"] == want["channels"]
    assert s["labels"] == want["labels"]
    assert len(lfd.load(path, images=False).hand) == len(lfd.load(EXP1, images=False).hand)


def test_info_lists_a_recording_without_tags(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A video without tags: the hand on the camera topic only, no object pose. ``lfd info``
    lists the camera topic and says in a warning that segmenting refuses it (exit 0)."""
    from lfd.io import McapRecorder

    path = tmp_path / "notags.mcap"
    with McapRecorder(path) as rec:
        for i in range(20):
            rec.add_hand(
                1_700_000_000_000_000_000 + i * 40_000_000, np.ones((21, 3)), frame="camera"
            )
    assert main(["info", str(path)]) == 0
    out, err = capsys.readouterr()
    assert "/hand/right/keypoints_camera" in out
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("lfd info: warning: "), err
    assert "not a usable lfd recording" in lines[0]


def _inflating(path: Path, topic: str, n: int) -> Path:
    """exp1 plus ``n`` 1 MiB messages on ``topic`` (5 KiB random, then zeros): a file of about
    n * 5 KiB that inflates ~200x, within the decompression budget."""
    import os

    from mcap.writer import Writer

    with open(EXP1, "rb") as f, open(path, "wb") as out:
        reader = make_reader(f)
        w = Writer(out)
        w.start(profile="", library="inflating")
        copy_records(reader, w)
        junk = w.register_channel(topic, "protobuf", 0, {})
        for i in range(n):
            t = 1_700_000_000_000_000_000 + i
            w.add_message(junk, t, os.urandom(5 * 1024) + bytes(2**20 - 5 * 1024), t)
        w.finish()
    return path


_MEASURED = """
import os, subprocess, sys
p = subprocess.Popen(sys.argv[1:], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
err = p.stderr.read()
_, status, usage = os.wait4(p.pid, 0)
sys.stderr.write(err)
print(usage.ru_maxrss, os.waitstatus_to_exitcode(status))
"""


@pytest.mark.slow
@pytest.mark.parametrize("topic", ["/tf", "/lfd/ground_truth"])
@pytest.mark.parametrize("killed", [False, True])
def test_info_memory_is_bounded(topic: str, killed: bool, tmp_path: Path) -> None:
    """A file of ~8 MB inflating to 1.5 GiB: lfd info peaks under 300 MB, with or without its
    summary; labels beyond 64 MiB are one error line (exit 2)."""
    import subprocess
    import sys

    path = _inflating(tmp_path / "big.mcap", topic, 1500)
    if killed:
        data = path.read_bytes()
        path.write_bytes(data[: int(len(data) * 0.6)])
    # through a small launcher: a child forked from this process (its RSS grown by the tests
    # before) starts with this process's peak memory in its ru_maxrss
    proc = subprocess.run(
        [sys.executable, "-c", _MEASURED, sys.executable, "-m", "lfd.cli", "info", str(path)],
        capture_output=True,
        text=True,
        check=True,
    )
    maxrss_kb, returncode = (int(v) for v in proc.stdout.split())
    err = proc.stderr
    assert maxrss_kb / 1024 < 300, maxrss_kb
    lines = [line for line in err.splitlines() if line.strip()]
    if topic == "/tf":
        assert returncode == 0, err
    else:
        assert returncode == 2, err
        assert lines[-1].startswith("lfd info: error: ") and "label channels" in lines[-1]
