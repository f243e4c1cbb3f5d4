"""Choose MuJoCo's OpenGL backend before MuJoCo is first imported.

MuJoCo picks its rendering backend once, at import, from ``MUJOCO_GL``. Without a display the
default (GLFW) cannot create a context, so offscreen rendering needs EGL. Every lfd module that
imports mujoco imports this module first; a user's own ``MUJOCO_GL`` always wins.
"""

from __future__ import annotations

import os


def ensure_headless_gl() -> None:
    """Default ``MUJOCO_GL`` to ``egl`` when no X display is available."""
    if not os.environ.get("DISPLAY"):
        os.environ.setdefault("MUJOCO_GL", "egl")


ensure_headless_gl()
