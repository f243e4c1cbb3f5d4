"""``camera.json``: the one reader and validator of a camera description (``lfd record``).

A camera description is read as what it is, and every value that would break a later stage or
silently give a wrong recording is refused in one :class:`~lfd.errors.LfdError` line naming the
file and the field:

- ``width``, ``height``: integers in [1, :data:`MAX_IMAGE_SIDE`];
- ``K``: a finite 3x3 pinhole matrix, upper triangular, last row exactly ``0 0 1``, focal
  lengths in :data:`~lfd.demo.FOCAL_RANGE_PX`, skew at most :data:`~lfd.demo.MAX_SKEW` of
  ``fx``, the principal point inside the image (:func:`lfd.demo.k_problem`);
- ``world_T_camera`` (optional): a finite rigid transform, a rotation block orthonormal with
  determinant +1 (within :data:`~lfd.demo.ROTATION_TOLERANCE`), last row ``0 0 0 1``, the
  translation under :data:`~lfd.demo.MAX_TRANSLATION_M` (:func:`lfd.demo.pose_problem`; the
  camera a recording holds is checked by the same two rules when it is read);
- ``fps`` (optional): a number in (0, :data:`MAX_FPS`] (a string is refused);
- ``objects``: a list of ``{"name", "tag_id", "size", "tag_size"?}``: a name the recording can
  use as a topic (:func:`lfd.io.writer.object_name_problem`), a tag id an integer in
  [0, :data:`~lfd.demo.MAX_TAG_ID`] (:func:`lfd.demo.tag_id_problem`, the ROS topic mapping's
  rule too; the ArUco dictionary's own range is checked by the tag tracker), 3
  sizes and the tag side in :data:`SIZE_RANGE_M`.

The other limits of a recording's inputs are here too: the camera device index
(:func:`camera_index`) and the hand rate (:func:`check_hand_rate`).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from ..demo import (
    MAX_IMAGE_SIDE,
    CameraInfo,
    is_number,
    k_problem,
    pose_problem,
    shared_tag_problem,
    tag_id_problem,
    whole_number,
)
from ..errors import LfdError
from ..io.sizes import MAX_OBJECT_SIDE_M

SIZE_RANGE_M = (0.001, MAX_OBJECT_SIDE_M)
"""Plausible object sizes and tag sides (m); the longest is every size source's
(:data:`lfd.io.sizes.MAX_OBJECT_SIDE_M`)."""
MAX_FPS = 1000.0
"""Largest frame rate (Hz)."""
MAX_CAMERA_INDEX = 63
"""Largest OpenCV device index ``lfd record --source camera:N`` opens."""
HAND_RATE_RANGE_HZ = (0.1, 1000.0)
"""Plausible hand sample rates (Hz)."""


def length_problem(value: Any, what: str) -> str | None:
    """What is wrong with a length in metres (None: within :data:`SIZE_RANGE_M`)."""
    lo, hi = SIZE_RANGE_M
    if not is_number(value) or not math.isfinite(value) or not lo <= value <= hi:
        return f"{what} must be a length in [{lo:g}, {hi:g}] m, got {value!r}"
    return None


def check_hand_rate(hz: Any, what: str = "hand rate") -> float:
    """The hand sample rate in Hz, within :data:`HAND_RATE_RANGE_HZ`, or an :class:`LfdError`."""
    lo, hi = HAND_RATE_RANGE_HZ
    if not is_number(hz) or not math.isfinite(hz) or not lo <= hz <= hi:
        raise LfdError(f"{what} must be a number in [{lo:g}, {hi:g}] Hz, got {hz!r}")
    return float(hz)


def camera_index(text: str | int) -> int:
    """A camera device index ``N`` of ``camera:N``: an integer in [0, :data:`MAX_CAMERA_INDEX`]
    (OpenCV is not asked about anything else: -1 crashes some of its backends)."""
    value = str(text).strip()
    if not value.isdigit() or int(value) > MAX_CAMERA_INDEX:
        raise LfdError(
            f"camera source: the device index must be an integer in [0, {MAX_CAMERA_INDEX}], "
            f"got {str(text)[:40]!r}"
        )
    return int(value)


def _object(o: Any, k: int) -> dict[str, Any]:
    """One entry of ``objects``, checked."""
    from ..io.writer import object_name_problem

    where = f"objects[{k}]"
    if not isinstance(o, dict):
        raise ValueError(f"{where} must be an object with name, tag_id and size")
    for key in ("name", "tag_id", "size"):
        if key not in o:
            raise ValueError(f"{where}: missing {key!r}")
    name = o["name"]
    problem = object_name_problem(name) if isinstance(name, str) else "must be a string"
    if problem is not None:
        raise ValueError(f"{where}.name {name!r}: {problem}")
    problem = tag_id_problem(o["tag_id"])
    if problem is not None:
        raise ValueError(f"{where}.tag_id of {name!r} {problem}")
    size = o["size"]
    if not isinstance(size, list) or len(size) != 3:
        raise ValueError(f"{where}.size of {name!r} must be 3 lengths (m), got {size!r}")
    for v in [*size, *([o["tag_size"]] if "tag_size" in o else [])]:
        problem = length_problem(v, f"{where} ({name!r}): size and tag_size")
        if problem is not None:
            raise ValueError(problem)
    out: dict[str, Any] = {
        "name": name,
        "tag_id": int(o["tag_id"]),
        "size": [float(v) for v in size],
    }
    if "tag_size" in o:
        out["tag_size"] = float(o["tag_size"])
    return out


def _size(meta: dict[str, Any], key: str) -> int:
    if key not in meta:
        raise ValueError(f"missing {key!r}")
    side = whole_number(meta[key], 1, MAX_IMAGE_SIDE)
    if side is None:
        raise ValueError(f"{key} must be an integer in [1, {MAX_IMAGE_SIDE}] px, got {meta[key]!r}")
    return side


def _fps(meta: dict[str, Any]) -> float | None:
    if "fps" not in meta:
        return None
    fps = meta["fps"]
    if not is_number(fps) or not math.isfinite(fps) or not 0 < fps <= MAX_FPS:
        raise ValueError(f"fps must be a number in (0, {MAX_FPS:g}] Hz, got {fps!r}")
    return float(fps)


def parse_camera(meta: Any) -> tuple[CameraInfo, list[dict[str, Any]], float | None, bool]:
    """A parsed camera description -> camera, objects, fps (None: not given) and whether the
    camera pose is given; a ``ValueError`` names the first field that is wrong."""
    if not isinstance(meta, dict):
        raise ValueError("expected a JSON object with width, height, K and objects")
    width, height = _size(meta, "width"), _size(meta, "height")
    if "K" not in meta:
        raise ValueError("missing 'K'")
    problem = k_problem(meta["K"], width, height)
    if problem is not None:
        raise ValueError(problem)
    known = "world_T_camera" in meta
    pose = meta.get("world_T_camera", np.eye(4).tolist())
    problem = pose_problem(pose)
    if problem is not None:
        raise ValueError(f"world_T_camera {problem}")
    objects = meta.get("objects", [])
    if not isinstance(objects, list):
        raise ValueError("objects must be a list")
    parsed = [_object(o, k) for k, o in enumerate(objects)]
    names = [o["name"] for o in parsed]
    if len(set(names)) != len(names):
        raise ValueError(f"object names must be distinct, got {names}")
    problem = shared_tag_problem({o["name"]: o["tag_id"] for o in parsed})
    if problem is not None:
        raise ValueError(f"objects: {problem}; each tag is on one object")
    camera = CameraInfo(width, height, np.asarray(meta["K"], float), np.asarray(pose, float))
    return camera, parsed, _fps(meta), known


def read_camera_json(path: Path) -> tuple[CameraInfo, list[dict[str, Any]], dict[str, Any], bool]:
    """Read and validate ``camera.json``: camera, objects, the document (``fps`` checked, a
    float when given) and whether the camera pose is given. Anything wrong is one
    :class:`LfdError` line naming the file and the field."""
    from ..inputs import parse_json, read_text

    path = Path(path)
    if not path.is_file():
        raise LfdError(f"{path}: missing (intrinsics and objects, see lfd.perception.sources)")
    meta = parse_json(read_text(path, "camera description", LfdError), str(path), LfdError)
    try:
        camera, objects, fps, known = parse_camera(meta)
    except ValueError as err:
        raise LfdError(f"{path}: {' '.join(str(err).split())[:300]}") from None
    if fps is not None:
        meta["fps"] = fps
    return camera, objects, meta, known
