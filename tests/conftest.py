"""Test session setup shared by every test module."""

import os

# Headless OpenGL for MuJoCo and no telemetry from Rerun, before either library is imported.
import lfd._gl  # noqa: F401

os.environ.setdefault("RERUN_TELEMETRY", "0")
