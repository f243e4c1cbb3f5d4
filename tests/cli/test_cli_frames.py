"""``lfd record --source frames:DIR``: its ``timestamps.txt`` and its folder as an input.

A timestamp is an integer below 2**63 (recordings count ns in signed 64-bit), read with
:func:`lfd.inputs.parse_integer`; the whole folder is read, so no output is written inside it.
Each refusal is exit 2, one line, nothing changed (:func:`test_cli_inputs._refused`).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from test_cli_inputs import _refused


@pytest.fixture
def frames(tmp_path: Path) -> Path:
    """A frames folder of three 64x48 grey images and their camera.json."""
    import cv2
    import numpy as np

    d = tmp_path / "F"
    (d / "color").mkdir(parents=True)
    for k in range(3):
        cv2.imwrite(str(d / "color" / f"{k:06d}.png"), np.full((48, 64, 3), 120, np.uint8))
    doc = {"width": 64, "height": 48, "K": [[50, 0, 32], [0, 50, 24], [0, 0, 1]]}
    (d / "camera.json").write_text(json.dumps(doc), encoding="utf-8")
    return d


@pytest.mark.parametrize(
    ("third", "expected"),
    [
        ("18446744073709551616", "line 3: timestamp 18446744073709551616 ns is not below 2**63"),
        ("9223372036854775808", "line 3: timestamp 9223372036854775808 ns is not below 2**63"),
        ("1_0", "line 3: one integer nanosecond timestamp per line, got '1_0'"),
    ],
    ids=["2**64", "2**63", "underscore"],
)
def test_frames_timestamp_out_of_range(
    frames: Path, tmp_path: Path, capsys: Any, third: str, expected: str
) -> None:
    """Was: 2**64 a struct.error at close (exit 1), 2**63 "must be >= 0 ns and strictly
    increasing", ``1_0`` taken as 10."""
    (frames / "timestamps.txt").write_text(f"1\n2\n{third}\n", encoding="utf-8")
    argv = ["record", "--source", f"frames:{frames}", "--no-hand", "-o", tmp_path / "x.mcap"]
    line = _refused(argv, capsys, tmp_path, expected)
    assert "timestamps.txt" in line


@pytest.mark.parametrize("inside", ["color/zz.mcap", "zz.mcap"])
def test_record_output_inside_the_frames_folder(
    frames: Path, tmp_path: Path, capsys: Any, inside: str
) -> None:
    """Was: written into the folder read; a re-run with --overwrite read it as a frame."""
    for extra in ([], ["--overwrite"]):
        argv = ["record", "--source", f"frames:{frames}", "--no-hand", "-o", frames / inside]
        _refused([*argv, *extra], capsys, tmp_path, "a frames: source folder being read")


def test_record_frames_beside_the_folder_still_works(
    frames: Path, tmp_path: Path, capsys: Any
) -> None:
    from lfd.cli import main

    (frames / "timestamps.txt").write_text("1\n2\n9223372036854775807\n", encoding="utf-8")
    argv = ["record", "--source", f"frames:{frames}", "--no-hand", "-o", tmp_path / "x.mcap"]
    assert main([str(a) for a in argv]) == 0
    assert (tmp_path / "x.mcap").is_file()
