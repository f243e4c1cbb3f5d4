"""Drive a headless Chromium over the DevTools protocol: open a page, record requests, screenshot."""

from __future__ import annotations

import base64
import json
import os
import shutil
import subprocess
import tempfile
import time
import urllib.request
from typing import Any


def chromium() -> str | None:
    """The Chromium executable, if installed."""
    for name in ("chromium", "chromium-browser", "google-chrome"):
        found = shutil.which(name)
        if found:
            return found
    return None


def visit(
    url: str, seconds: float, size: tuple[int, int] = (1600, 1000)
) -> tuple[bytes, list[str]]:
    """Load ``url``, wait ``seconds``, return (PNG screenshot, URLs the page requested)."""
    from websockets.sync.client import connect

    exe = chromium()
    assert exe is not None
    profile = tempfile.mkdtemp(prefix="lfd-chromium-")
    proc = subprocess.Popen(
        [exe, "--headless=new", "--no-sandbox", "--use-angle=swiftshader",
         "--enable-unsafe-swiftshader", "--remote-debugging-port=0",
         f"--user-data-dir={profile}", f"--window-size={size[0]},{size[1]}", "about:blank"],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )  # fmt: skip
    try:
        port_file = os.path.join(profile, "DevToolsActivePort")
        deadline = time.monotonic() + 30
        while not (os.path.exists(port_file) and open(port_file).read().strip()):
            if time.monotonic() > deadline or proc.poll() is not None:
                raise RuntimeError("chromium did not start")
            time.sleep(0.1)
        port = int(open(port_file).read().split()[0])
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list", timeout=10) as resp:
            pages = json.load(resp)
        ws = next(p for p in pages if p["type"] == "page")["webSocketDebuggerUrl"]
        requests: list[str] = []
        with connect(ws, max_size=2**27) as conn:
            counter = [0]

            def call(method: str, timeout: float = 30.0, **params: Any) -> Any:
                counter[0] += 1
                conn.send(json.dumps({"id": counter[0], "method": method, "params": params}))
                return pump(timeout, counter[0])

            def pump(timeout: float, want: int | None = None) -> Any:
                end = time.monotonic() + timeout
                while time.monotonic() < end:
                    try:
                        msg = json.loads(conn.recv(timeout=max(0.01, end - time.monotonic())))
                    except TimeoutError:
                        break
                    if msg.get("method") == "Network.requestWillBeSent":
                        requests.append(msg["params"]["request"]["url"])
                    if want is not None and msg.get("id") == want:
                        return msg.get("result")
                return None

            call("Network.enable")
            call("Page.enable")
            call("Page.navigate", url=url)
            pump(seconds)
            shot = call("Page.captureScreenshot", format="png")
        return base64.b64decode(shot["data"]), requests
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
        shutil.rmtree(profile, ignore_errors=True)
