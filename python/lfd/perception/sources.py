"""Frame sources for ``lfd record``: the simulator, a folder of images, a camera, a video file.

Simulator (``--source sim:TASK[:STYLE]``): the simulated demonstrator performing ``TASK``
(``lfd simulate``'s tasks) in the careful style (default) or the natural one
(``sim:exp1:natural``), rendered and perceived like a camera's frames.

A source has ``camera`` (:class:`~lfd.demo.CameraInfo`; ``world_T_camera`` may be None-like
identity until the reference marker is seen), ``objects`` (name, tag_id, size), ``metadata``,
and ``frames()`` yielding :class:`Frame`. Every source goes through the same perception path.

Image folder layout (``--source frames:DIR``)::

    DIR/camera.json        {"width": 640, "height": 480, "K": [[fx,0,cx],[0,fy,cy],[0,0,1]],
                            "fps": 30,                                   (optional, default 30)
                            "objects": [{"name": "box_1", "tag_id": 1,
                                         "size": [0.05, 0.05, 0.05],
                                         "tag_size": 0.042}],            (tag_size optional)
                            "world_T_camera": [[...4x4...]]}             (optional)
    DIR/color/000000.png   colour frames (any OpenCV-readable format), sorted by name
    DIR/depth/000000.png   depth, 16-bit PNG in millimetres (0 = no data), same names (optional)
    DIR/timestamps.txt     capture time per frame in integer ns (optional, else from fps)

Every ``camera.json`` is read and checked by :mod:`lfd.perception.camera_file` (the fields'
ranges are there); a frame of any source is checked by :func:`check_frame`.

Camera (``--source camera:N``, N in 0-63): ``cv2.VideoCapture(N)`` gives colour; depth comes from a
:class:`DepthReader` (any object with ``read() -> array (H, W) uint16 mm or None``), e.g. a
RealSense / Azure Kinect wrapper aligned to the colour camera. A reader that also has
``read_frame() -> (rgb (H, W, 3) uint8, depth (H, W) uint16 mm)`` supplies both images (an
RGB-D camera whose colour stream is not a separate video device, e.g. a RealSense through
pyrealsense2: ``docs/examples/realsense_reader.py``); then no video device is opened. Intrinsics
come from a ``camera.json`` as above (``--intrinsics``). Without a depth reader the camera is
colour-only (a webcam): the hand is placed from colour alone
(:class:`~lfd.perception.hand.colour.ColourHand`), the tags by PnP.

Video file (``--source video:FILE``): ``cv2.VideoCapture`` on the file, colour only; each
frame's time is the container's (``CAP_PROP_POS_MSEC``), made strictly increasing, else the
frame index over the frame rate (the container's, else ``fps`` of ``camera.json``, else 30).
Intrinsics and objects come from ``--intrinsics camera.json``, whose ``width`` and ``height``
must be the video's frame size.

``has_depth`` tells whether a source gives depth images (the recording's ``depth`` metadata).
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol, cast

import numpy as np

from ..demo import CameraInfo
from ..errors import LfdError
from .camera_file import camera_index, read_camera_json

__all__ = ["KINDS", "DepthReader", "Frame", "Source", "open_source", "read_camera_json"]


def describe(err: BaseException) -> str:
    """An exception as one line: an :class:`LfdError`'s message, any other's type and message
    (``RuntimeError: Frame didn't arrive within 5000``), at most 300 characters."""
    text = " ".join(str(err).split())
    if not isinstance(err, LfdError):
        text = f"{type(err).__name__}: {text}" if text else type(err).__name__
    return text[:300]


def plugin_call(fn: Callable[[], Any], what: str) -> Any:
    """``fn()``, a plug-in's own code (a ``--depth-reader``): whatever it raises but Ctrl+C is
    its failure, one :class:`LfdError` line ``what`` and the error, ``SystemExit`` too (a
    plug-in's exit is not lfd's: the recording's error path keeps what was recorded)."""
    try:
        return fn()
    except KeyboardInterrupt:
        raise
    except BaseException as err:
        raise LfdError(f"{what} {describe(err)}") from err


def check_frame(frame: Any, camera: CameraInfo, what: str) -> Frame:
    """``frame`` if it is a :class:`Frame` of the camera's size (colour (H, W, 3) uint8, depth
    None or (H, W) uint16, an integer time >= 0), else an :class:`LfdError` saying what
    ``what`` gave instead."""
    shape = (camera.height, camera.width)
    if not isinstance(frame, Frame):
        raise LfdError(f"{what} gave a {type(frame).__name__}, not a Frame")
    t = frame.t_ns
    if isinstance(t, bool | np.bool_) or not isinstance(t, int | np.integer) or t < 0:
        raise LfdError(f"{what} gave a frame time {t!r}, not integer nanoseconds >= 0")
    rgb, depth = frame.color, frame.depth
    if not isinstance(rgb, np.ndarray) or rgb.dtype != np.uint8 or rgb.shape != (*shape, 3):
        raise LfdError(
            f"{what} gave a colour image {_array(rgb)}; the intrinsics are for "
            f"{shape[1]}x{shape[0]} uint8 RGB, (H, W, 3) = {(*shape, 3)}"
        )
    if depth is not None and (
        not isinstance(depth, np.ndarray) or depth.dtype != np.uint16 or depth.shape != shape
    ):
        raise LfdError(
            f"{what} gave depth {_array(depth)}; expected uint16 mm {shape}, aligned with the "
            "colour camera"
        )
    return frame


def _array(a: Any) -> str:
    return f"{a.dtype} {a.shape}" if isinstance(a, np.ndarray) else f"of type {type(a).__name__}"


@dataclass
class Frame:
    """One frame: capture time (ns), colour (H, W, 3) uint8 RGB, depth (H, W) uint16 mm or None."""

    t_ns: int
    color: np.ndarray
    depth: np.ndarray | None


class DepthReader(Protocol):
    """A depth camera aligned with the colour camera: the latest depth frame (H, W) uint16 mm."""

    def read(self) -> np.ndarray | None: ...


@dataclass
class Source:
    """Common fields of a frame source."""

    camera: CameraInfo
    objects: list[dict[str, Any]]
    metadata: dict[str, Any] = field(default_factory=dict)
    camera_pose_known: bool = False
    has_depth: bool = True
    fps: float | None = None
    """The nominal frame rate (Hz), when the source knows it (a video file)."""

    def frames(self) -> Iterator[Frame]:  # pragma: no cover - overridden
        raise NotImplementedError

    def close(self) -> None:
        """Release the device (no-op by default)."""

    def world_T_camera_if_known(self) -> np.ndarray | None:
        """The calibrated camera pose, if the source provides one (else the reference tag)."""
        return self.camera.world_T_camera if self.camera_pose_known else None

    def calibration_frame(self) -> Frame | None:
        """A frame of the empty workspace to find the reference marker before recording."""
        return None


class SimSource(Source):
    """The simulated demonstrator rendered frame by frame (colour + depth, 640x480); ``style``
    selects the demonstrator (``careful`` or ``natural``, :class:`~lfd.sim.Variability`)."""

    def __init__(
        self,
        task: str,
        *,
        seed: int = 0,
        fps: float = 30.0,
        duration: float | None = None,
        style: str = "careful",
    ):
        from ..sim import Variability, simulate
        from ..sim.demonstrator import crop
        from ..sim.variability import STYLES, Style

        if style not in STYLES:
            raise LfdError(f"sim source: style must be one of {', '.join(STYLES)}, got {style!r}")
        try:
            self.result = simulate(
                task,
                seed=seed,
                variability=Variability(style=cast(Style, style)),
                object_rate_hz=fps,
            )
        except (KeyError, ValueError) as err:
            raise LfdError(f"sim source: {err}") from err
        if duration is not None:
            self.result = crop(self.result, duration)
        demo = self.result.demo
        assert demo.camera is not None
        objects = [
            {"name": o.name, "tag_id": o.tag_id, "size": list(o.size)}
            for o in self.result.scene.objects
        ]
        meta = {
            "source": f"sim:{task}" + (f":{style}" if style != "careful" else ""),
            "task": task,
            "seed": seed,
            "style": style,
            "simulator": "lfd.sim",
        }
        super().__init__(demo.camera, objects, meta, camera_pose_known=False)
        self.labels = list(demo.labels)
        self.handovers = list(demo.handovers)
        self.sides: tuple[str, ...] = tuple(self.result.scene.sides)
        """The hands of the simulated scene (``("right", "left")`` for a two-hand task)."""

    def calibration_frame(self) -> Frame | None:
        """The first frame rendered with the hand out of view (the workspace before the demo)."""
        from dataclasses import replace

        from ..sim.render import render_frames

        truth = self.result.truth
        away = replace(truth, wrist_pos=truth.wrist_pos.copy())
        away.wrist_pos[0] = (0.0, -1.2, 1.5)
        color, depth = render_frames(self.result.scene, away, np.array([0]))
        return Frame(
            int(color.t_ns[0]), color.frames[0], None if depth is None else depth.frames[0]
        )

    def frames(self, chunk: int = 10) -> Iterator[Frame]:
        from ..sim.render import render_frames

        truth = self.result.truth
        n = truth.t_ns.size
        for start in range(0, n, chunk):
            idx = np.arange(start, min(n, start + chunk))
            color, depth = render_frames(self.result.scene, truth, idx)
            assert depth is not None
            for k in range(idx.size):
                yield Frame(int(color.t_ns[k]), color.frames[k], depth.frames[k])


def _timestamps(path: Path) -> list[int]:
    """The capture times of ``timestamps.txt``: one integer (ns) per line, read with
    :func:`lfd.inputs.parse_integer` and below 2**63 (recordings count ns in signed 64-bit)."""
    from ..inputs import parse_integer, read_text, shown

    t_ns = []
    for n, line in enumerate(read_text(path, "timestamps", LfdError).splitlines(), 1):
        if not line.strip():
            continue
        try:
            t = parse_integer(line.strip())
        except ValueError:
            raise LfdError(
                f"{path} line {n}: one integer nanosecond timestamp per line, got {shown(line)}"
            ) from None
        if t >= 2**63:
            raise LfdError(
                f"{path} line {n}: timestamp {shown(t)} ns is not below 2**63 "
                "(recordings count ns in signed 64-bit)"
            )
        t_ns.append(t)
    return t_ns


class FolderSource(Source):
    """Colour (+ depth) image files with a ``camera.json`` (layout in the module docstring)."""

    def __init__(self, directory: str | os.PathLike[str]):
        self.dir = Path(directory)
        if not self.dir.is_dir():
            raise LfdError(f"frames source: {self.dir} is not a directory")
        camera, objects, meta, known = read_camera_json(self.dir / "camera.json")
        self.color_files = sorted((self.dir / "color").glob("*.*"))
        if not self.color_files:
            raise LfdError(f"frames source: no images in {self.dir / 'color'}")
        fps = float(meta.get("fps", 30.0))  # checked: a number in (0, 1000]
        ts = self.dir / "timestamps.txt"
        if ts.is_file():
            self.t_ns = _timestamps(ts)
            if any(t < 0 for t in self.t_ns) or any(np.diff(self.t_ns) <= 0):
                raise LfdError(f"{ts}: timestamps must be >= 0 ns and strictly increasing")
            if len(self.t_ns) != len(self.color_files):
                raise LfdError(f"{ts}: {len(self.t_ns)} timestamps, {len(self.color_files)} images")
        else:
            self.t_ns = [round(i * 1e9 / fps) for i in range(len(self.color_files))]
        depth = self.dir / "depth"
        super().__init__(
            camera,
            objects,
            {"source": f"frames:{self.dir}"},
            camera_pose_known=known,
            has_depth=depth.is_dir() and any(depth.iterdir()),
            fps=fps,
        )

    def frames(self) -> Iterator[Frame]:
        import cv2

        from .image_header import decode

        for t, path in zip(self.t_ns, self.color_files, strict=True):
            bgr = decode(path, "image", cv2.IMREAD_COLOR)
            depth = None
            dpath = self.dir / "depth" / f"{path.stem}.png"
            if dpath.is_file():
                depth = decode(dpath, "depth image", cv2.IMREAD_UNCHANGED)
                if depth.dtype != np.uint16 or depth.shape != bgr.shape[:2]:
                    raise LfdError(f"{dpath}: depth must be a 16-bit PNG of the colour image size")
            yield Frame(t, cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB), depth)


class CameraSource(Source):
    """A live OpenCV camera (colour) with an optional :class:`DepthReader`.

    Whatever the reader raises or returns that is not a frame (not a tuple, another size or
    type) is an :class:`LfdError` naming it: :func:`~lfd.perception.record.record` then keeps
    the frames recorded before it."""

    def __init__(
        self,
        index: int,
        *,
        intrinsics: str | os.PathLike[str] | None = None,
        depth_reader: DepthReader | None = None,
    ):
        index = camera_index(index)
        if intrinsics is None:
            raise LfdError("camera source needs --intrinsics camera.json (K, width, height)")
        camera, objects, _, known = read_camera_json(Path(intrinsics))
        self.depth_reader = depth_reader
        self.rgbd = callable(getattr(depth_reader, "read_frame", None))
        self.cap = None
        if not self.rgbd:
            from .stderr import opencv

            cv2 = opencv()
            self.cap = cv2.VideoCapture(index)
            if not self.cap.isOpened():
                self.cap.release()
                raise LfdError(
                    f"camera {index}: cannot open the video device (is a camera connected?)"
                )
        super().__init__(
            camera,
            objects,
            {"source": f"camera:{index}"},
            camera_pose_known=known,
            has_depth=depth_reader is not None,
        )

    def _reader(self, method: str) -> Any:
        """The depth reader's ``method()``; what it raises, one line naming it."""
        return plugin_call(
            getattr(self.depth_reader, method), f"the depth reader's {method}() raised"
        )

    def _read(self) -> tuple[Any, Any] | None:
        """(RGB, depth or None) of the next frame, or None at the end of the stream."""
        import cv2

        if self.rgbd:
            got = self._reader("read_frame")
            if got is None:
                return None
            if not isinstance(got, tuple | list) or len(got) != 2:
                raise LfdError(
                    f"the depth reader's read_frame() returned {type(got).__name__}, not "
                    "(rgb, depth) or None"
                )
            return got[0], got[1]
        assert self.cap is not None
        ok, bgr = self.cap.read()
        if not ok:
            return None
        depth = self._reader("read") if self.depth_reader is not None else None
        return cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB), depth

    def frames(self) -> Iterator[Frame]:
        what = f"camera:{self.metadata['source'].partition(':')[2]}" + (
            "'s depth reader" if self.depth_reader is not None else ""
        )
        while True:
            got = self._read()
            if got is None:
                return
            t = time.time_ns()
            rgb, depth = got
            if isinstance(rgb, np.ndarray) and rgb.ndim == 3 and rgb.shape[2] == 4:
                rgb = np.ascontiguousarray(rgb[:, :, :3])  # RGBA: its colour
            yield check_frame(Frame(t, rgb, depth), self.camera, what)

    def close(self) -> None:
        if self.cap is not None:
            self.cap.release()
        closer = getattr(self.depth_reader, "close", None)
        if callable(closer):
            plugin_call(closer, "the depth reader's close() raised")


class VideoSource(Source):
    """The frames of a video file (colour only), with a ``camera.json`` for its intrinsics."""

    def __init__(
        self, path: str | os.PathLike[str], *, intrinsics: str | os.PathLike[str] | None = None
    ):
        import cv2

        from ..inputs import check_input_file
        from .stderr import quiet_stderr

        self.path = check_input_file(path, "video", LfdError)
        if intrinsics is None:
            raise LfdError(
                f"video source {self.path}: needs --intrinsics camera.json (K, width, height)"
            )
        if not os.path.isfile(self.path):
            raise LfdError(f"video source {self.path}: no such file")
        camera, objects, meta, known = read_camera_json(Path(intrinsics))
        with quiet_stderr():  # FFmpeg's own lines for a damaged file: the error below says it
            self.cap = cv2.VideoCapture(self.path)
            ok, bgr = self.cap.read() if self.cap.isOpened() else (False, None)
        if not ok or bgr is None:
            self.cap.release()
            raise LfdError(f"{self.path}: not a readable video (OpenCV decodes no frame of it)")
        h, w = bgr.shape[:2]
        if (w, h) != (camera.width, camera.height):
            self.cap.release()
            raise LfdError(
                f"{intrinsics}: the intrinsics are for {camera.width}x{camera.height}, the "
                f"video {self.path} is {w}x{h}; calibrate at the video's size"
            )
        self._first: Any = bgr
        fps = float(self.cap.get(cv2.CAP_PROP_FPS) or 0.0)
        if not (np.isfinite(fps) and 0.0 < fps <= 1000.0):
            fps = float(meta.get("fps", 30.0))  # checked: a number in (0, 1000]
        super().__init__(
            camera,
            objects,
            {"source": f"video:{self.path}"},
            camera_pose_known=known,
            has_depth=False,
            fps=fps,
        )

    def frames(self) -> Iterator[Frame]:
        import cv2

        assert self.fps is not None
        period = round(1e9 / self.fps)
        shape = self._first.shape
        last: int | None = None
        index = 0
        bgr = self._first
        self._first = None
        while bgr is not None:
            if bgr.shape != shape:
                raise LfdError(
                    f"{self.path}: frame {index} is {bgr.shape[1]}x{bgr.shape[0]}, the first "
                    f"{shape[1]}x{shape[0]}"
                )
            msec = float(self.cap.get(cv2.CAP_PROP_POS_MSEC))
            t = round(msec * 1e6) if np.isfinite(msec) and msec >= 0 else index * period
            if last is not None and t <= last:  # a container without (or with repeated) times
                t = last + period
            last = t
            yield Frame(t, cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB), None)
            index += 1
            ok, got = self.cap.read()
            bgr = got if ok else None

    def close(self) -> None:
        self.cap.release()


def load_depth_reader(spec: str) -> DepthReader:
    """``module:factory`` -> ``factory()``, a :class:`DepthReader` (e.g. a RealSense wrapper).

    The module is imported (it may be a file path ending in ``.py``) and the factory called
    without arguments; the result must have a ``read()`` method. A module that does not import
    (a syntax error, an exception at import) or a factory that raises is one :class:`LfdError`
    line naming the plug-in.
    """
    import importlib
    import importlib.util

    module_name, _, attr = spec.rpartition(":")
    if not module_name or not attr:
        raise LfdError(f"depth reader {spec!r}: expected module:factory")

    def load() -> Any:
        if module_name.endswith(".py"):
            loader = importlib.util.spec_from_file_location("lfd_depth_reader", module_name)
            if loader is None or loader.loader is None:
                raise ImportError(module_name)
            module = importlib.util.module_from_spec(loader)
            loader.loader.exec_module(module)
        else:
            module = importlib.import_module(module_name)
        return getattr(module, attr)

    # the plug-in's own code runs: anything it raises is its failure
    factory = plugin_call(load, f"depth reader {spec!r}: cannot load it:")
    reader = plugin_call(factory, f"depth reader {spec!r}: {attr}() raised")
    if not callable(getattr(reader, "read", None)):
        raise LfdError(f"depth reader {spec!r}: {attr}() returned an object without read()")
    return reader  # type: ignore[no-any-return]


KINDS = "sim:TASK[:STYLE], frames:DIR, camera:N or video:FILE"
"""The source specifications :func:`open_source` reads."""


def open_source(spec: str, **kwargs: Any) -> Source:
    """``sim:TASK[:STYLE]``, ``frames:DIR``, ``camera:N`` or ``video:FILE`` -> a source (STYLE:
    the simulated demonstrator's, ``careful`` by default or ``natural``; ``intrinsics`` names
    the camera.json of a camera or a video)."""
    kind, _, arg = spec.partition(":")
    if not arg:
        raise LfdError(f"source {spec!r}: expected {KINDS}")
    if kind not in ("sim", "frames", "camera", "video"):
        raise LfdError(f"unknown source kind {kind!r}: use {KINDS}")
    if kind != "camera" and kwargs.get("depth_reader") is not None:
        raise LfdError(
            f"a {kind}: source takes no depth reader: --depth-reader is for a camera source "
            "(camera:N)"
        )
    if kind == "sim":
        task, _, style = arg.partition(":")
        return SimSource(
            task,
            seed=int(kwargs.get("seed", 0)),
            fps=30.0 if kwargs.get("fps") is None else float(kwargs["fps"]),
            duration=kwargs.get("duration"),
            style=style or "careful",
        )
    if kind == "frames":
        return FolderSource(arg)
    if kind == "camera":
        index = camera_index(arg)  # before anything is loaded or opened
        reader = kwargs.get("depth_reader")
        return CameraSource(
            index,
            intrinsics=kwargs.get("intrinsics"),
            depth_reader=load_depth_reader(reader) if isinstance(reader, str) else reader,
        )
    return VideoSource(arg, intrinsics=kwargs.get("intrinsics"))
