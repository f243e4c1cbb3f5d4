"""Every path a command reads, given the files it was given: what no output may damage.

A recording is read with its object-size sidecar (:func:`lfd.io.sizes.sidecar_path`); a ROS 2
bag is a directory read as a whole (every file in it, named by the directory or by one of its
storage files). :func:`read_paths` lists them as :class:`lfd.outputs.ReadPath` s, which
:func:`lfd.outputs.check_output` and :func:`~lfd.outputs.check_output_dir` refuse as outputs
(nor write inside a bag directory).
"""

from __future__ import annotations

import os
from collections.abc import Iterable

from ..outputs import STDOUT, ReadPath
from .reader import is_ros_path
from .sizes import sidecar_path

__all__ = ["read_paths"]


def read_paths(inputs: Iterable[str | os.PathLike[str] | ReadPath | None]) -> list[ReadPath]:
    """Every path read for the files ``inputs`` (``None`` and ``-`` skipped, a
    :class:`ReadPath` kept as it is): each one, its object-size sidecar (read for a recording;
    refused as an output for any input), and the ROS 2 bag directory it is or lies in (nothing
    may be written inside it)."""
    out: list[ReadPath] = []
    for inp in inputs:
        if isinstance(inp, ReadPath):
            out.append(inp)
            continue
        if inp is None or os.fspath(inp) in ("", STDOUT):
            continue
        given = os.fspath(inp)
        bag = os.path.isdir(given) and is_ros_path(given)
        out.append(ReadPath(given, tree=bag))
        out.append(ReadPath(sidecar_path(given), why=f"the object sizes of {given}"))
        parent = os.path.dirname(os.path.abspath(given))
        if os.path.isfile(given) and os.path.isdir(parent) and is_ros_path(parent):
            out.append(ReadPath(parent, why=f"it holds {given}", tree=True))
    return out
