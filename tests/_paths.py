"""Paths the test modules share, wherever in ``tests/`` they live (``tests/`` is on pytest's
``pythonpath``, so ``from _paths import ROOT`` works from every directory)."""

from __future__ import annotations

from pathlib import Path

TESTS = Path(__file__).resolve().parent
"""``tests/``: the helper modules (``_synthetic``, ``_rosbags``, ...) live here."""
ROOT = TESTS.parent
"""The repository."""
RECORDINGS = ROOT / "recordings"
EXP1 = RECORDINGS / "exp1.mcap"
SHARED = ROOT.parent / "shared"
"""Data that may not be copied into the repository (real motion capture, photographs)."""
