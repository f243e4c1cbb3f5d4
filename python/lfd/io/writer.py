"""Write demonstrations to MCAP, incrementally (:class:`McapRecorder`) or at once (:func:`save`).

The file is written to a temporary file beside the destination, ``.NAME.XXXXXXXX.partial``
(:attr:`McapRecorder.partial_path`), and renamed to ``NAME`` when it is closed: a recording
under the requested name is always complete. A recording stopped by Ctrl+C is closed normally
(see ``lfd record``); :func:`save` failing midway leaves no file.

Ctrl+C (or SIGTERM) waits for the sample, chunk or summary being written: a recording that
goes on after it, or is closed, has no half-written record. The recorder is also safe to
kill: chunks are closed at least every ``max_chunk_duration_s`` of capture time (and whenever
they reach ``chunk_size`` bytes) and flushed to the operating system, so a process killed hard
(SIGKILL, power loss) leaves the ``.partial`` file, from which :func:`lfd.io.load` and
``lfd info`` recover every complete chunk (rename it to keep it). See :mod:`lfd.io.topics` for
the layout.
"""

from __future__ import annotations

import json
import math
import os
import time
from collections.abc import Iterable, Mapping, Sequence
from contextlib import ExitStack
from typing import IO, Any

import numpy as np
import numpy.typing as npt
from foxglove_schemas_protobuf.CameraCalibration_pb2 import CameraCalibration
from foxglove_schemas_protobuf.CompressedImage_pb2 import CompressedImage
from foxglove_schemas_protobuf.Event_pb2 import Event
from foxglove_schemas_protobuf.FrameTransforms_pb2 import FrameTransforms
from foxglove_schemas_protobuf.PoseInFrame_pb2 import PoseInFrame
from foxglove_schemas_protobuf.PosesInFrame_pb2 import PosesInFrame
from foxglove_schemas_protobuf.RawImage_pb2 import RawImage
from mcap.writer import CompressionType
from mcap.writer import Writer as _McapWriter
from mcap_protobuf.schema import build_file_descriptor_set

from .._version import __version__
from ..demo import (
    HAND_BONES,
    KEYPOINT_LAYOUT,
    KEYPOINT_NAMES,
    CameraInfo,
    Demonstration,
    Handover,
    SkillLabel,
)
from ..errors import DemonstrationError
from ..outputs import PendingOutput, signals_held
from . import messages as M
from . import topics as T
from .hands import clock_problem, lanes_problem, spans_of
from .images import COLOR_FORMATS, encode_compressed

__all__ = ["McapRecorder", "ObjectSpec", "object_name_problem", "save"]

ObjectSpec = tuple[str, int, npt.ArrayLike]
"""``(name, tag_id, size)`` of one AR-tagged box; ``size`` is 3 lengths in metres."""

RESERVED_OBJECT_NAMES = (T.WORLD_FRAME, T.CAMERA_FRAME)
"""Names an object may not have: the ``/tf`` frames of the world and the camera (an object named
``camera`` would publish the camera's pose)."""
MAX_OBJECT_NAME = 200
"""Longest object name (characters)."""


def object_name_problem(name: str) -> str | None:
    """What makes ``name`` unusable as an object's name (None: usable). It becomes the topic
    ``/objects/<name>/pose`` and the ``/tf`` child frame, so it is refused (never escaped) when
    it is empty, longer than :data:`MAX_OBJECT_NAME`, has a ``/``, a control character or
    surrounding spaces, or is one of :data:`RESERVED_OBJECT_NAMES`. Any other name (``hand``
    too) is an object's own topic and comes back from :func:`lfd.io.load` as it was written."""
    if not isinstance(name, str) or not name:
        return "must be a non-empty string"
    if len(name) > MAX_OBJECT_NAME:
        return f"must be at most {MAX_OBJECT_NAME} characters"
    if "/" in name or name != name.strip() or any(not c.isprintable() for c in name):
        return "must have no '/', control characters or surrounding spaces (it names a topic)"
    if name in RESERVED_OBJECT_NAMES:
        return f"is reserved for the /tf frame of the {name} ({', '.join(RESERVED_OBJECT_NAMES)})"
    return None


def _check_time(t_ns: Any) -> int:
    if isinstance(t_ns, (bool, np.bool_)) or not isinstance(t_ns, (int, np.integer)):
        raise DemonstrationError(f"timestamps must be integer nanoseconds, got {t_ns!r}")
    t = int(t_ns)
    if t < 0:
        raise DemonstrationError(f"timestamps must be >= 0 ns, got {t}")
    return t


class McapRecorder:
    """Record a demonstration to an MCAP file, one sample at a time.

    Parameters
    ----------
    path : str or os.PathLike
        Output file, replaced when the recorder is closed (written until then to
        :attr:`partial_path` beside it).
    objects : sequence of (name, tag_id, size)
        The AR-tagged boxes; ``size`` has shape (3,), metres. Names become topics
        (:func:`object_name_problem` says which are refused).
    metadata : mapping, optional
        Free JSON-serialisable metadata (``task``, ``seed``, ``demonstrator`` ...).
    side : str
        Hand side, ``"right"`` or ``"left"``: the only hand's.
    hands : sequence of str, optional
        The sides of the hands the recording holds, to record two: ``("right", "left")``
        (:meth:`add_hand` then takes each sample's ``side``; default: ``side`` alone). A
        two-hand recording's labels and live segments each name their hand.
    chunk_size : int
        Target chunk size in bytes (64-256 KiB is a good range).
    max_chunk_duration_s : float
        A chunk is closed and flushed once it spans this much capture time, bounding what a
        killed recorder loses. ``math.inf`` disables it.
    max_chunk_wall_s : float
        A chunk is also closed and flushed once its first message is this many seconds old
        (wall clock), checked at every write and by :meth:`flush_if_due`: a process following
        the file (:func:`lfd.io.follow`) sees every sample within about this long, even when
        capture is slower than real time. ``math.inf`` disables it.
    write_tf : bool
        Also publish world -> object transforms on ``/tf`` (for viewers).
    color_format : str
        ``"raw"`` (RawImage rgb8, ~0.5 MB per 640x480 frame after zstd), ``"png"`` or
        ``"jpeg"`` (CompressedImage on ``/camera/color/image_raw/compressed``; needs OpenCV or
        Pillow).

    Examples
    --------
    >>> with McapRecorder("demo.mcap", objects=[("cube", 1, (0.05, 0.05, 0.05))]) as rec:
    ...     rec.add_hand(t_ns, keypoints, confidence, visible)
    ...     rec.add_object_pose("cube", t_ns, position, quaternion)

    Two hands: ``McapRecorder(path, objects=..., hands=("right", "left"))``, then
    ``rec.add_hand(t_ns, keypoints, side="left")``.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        objects: Iterable[ObjectSpec] = (),
        metadata: Mapping[str, Any] | None = None,
        side: str = "right",
        hands: Sequence[str] | None = None,
        chunk_size: int = 128 * 1024,
        max_chunk_duration_s: float = 1.0,
        max_chunk_wall_s: float = 1.0,
        write_tf: bool = True,
        color_format: str = "raw",
    ) -> None:
        given = (side,) if hands is None else tuple(hands)
        for s in given:
            if s not in T.HAND_SIDES:
                raise DemonstrationError(f"hand side must be one of {T.HAND_SIDES}, got {s!r}")
        if not given or len(set(given)) != len(given):
            raise DemonstrationError(f"hands must be one or two different sides, got {given}")
        self.path = os.fspath(path)
        self.sides: tuple[str, ...] = tuple(s for s in T.HAND_SIDES if s in given)
        """The sides of the hands recorded, the right first."""
        self.side = self.sides[0]
        """The side of the only hand, or the right hand of two (the default of :meth:`add_hand`)."""
        self._objects: dict[str, tuple[int, np.ndarray]] = {}
        for name, tag_id, size in objects:
            self._declare_object(name, tag_id, size)
        self._metadata = dict(metadata or {})
        self._write_tf = write_tf
        if color_format not in COLOR_FORMATS:
            raise DemonstrationError(f"color_format must be one of {COLOR_FORMATS}")
        self._color_format = color_format
        self._max_chunk_ns = (
            math.inf if math.isinf(max_chunk_duration_s) else int(max_chunk_duration_s * 1e9)
        )
        self._max_chunk_wall_s = float(max_chunk_wall_s)
        self._chunk_wall0: float | None = None
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, int] = {}
        self._chunk_t: tuple[int, int] | None = None
        self._closed = False
        self._live_last = -1  # log time of the last /lfd/live/segments message
        self.message_count = 0
        record = self._demo_record()
        with signals_held():  # Ctrl+C meanwhile leaves no temporary file behind
            self._pending = PendingOutput(self.path)
            self.partial_path = os.fspath(self._pending.path)
            """The temporary file being written; renamed to :attr:`path` by :meth:`close`."""
            with ExitStack() as undo:  # on any error: the file closed, then discarded
                undo.callback(self._pending.discard)
                self._file: IO[bytes] = open(self.partial_path, "wb")
                undo.callback(self._file.close)
                self._writer = _McapWriter(
                    self._file, chunk_size=chunk_size, compression=CompressionType.ZSTD
                )
                self._writer.start(profile=T.PROFILE, library=f"lfd {__version__}")
                self._written = self._file.tell()
                self._writer.add_metadata(T.DEMO_METADATA, record)
                self._sync()
                undo.pop_all()

    # --- setup -----------------------------------------------------------------------------
    def _declare_object(self, name: str, tag_id: int, size: npt.ArrayLike) -> None:
        problem = object_name_problem(name)
        if problem is not None:
            raise DemonstrationError(f"object name {name!r} {problem}")
        if name in self._objects:
            raise DemonstrationError(f"object {name!r} declared twice")
        s = np.asarray(size, dtype=np.float64)
        if s.shape != (3,) or not np.all(np.isfinite(s)) or not np.all(s > 0):
            raise DemonstrationError(f"object {name!r}: size must be 3 positive lengths, got {s}")
        self._objects[name] = (int(tag_id), s)

    def _demo_record(self) -> dict[str, str]:
        objects = [
            {"name": n, "tag_id": tag, "size": size.tolist()}
            for n, (tag, size) in self._objects.items()
        ]
        record = {
            "format": T.FORMAT_NAME,
            "version": str(T.FORMAT_VERSION),
            "objects": M.dumps(objects),
            "hand_side": self.side,
            **({"hands": M.dumps(list(self.sides))} if len(self.sides) > 1 else {}),
            "keypoint_layout": KEYPOINT_LAYOUT,
            "units": M.dumps(T.UNITS),
            "metadata": M.dumps(self._metadata),
        }
        for key in ("task", "seed"):
            if key in self._metadata:
                record[key] = str(self._metadata[key])
        return record

    def _channel(
        self,
        topic: str,
        message_type: Any = None,
        *,
        json_schema: tuple[str, dict[str, Any]] | None = None,
        metadata: Mapping[str, str] | None = None,
    ) -> int:
        channel_id = self._channels.get(topic)
        if channel_id is not None:
            return channel_id
        if json_schema is not None:
            name, schema = json_schema
            encoding, data, msg_encoding = "jsonschema", json.dumps(schema).encode(), "json"
        else:
            name = message_type.DESCRIPTOR.full_name
            data = build_file_descriptor_set(message_type).SerializeToString()
            encoding, msg_encoding = "protobuf", "protobuf"
        with signals_held():
            schema_id = self._schemas.get(name)
            if schema_id is None:
                schema_id = self._writer.register_schema(name=name, encoding=encoding, data=data)
                self._schemas[name] = schema_id
            channel_id = self._writer.register_channel(
                topic=topic,
                message_encoding=msg_encoding,
                schema_id=schema_id,
                metadata=dict(metadata or {}),
            )
            self._channels[topic] = channel_id
        return channel_id

    # --- writing ----------------------------------------------------------------------------
    def _write(self, channel_id: int, t_ns: int, data: bytes) -> None:
        if self._closed:
            raise DemonstrationError(f"recorder for {self.path} is closed")
        with signals_held():  # Ctrl+C waits for the message and its chunk (module docstring)
            self._writer.add_message(
                channel_id=channel_id, log_time=t_ns, publish_time=t_ns, data=data, sequence=0
            )
            self.message_count += 1
            lo, hi = self._chunk_t if self._chunk_t is not None else (t_ns, t_ns)
            self._chunk_t = (min(lo, t_ns), max(hi, t_ns))
            if self._chunk_wall0 is None:
                self._chunk_wall0 = time.monotonic()
            if self._chunk_t[1] - self._chunk_t[0] >= self._max_chunk_ns:
                self.flush()
            else:
                self.flush_if_due()
            self._sync()

    def flush(self) -> None:
        """Close the open chunk and hand the file's bytes to the OS (no fsync)."""
        if self._closed:
            return
        with signals_held():
            self._writer.flush()  # closes the chunk and flushes the file
            self._chunk_t = None
            self._chunk_wall0 = None
            self._sync()

    def flush_if_due(self) -> None:
        """:meth:`flush` when the open chunk is ``max_chunk_wall_s`` old (call it while idle)."""
        wall0 = self._chunk_wall0
        if wall0 is not None and time.monotonic() - wall0 >= self._max_chunk_wall_s:
            self.flush()

    def _sync(self) -> None:
        """Hand every finished chunk to the OS so that a killed process loses only the last one."""
        pos = self._file.tell()
        if pos != self._written:
            self._file.flush()
            self._written = pos
            self._chunk_t = None  # bytes only reach the file when a chunk is finished
            self._chunk_wall0 = None

    def add_hand(
        self,
        t_ns: int,
        keypoints: npt.ArrayLike,
        confidence: npt.ArrayLike | None = None,
        visible: npt.ArrayLike | None = None,
        *,
        frame: str = T.WORLD_FRAME,
        side: str | None = None,
    ) -> None:
        """Write one hand observation (of the ``side`` hand: default the only, or the right).

        Parameters
        ----------
        t_ns : int
            Capture time, nanoseconds.
        keypoints : array, shape (21, 3)
            Keypoint positions in metres (in ``frame``), NaN where not observed.
        confidence : array, shape (21,), optional
            Per-keypoint confidence in [0, 1]; default 1 where observed, 0 elsewhere.
        visible : array of bool, shape (21,), optional
            Whether each keypoint was seen (False: estimated, e.g. occluded and filled from the
            model); default: finite keypoints with confidence > 0.
        frame : str
            ``"world"`` (:data:`~lfd.io.topics.WORLD_FRAME`): the demonstration's hand,
            ``/hand/<side>/keypoints`` and ``/hand/<side>/confidence``; ``"camera"``
            (:data:`~lfd.io.topics.CAMERA_FRAME`, OpenCV axes): a sample taken before the world
            frame was known, on ``/hand/<side>/keypoints_camera`` and
            ``/hand/<side>/confidence_camera`` (:func:`lfd.io.load` does not read them).
        side : str, optional
            ``"right"`` or ``"left"``, one of the recorder's :attr:`sides`.
        """
        t = _check_time(t_ns)
        side = self.side if side is None else side
        if side not in self.sides:
            raise DemonstrationError(
                f"{self.path}: a {side!r} hand sample, but the recorder records the "
                f"{' and '.join(self.sides)} hand (McapRecorder(hands=...))"
            )
        if frame not in (T.WORLD_FRAME, T.CAMERA_FRAME):
            raise DemonstrationError(
                f"hand frame must be {T.WORLD_FRAME!r} or {T.CAMERA_FRAME!r}, got {frame!r}"
            )
        world = frame == T.WORLD_FRAME
        kp = np.asarray(keypoints, dtype=np.float64)
        if kp.shape != (21, 3):
            raise DemonstrationError(f"hand keypoints must have shape (21, 3), got {kp.shape}")
        if confidence is None:
            conf = np.isfinite(kp).all(axis=1).astype(np.float64)
        else:
            conf = np.asarray(confidence, dtype=np.float64)
            if conf.shape != (21,):
                raise DemonstrationError(f"hand confidence must have shape (21,), got {conf.shape}")
            if not np.all((conf >= 0) & (conf <= 1)):
                raise DemonstrationError(f"hand confidence must be numbers in [0, 1], got {conf}")
        if visible is None:
            vis = np.isfinite(kp).all(axis=1) & (conf > 0)
        else:
            vis = np.asarray(visible)
            if vis.shape != (21,) or vis.dtype != np.bool_:
                raise DemonstrationError(
                    f"{self.path}: {T.confidence_topic(side)} at {t} ns: visible must be "
                    f"21 booleans, got {vis.dtype} {vis.shape}"
                )
        with signals_held():  # one sample: both messages or neither
            msg = M.hand_poses(t, kp, frame)
            channel = self._channel(
                T.hand_topic(side) if world else T.hand_camera_topic(side),
                PosesInFrame,
                metadata={
                    "layout": KEYPOINT_LAYOUT,
                    "keypoints": json.dumps(KEYPOINT_NAMES),
                    "bones": json.dumps(HAND_BONES),
                    "side": side,
                    "units": "m",
                    "unobserved": "NaN",
                    **({} if world else {"frame_id": frame}),
                },
            )
            self._write(channel, t, msg.SerializeToString())
            channel = self._channel(
                T.confidence_topic(side) if world else T.confidence_camera_topic(side),
                json_schema=(T.CONFIDENCE_SCHEMA, T.CONFIDENCE_JSON_SCHEMA),
                metadata={"layout": KEYPOINT_LAYOUT},
            )
            record = {"confidence": conf.tolist(), "visible": vis.tolist()}
            self._write(channel, t, M.dumps(record).encode())

    def add_object_pose(
        self,
        name: str,
        t_ns: int,
        position: npt.ArrayLike,
        quaternion: npt.ArrayLike,
    ) -> None:
        """Write one observation of an object (only call it when the tag was visible).

        Parameters
        ----------
        name : str
            A declared object name.
        t_ns : int
            Capture time, nanoseconds.
        position : array, shape (3,)
            Box centre, metres, world frame.
        quaternion : array, shape (4,)
            Orientation (x, y, z, w); normalised before writing.
        """
        if name not in self._objects:
            raise DemonstrationError(
                f"unknown object {name!r}; declared objects: {sorted(self._objects)}"
            )
        t = _check_time(t_ns)
        p = np.asarray(position, dtype=np.float64)
        q = np.asarray(quaternion, dtype=np.float64)
        if p.shape != (3,) or q.shape != (4,):
            raise DemonstrationError(
                f"object {name!r}: position must be (3,) and quaternion (4,), got {p.shape}, {q.shape}"
            )
        norm = float(np.linalg.norm(q))
        if not (np.all(np.isfinite(p)) and np.isfinite(norm) and norm > 0):
            raise DemonstrationError(
                f"object {name!r} at {t} ns: non-finite pose (do not write invisible samples)"
            )
        q = q / norm
        tag_id, size = self._objects[name]
        with signals_held():  # one sample: the pose and its /tf
            msg = M.object_pose(t, p, q)
            channel = self._channel(
                T.object_topic(name),
                PoseInFrame,
                metadata={"name": name, "tag_id": str(tag_id), "size": M.dumps(size.tolist())},
            )
            self._write(channel, t, msg.SerializeToString())
            if self._write_tf:
                self._tf(t, name, p, q)

    def _tf(self, t: int, child: str, p: np.ndarray, q: np.ndarray) -> None:
        msg = M.transform(t, child, p, q)
        self._write(self._channel(T.TF_TOPIC, FrameTransforms), t, msg.SerializeToString())

    def _image(self, topic: str, t: int, img: np.ndarray, encoding: str) -> None:
        msg = M.raw_image(t, img, encoding)
        self._write(self._channel(topic, RawImage), t, msg.SerializeToString())

    def add_color(self, t_ns: int, rgb: npt.ArrayLike) -> None:
        """Write a colour frame, array shape (H, W, 3), uint8 RGB (``rgb8``)."""
        img = np.asarray(rgb)
        if img.ndim != 3 or img.shape[2] != 3 or img.dtype != np.uint8:
            raise DemonstrationError(
                f"colour image must be (H, W, 3) uint8, got {img.shape} {img.dtype}"
            )
        t = _check_time(t_ns)
        if self._color_format == "raw":
            self._image(T.COLOR_TOPIC, t, img, "rgb8")
            return
        data = encode_compressed(img, self._color_format)
        msg = M.compressed_image(t, data, self._color_format)
        topic = T.compressed_topic(T.COLOR_TOPIC)
        self._write(self._channel(topic, CompressedImage), t, msg.SerializeToString())

    def add_depth(self, t_ns: int, depth_mm: npt.ArrayLike) -> None:
        """Write a depth frame, array shape (H, W), uint16 millimetres (``16UC1``, 0 = no data)."""
        img = np.asarray(depth_mm)
        if img.ndim != 2 or img.dtype != np.uint16:
            raise DemonstrationError(
                f"depth image must be (H, W) uint16 millimetres, got {img.shape} {img.dtype}"
            )
        self._image(T.DEPTH_TOPIC, _check_time(t_ns), img.astype("<u2", copy=False), "16UC1")

    def add_camera_info(self, camera: CameraInfo, t_ns: int = 0) -> None:
        """Write the camera calibration (intrinsics + world -> camera pose) at time ``t_ns``."""
        from scipy.spatial.transform import Rotation

        t = _check_time(t_ns)
        msg = M.calibration(t, camera)
        pose = camera.world_T_camera
        record = {
            "width": int(camera.width),
            "height": int(camera.height),
            "K": camera.K.tolist(),
            "world_T_camera": pose.tolist(),
            "frame_id": camera.frame_id,
        }
        with signals_held():  # the message, its /tf and the metadata, or none of them
            channel = self._channel(T.CAMERA_INFO_TOPIC, CameraCalibration)
            self._write(channel, t, msg.SerializeToString())
            self._tf(t, camera.frame_id, pose[:3, 3], Rotation.from_matrix(pose[:3, :3]).as_quat())
            self._writer.add_metadata(T.CALIBRATION_METADATA, {"camera": M.dumps(record)})
            self._sync()

    def _check_lane(self, labels: Sequence[SkillLabel], what: str) -> None:
        problem = lanes_problem(self.sides, labels, (), what)
        if problem is not None:
            raise DemonstrationError(f"{self.path}: {problem}")

    def add_label(self, label: SkillLabel) -> None:
        """Write a ground-truth skill label (``log_time`` = its start; metadata ``hand`` when
        it names its hand, as every label of a two-hand recording does)."""
        _check_time(label.start_ns)
        self._check_lane([label], "label")
        msg = M.event(label)
        channel = self._channel(T.GROUND_TRUTH_TOPIC, Event)
        self._write(channel, label.start_ns, msg.SerializeToString())

    def add_live_segment(
        self, label: SkillLabel, settled_ns: int, extra: dict[str, str] | None = None
    ) -> None:
        """Write a skill the live segmenter settled at ``settled_ns`` (the ``log_time``) on
        ``/lfd/live/segments``, with the ground truth's metadata keys plus ``extra`` (kept apart
        from ``/lfd/ground_truth``). Skills settled at the same time are written 1 ns apart, in
        order (a topic's log times are unique: :func:`lfd.load` drops repeated ones)."""
        _check_time(label.start_ns)
        _check_time(settled_ns)
        self._check_lane([label], "live segment")
        t = max(int(settled_ns), self._live_last + 1)
        self._live_last = t
        msg = M.event(label, extra)
        channel = self._channel(T.LIVE_SEGMENTS_TOPIC, Event)
        self._write(channel, t, msg.SerializeToString())

    def add_handover(self, handover: Handover) -> None:
        """Write a ground-truth handover on ``/lfd/ground_truth/handovers`` (``log_time`` = its
        start; metadata ``giver``, ``taker``, ``object``): a two-hand recording's."""
        _check_time(handover.start_ns)
        problem = lanes_problem(self.sides, (), [handover])
        if problem is not None:
            raise DemonstrationError(f"{self.path}: {problem}")
        channel = self._channel(T.HANDOVERS_TOPIC, Event)
        self._write(channel, handover.start_ns, M.handover_event(handover).SerializeToString())

    # --- lifetime ---------------------------------------------------------------------------
    @property
    def closed(self) -> bool:
        """Whether the file was closed or discarded."""
        return self._closed

    def close(self) -> None:
        """Finish the file (summary, index, footer) and move it to :attr:`path`. Idempotent."""
        if self._closed:
            return
        self._closed = True
        with signals_held():  # a Ctrl+C meanwhile comes once the file is whole and renamed
            try:
                self._writer.finish()
                self._file.close()
            except BaseException:
                self._file.close()
                self._pending.discard()
                raise
            self._pending.commit()

    def discard(self) -> None:
        """Stop recording and remove the temporary file; :attr:`path` is left as it was."""
        if self._closed:
            return
        self._closed = True
        self._file.close()
        self._pending.discard()

    def __enter__(self) -> McapRecorder:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, *exc: object) -> None:
        """Close the file; an exception (Ctrl+C included) in the block discards it instead."""
        if exc_type is None:
            self.close()
        else:
            self.discard()


_HAND, _OBJECT, _COLOR, _DEPTH = 1, 2, 3, 4
"""The kinds of samples :func:`save` interleaves, in their order at one time."""
_HELD_EVENTS = 256
"""Samples :func:`save` writes under one :func:`~lfd.outputs.signals_held` (Ctrl+C waits for
them: a few milliseconds)."""


def _save_sample(
    rec: McapRecorder, demo: Demonstration, t: int, kind: int, name: str, i: int
) -> None:
    """Write sample ``i`` of the stream ``kind`` (``name``: its hand side or object)."""
    if kind == _HAND:
        hand = demo.hands[name]
        rec.add_hand(t, hand.keypoints[i], hand.confidence[i], hand.visible[i], side=hand.side)
    elif kind == _COLOR:
        assert demo.color is not None
        rec.add_color(t, demo.color.frames[i])
    elif kind == _DEPTH:
        assert demo.depth is not None
        rec.add_depth(t, demo.depth.frames[i])
    else:
        obj = demo.objects[name]
        rec.add_object_pose(name, t, obj.position[i], obj.quaternion[i])


def save(demo: Demonstration, path: str | os.PathLike[str], **kwargs: Any) -> None:
    """Write a whole :class:`~lfd.demo.Demonstration` to ``path``.

    Streams are interleaved in time order. Object samples with ``visible == False`` are not
    written (visibility = presence), so they do not come back from :func:`lfd.io.load`. Both
    hands of a two-hand demonstration are written, with its handovers; its hands must be on one
    clock (:func:`lfd.io.hands.clock_problem`). Extra keyword arguments go to
    :class:`McapRecorder`.
    """
    problem = clock_problem(*spans_of(demo))
    if problem is not None:
        raise DemonstrationError(f"cannot save {os.fspath(path)}: {problem}")
    objects: Sequence[ObjectSpec] = [(o.name, o.tag_id, o.size) for o in demo.objects.values()]
    # (t, stream kind, object name or "", index): the kind, never a name, says what a sample
    # is, so an object named "hand" is an object
    events: list[tuple[int, int, str, int]] = []
    for side, hand in demo.hands.items():
        events += [(int(t), _HAND, side, i) for i, t in enumerate(hand.t_ns)]
    for name, obj in demo.objects.items():
        events += [(int(t), _OBJECT, name, i) for i, t in enumerate(obj.t_ns) if obj.visible[i]]
    if demo.color is not None:
        events += [(int(t), _COLOR, "", i) for i, t in enumerate(demo.color.t_ns)]
    if demo.depth is not None:
        events += [(int(t), _DEPTH, "", i) for i, t in enumerate(demo.depth.t_ns)]
    events.sort(key=lambda e: (e[0], e[1]))
    metadata = {k: v for k, v in demo.metadata.items() if k != "load_report"}
    with McapRecorder(path, objects=objects, metadata=metadata, hands=demo.sides, **kwargs) as rec:
        if demo.camera is not None:
            t0 = events[0][0] if events else 0
            rec.add_camera_info(demo.camera, t0)
        for lo in range(0, len(events), _HELD_EVENTS):
            with signals_held():  # one hold for many samples (each would cost one, ~20 us)
                for t, kind, name, i in events[lo : lo + _HELD_EVENTS]:
                    _save_sample(rec, demo, t, kind, name, i)
        for label in demo.labels:
            rec.add_label(label)
        for label in demo.live_segments:  # settle times and scores are not kept by load
            rec.add_live_segment(label, label.end_ns)
        for handover in demo.handovers:
            rec.add_handover(handover)
