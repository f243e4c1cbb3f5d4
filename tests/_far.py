"""A recording whose object is out of the arm's reach wherever a layout puts it (made with lfd's
own writer from a shipped recording)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import lfd
import numpy as np
from _paths import EXP1


def far_recording(path: Path, name: str = "box_1", dx: float = 3.0) -> Path:
    """exp1 with ``name`` ``dx`` m further along x all along: out of the arm's reach."""
    demo = lfd.load(EXP1, images=False)
    box = demo.objects[name]
    far = dataclasses.replace(box, position=box.position + np.array([dx, 0.0, 0.0]))
    meta = {k: v for k, v in demo.metadata.items() if k != "load_report"}
    lfd.save(dataclasses.replace(demo, objects={**demo.objects, name: far}, metadata=meta), path)
    return path
