"""Screenshots of a saved recording in the headless native viewer (docs, tests).

From a shell: ``python -m lfd.cli.screenshot IN.rrd OUT.png`` (:mod:`lfd.cli.screenshot`).

Needs a Vulkan driver; on Debian without a GPU: ``apt-get install mesa-vulkan-drivers``
(software rendering with llvmpipe).
"""

from __future__ import annotations

import os
import socket
import time
from pathlib import Path

from .recording import import_rerun


def free_port() -> int:
    """A TCP port that is free on localhost right now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def screenshot(
    rrd: str | os.PathLike[str],
    png: str | os.PathLike[str],
    *,
    settle_s: float = 2.0,
    max_width: int | None = None,
    time_s: float | None = None,
    timeline: str = "demo_time",
    view: str | None = None,
) -> Path:
    """Open ``rrd`` in a headless viewer and save a screenshot of the whole window to ``png``.

    Parameters
    ----------
    rrd : path
        A saved recording (its default blueprint is used).
    png : path
        Output image.
    settle_s : float
        Seconds to let the viewer load and lay out before the capture.
    max_width : int, optional
        Downscale (and palette-quantise) the capture to at most this width, for small files.
    time_s : float, optional
        Pause the time cursor of ``timeline`` at this many seconds (else it plays from 0).
    view : str, optional
        Capture only the view with this name (e.g. ``"Scene (reference marker frame)"``).

    Returns
    -------
    Path
        ``png``.

    Raises
    ------
    RuntimeError
        If the viewer cannot start (no graphics adapter) or the capture fails.
    """
    rr = import_rerun()
    out = Path(png).resolve()
    out.parent.mkdir(parents=True, exist_ok=True)
    viewer = rr.experimental.ViewerClient.spawn(headless=True, port=free_port())
    try:
        viewer.open(str(Path(rrd).resolve()))
        deadline = time.monotonic() + 30.0
        while viewer.get_state().loading and time.monotonic() < deadline:
            time.sleep(0.2)
        if time_s is not None:
            viewer.set_time(timeline, duration=float(time_s), play_state="paused")
        time.sleep(settle_s)
        view_id = None
        if view is not None:
            views = {v.name: v.view_id for v in viewer.get_state().views}
            if view not in views:
                raise RuntimeError(f"no view named {view!r}; views: {sorted(views)}")
            view_id = views[view]
        viewer.save_screenshot(str(out), view_id=view_id)
    finally:
        viewer.quit()
    if max_width is not None:
        from PIL import Image

        with Image.open(out) as img:
            rgb = img.convert("RGB")
        if rgb.width > max_width:
            h = round(rgb.height * max_width / rgb.width)
            rgb = rgb.resize((max_width, h), Image.Resampling.LANCZOS)
        rgb.quantize(colors=256, method=Image.Quantize.MEDIANCUT).save(out, optimize=True)
    return out
