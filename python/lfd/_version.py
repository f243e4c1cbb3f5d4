"""The installed package's version (a module of its own so that any stage can import it)."""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("lfd")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.0.0"
