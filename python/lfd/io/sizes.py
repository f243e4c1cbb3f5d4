"""Object sizes a recording does not carry: given sizes, the sidecar file, the default cube.

The segmentation needs every object's box size (``d_i`` of the paper). A file written by another
tool in lfd's topic layout, or a ROS bag, may not declare them. :func:`resolve_sizes` takes the
size of each object from, in this order:

1. ``object_sizes={name: (x, y, z)}`` given to :func:`lfd.load` (``--object-size NAME=X,Y,Z``);
2. the sidecar file ``<recording>.sizes.toml`` beside the recording (:func:`sidecar_path`)::

       [sizes]
       box_1 = [0.05, 0.05, 0.05]   # metres, x y z

3. the recording itself (the ``demo`` metadata record or the pose channel's metadata; for a ROS
   bag, the topic mapping file);
4. else :data:`DEFAULT_OBJECT_SIZE`, with one :class:`~lfd.errors.DefaultSizeWarning` per object.

Sizes are three positive, finite lengths in metres, each at most :data:`MAX_OBJECT_SIDE_M` (every
source goes through :func:`check_size`, as does ``camera.json``'s); a given size for an object the recording
does not have is refused with :class:`~lfd.errors.UsageError` listing the objects it has.
"""

from __future__ import annotations

import math
import os
import warnings
from collections.abc import Mapping, Sequence
from typing import Any

from ..errors import DefaultSizeWarning, UsageError

__all__ = [
    "DEFAULT_OBJECT_SIZE",
    "MAX_OBJECT_SIDE_M",
    "SIDECAR_SUFFIX",
    "check_size",
    "parse_object_size",
    "read_sidecar",
    "resolve_sizes",
    "sidecar_path",
]

DEFAULT_OBJECT_SIZE: tuple[float, float, float] = (0.05, 0.05, 0.05)
"""The size (metres) of an object no source gives a size for: a 5 cm cube."""

MAX_OBJECT_SIDE_M = 2.0
"""The longest side (metres) of an object: a box on a table that a hand picks up, pushes or
stacks. A longer one is a mistake (millimetres given as metres, a misplaced exponent) that would
make the simulator build a scene kilometres wide or overflow; it is refused with one line."""

SIDECAR_SUFFIX = ".sizes.toml"
"""``REC.mcap`` -> ``REC.mcap.sizes.toml`` (a ROS 2 bag directory ``BAG`` -> ``BAG.sizes.toml``)."""

Size = tuple[float, float, float]


def sidecar_path(path: str | os.PathLike[str]) -> str:
    """The sidecar size file of a recording: its path plus :data:`SIDECAR_SUFFIX`."""
    return os.fspath(path).rstrip("/" + os.sep) + SIDECAR_SUFFIX


def check_size(value: Any, where: str) -> Size:
    """``value`` as three positive finite lengths in metres, each at most
    :data:`MAX_OBJECT_SIDE_M`, else :class:`UsageError` (the one rule of every size source)."""
    ok = (
        isinstance(value, (list, tuple))
        and len(value) == 3
        and all(
            isinstance(v, (int, float))
            and not isinstance(v, bool)
            and math.isfinite(v)
            and 0 < v <= MAX_OBJECT_SIDE_M
            for v in value
        )
    )
    if not ok:
        raise UsageError(
            f"{where}: a size is three positive finite lengths in metres [x, y, z], each at "
            f"most {MAX_OBJECT_SIDE_M:g} m (an object a hand handles), got {value!r}"
        )
    return (float(value[0]), float(value[1]), float(value[2]))


def parse_object_size(text: str) -> tuple[str, Size]:
    """``NAME=X,Y,Z`` (metres) -> ``(name, (x, y, z))``; :class:`UsageError` when malformed."""
    name, sep, rest = text.partition("=")
    name = name.strip()
    where = f"--object-size {text}"
    if not sep or not name:
        raise UsageError(
            f"{where}: expected NAME=X,Y,Z in metres, e.g. box_1=0.05,0.05,0.05, got {text!r}"
        )
    from ..inputs import parse_number

    try:
        values = [parse_number(v) for v in rest.split(",")]
    except ValueError:
        raise UsageError(
            f"{where}: expected NAME=X,Y,Z with three numbers in metres, e.g. "
            f"box_1=0.05,0.05,0.05, got {text!r}"
        ) from None
    return name, check_size(values, where)


def read_sidecar(path: str | os.PathLike[str]) -> dict[str, Size] | None:
    """The sizes of a recording's sidecar file (:func:`sidecar_path`), or None if it has none.

    Raises
    ------
    UsageError
        The sidecar is not TOML, lacks the ``[sizes]`` table or holds a malformed size.
    """
    from ..inputs import parse_toml, read_text

    side = sidecar_path(path)
    if not os.path.lexists(side):
        return None
    text = read_text(side, not_text="is not a size file (binary, not UTF-8 TOML text)")
    doc = parse_toml(text, f"{side}: not valid TOML")
    unknown = sorted(set(doc) - {"sizes"})
    if unknown:
        raise UsageError(f"{side}: unknown key {unknown[0]!r}; expected a [sizes] table")
    sizes = doc.get("sizes")
    if not isinstance(sizes, dict):
        raise UsageError(f"{side}: expected a [sizes] table of NAME = [x, y, z] (metres)")
    return {str(k): check_size(v, f"{side}: sizes.{k}") for k, v in sizes.items()}


def _unknown(given: Mapping[str, Any], names: Sequence[str], where: str) -> None:
    unknown = [n for n in given if n not in names]
    if unknown:
        raise UsageError(
            f"{where} gives a size for object {unknown[0]!r}, which the recording does not "
            f"have; its objects are {', '.join(names) or 'none'}"
        )


def resolve_sizes(
    path: str | os.PathLike[str],
    declared: Mapping[str, Any],
    object_sizes: Mapping[str, Sequence[float]] | None = None,
) -> dict[str, Size]:
    """The size of each object of ``declared`` (name -> size from the recording, or None).

    Order: ``object_sizes``, the sidecar file, ``declared``, :data:`DEFAULT_OBJECT_SIZE` (with a
    :class:`~lfd.errors.DefaultSizeWarning` per object). Names in ``object_sizes`` or the
    sidecar that are not in ``declared`` raise :class:`UsageError`.
    """
    names = list(declared)
    given = {
        str(k): check_size(v, f"object size of {k!r}") for k, v in (object_sizes or {}).items()
    }
    _unknown(given, names, "--object-size")
    side = read_sidecar(path) or {}
    _unknown(side, names, sidecar_path(path))
    out: dict[str, Size] = {}
    for name in names:
        size = given.get(name) or side.get(name)
        if size is None and declared[name] is not None:
            size = check_size(declared[name], f"{path}: the size of object {name!r}")
        if size is None:
            warnings.warn(
                f"object {name} has no size; using {DEFAULT_OBJECT_SIZE[0]:g} m cube, give it with "
                f"--object-size {name}=X,Y,Z (metres) or in {os.path.basename(sidecar_path(path))}",
                DefaultSizeWarning,
                stacklevel=3,
            )
            size = DEFAULT_OBJECT_SIZE
        out[name] = size
    return out
