"""Builders of the foxglove protobuf messages of a recording (no file I/O here).

Each function takes validated numpy arrays and returns a protobuf message; the recorder
serialises and writes it. Times are integer nanoseconds.
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np
from foxglove_schemas_protobuf.CameraCalibration_pb2 import CameraCalibration
from foxglove_schemas_protobuf.CompressedImage_pb2 import CompressedImage
from foxglove_schemas_protobuf.Event_pb2 import Event
from foxglove_schemas_protobuf.FrameTransform_pb2 import FrameTransform
from foxglove_schemas_protobuf.FrameTransforms_pb2 import FrameTransforms
from foxglove_schemas_protobuf.KeyValuePair_pb2 import KeyValuePair
from foxglove_schemas_protobuf.Pose_pb2 import Pose
from foxglove_schemas_protobuf.PoseInFrame_pb2 import PoseInFrame
from foxglove_schemas_protobuf.PosesInFrame_pb2 import PosesInFrame
from foxglove_schemas_protobuf.Quaternion_pb2 import Quaternion
from foxglove_schemas_protobuf.RawImage_pb2 import RawImage
from foxglove_schemas_protobuf.Vector3_pb2 import Vector3
from google.protobuf.timestamp_pb2 import Timestamp

from ..demo import CameraInfo, Handover, SkillLabel
from . import topics as T

__all__ = [
    "calibration",
    "compressed_image",
    "dumps",
    "event",
    "hand_poses",
    "handover_event",
    "object_pose",
    "raw_image",
    "stamp",
    "transform",
]


def stamp(t_ns: int) -> Timestamp:
    """A protobuf Timestamp of integer nanoseconds."""
    return Timestamp(seconds=t_ns // 1_000_000_000, nanos=t_ns % 1_000_000_000)


def _json_default(obj: Any) -> Any:
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    raise TypeError(f"{type(obj).__name__} is not JSON serialisable")


def dumps(obj: Any) -> str:
    """JSON text of ``obj``, numpy arrays and scalars included, NaN allowed."""
    return json.dumps(obj, default=_json_default, allow_nan=True)


def _vector(p: np.ndarray) -> Vector3:
    return Vector3(x=float(p[0]), y=float(p[1]), z=float(p[2]))


def _quat(q: np.ndarray) -> Quaternion:
    return Quaternion(x=float(q[0]), y=float(q[1]), z=float(q[2]), w=float(q[3]))


def hand_poses(t: int, keypoints: np.ndarray, frame_id: str = T.WORLD_FRAME) -> PosesInFrame:
    """21 keypoints, shape (21, 3), as poses with identity orientation (NaN kept) in
    ``frame_id``."""
    identity = Quaternion(x=0.0, y=0.0, z=0.0, w=1.0)
    return PosesInFrame(
        timestamp=stamp(t),
        frame_id=frame_id,
        poses=[Pose(position=_vector(p), orientation=identity) for p in keypoints],
    )


def object_pose(t: int, position: np.ndarray, quaternion: np.ndarray) -> PoseInFrame:
    """A box pose in the world frame."""
    return PoseInFrame(
        timestamp=stamp(t),
        frame_id=T.WORLD_FRAME,
        pose=Pose(position=_vector(position), orientation=_quat(quaternion)),
    )


def transform(
    t: int, child: str, translation: np.ndarray, quaternion: np.ndarray
) -> FrameTransforms:
    """One world -> ``child`` transform."""
    tf = FrameTransform(
        timestamp=stamp(t),
        parent_frame_id=T.WORLD_FRAME,
        child_frame_id=child,
        translation=_vector(translation),
        rotation=_quat(quaternion),
    )
    return FrameTransforms(transforms=[tf])


def raw_image(t: int, img: np.ndarray, encoding: str) -> RawImage:
    """An image, shape (H, W, C) or (H, W), little-endian, as a RawImage."""
    channels = img.shape[2] if img.ndim == 3 else 1
    return RawImage(
        timestamp=stamp(t),
        frame_id=T.CAMERA_FRAME,
        width=int(img.shape[1]),
        height=int(img.shape[0]),
        encoding=encoding,
        step=int(img.shape[1] * img.itemsize * channels),
        data=np.ascontiguousarray(img).tobytes(),
    )


def compressed_image(t: int, data: bytes, fmt: str) -> CompressedImage:
    """Encoded image bytes (``png`` / ``jpeg``) as a CompressedImage."""
    return CompressedImage(timestamp=stamp(t), frame_id=T.CAMERA_FRAME, format=fmt, data=data)


def calibration(t: int, camera: CameraInfo) -> CameraCalibration:
    """Pinhole intrinsics without distortion (rendered or rectified images)."""
    K = camera.K
    P = np.hstack([K, np.zeros((3, 1))])
    return CameraCalibration(
        timestamp=stamp(t),
        frame_id=camera.frame_id,
        width=int(camera.width),
        height=int(camera.height),
        distortion_model="plumb_bob",
        D=[0.0] * 5,
        K=K.ravel().tolist(),
        R=np.eye(3).ravel().tolist(),
        P=P.ravel().tolist(),
    )


def event(label: SkillLabel, extra: dict[str, str] | None = None) -> Event:
    """A skill label as an Event with metadata ``skill`` (and ``object`` when known, ``hand``
    when the label names its hand), then ``extra`` (e.g. ``score``, ``confidence`` of a live
    result)."""
    meta = [KeyValuePair(key="skill", value=label.skill)]
    if label.object is not None:
        meta.append(KeyValuePair(key="object", value=label.object))
    if label.hand is not None:
        meta.append(KeyValuePair(key="hand", value=label.hand))
    meta.extend(KeyValuePair(key=k, value=v) for k, v in (extra or {}).items())
    return Event(start_time=stamp(label.start_ns), end_time=stamp(label.end_ns), metadata=meta)


def handover_event(handover: Handover) -> Event:
    """A handover as an Event with metadata ``giver``, ``taker`` (and ``object`` when known)."""
    meta = [
        KeyValuePair(key="giver", value=handover.giver),
        KeyValuePair(key="taker", value=handover.taker),
    ]
    if handover.object is not None:
        meta.append(KeyValuePair(key="object", value=handover.object))
    return Event(
        start_time=stamp(handover.start_ns),
        end_time=stamp(handover.end_ns),
        metadata=meta,
    )
