"""The served web viewer as a user opens it, in a real headless Chromium (opt-in).

Run with ``LFD_BROWSER_TESTS=1`` on a machine with Chromium (Debian: ``apt install chromium``).
"""

from __future__ import annotations

import io
import os
import subprocess
import sys
import time
import urllib.parse
import urllib.request
from pathlib import Path

import _paths
import numpy as np
import pytest
from _browser import chromium, visit

ROOT = _paths.ROOT
EXP1 = ROOT / "recordings" / "exp1.mcap"


def _skip_unless_possible() -> None:
    if os.environ.get("LFD_BROWSER_TESTS") != "1":
        pytest.skip("opt-in: set LFD_BROWSER_TESTS=1 (needs Chromium)")
    if chromium() is None:
        pytest.skip("Chromium is not installed (Debian: apt install chromium)")
    pytest.importorskip("websockets", reason="the DevTools client needs websockets")
    pytest.importorskip("rerun", reason="rerun-sdk not installed")


@pytest.mark.slow
def test_served_viewer_shows_the_skill_timeline_in_a_browser(tmp_path: Path) -> None:
    """``lfd segment rec.mcap --rerun-serve-for``: the page loads the viewer, connects to the
    gRPC server and draws the skill lanes (their colours on screen; a blank page has none)."""
    _skip_unless_possible()
    from lfd.viz.session import DEFAULT_GRPC_PORT, DEFAULT_WEB_PORT, _port_open
    from PIL import Image

    if _port_open(DEFAULT_GRPC_PORT) or _port_open(DEFAULT_WEB_PORT):
        pytest.skip(f"ports {DEFAULT_GRPC_PORT}/{DEFAULT_WEB_PORT} are in use (a viewer running?)")
    proc = subprocess.Popen(
        [sys.executable, "-m", "lfd.cli", "segment", str(EXP1), "--rerun-serve-for", "120"],
        stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    )  # fmt: skip
    try:
        assert proc.stdout is not None
        url = None
        deadline = time.monotonic() + 120
        while url is None and time.monotonic() < deadline:
            line = proc.stdout.readline()
            if not line:
                break
            if "serving until" in line:
                url = line.split()[3]
        assert url is not None, "lfd segment did not print the viewer address"
        assert urllib.parse.urlsplit(url).hostname == "127.0.0.1"
        try:
            png, requests = visit(url, seconds=25)
            blank, _ = visit("about:blank", seconds=1)
        except RuntimeError as err:
            pytest.skip(f"headless Chromium cannot run here: {err}")
    finally:
        proc.terminate()
        proc.wait(timeout=30)
    (tmp_path / "viewer.png").write_bytes(png)
    pixels = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.int64)
    empty = np.asarray(Image.open(io.BytesIO(blank)).convert("RGB"), dtype=np.int64)
    assert len(np.unique(empty.reshape(-1, 3), axis=0)) < 5  # what a blank page looks like
    assert len(np.unique(pixels.reshape(-1, 3), axis=0)) > 200
    # the skill timeline (top right in the default layout): coloured lanes, where the dark
    # theme's chrome is grey (the viewer shades the lane colours, so no exact match)
    h, w, _ = pixels.shape
    lanes = pixels[: int(0.3 * h), w // 2 :]
    saturated = (lanes.max(axis=2) - lanes.min(axis=2)) > 80
    assert saturated.mean() > 0.05, saturated.mean()
    # the page connected to the gRPC server
    grpc = urllib.parse.parse_qs(urllib.parse.urlsplit(url).query)["url"][0]
    grpc_host = urllib.parse.urlsplit(grpc).netloc
    assert any(grpc_host in r for r in requests), requests
    # what else the page asks for (telemetry and more; docs/viz.md lists it)
    external = sorted(
        {urllib.parse.urlsplit(r).hostname or "" for r in requests} - {"127.0.0.1", "localhost", ""}
    )
    print("external hosts the viewer page contacted:", external)
