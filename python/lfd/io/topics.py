"""Topic names, schemas and constants of the lfd MCAP recording format (format version 1).

A recording is an MCAP file (zstd chunks of 64-256 KiB, ``log_time`` = capture time in integer
nanoseconds) whose messages use foxglove's protobuf schemas, so Foxglove and Rerun open it:

====================================  ============================  ===============================
topic                                 schema                        content
====================================  ============================  ===============================
``/hand/<side>/keypoints``            foxglove.PosesInFrame         21 keypoints (metres, identity
                                                                    orientations, NaN = unobserved)
``/hand/<side>/confidence``           JSON ``{"confidence": [21],   per-keypoint confidence in
                                      "visible": [21]}``            [0, 1] and (optional) whether
                                                                    the keypoint was seen (False:
                                                                    estimated, e.g. occluded)
``/hand/<side>/keypoints_camera``     foxglove.PosesInFrame         the hand in the ``camera``
                                                                    frame (OpenCV axes), sampled
                                                                    before the world frame was
                                                                    known (``lfd record``: the
                                                                    reference tag not seen yet)
``/hand/<side>/confidence_camera``    JSON, as ``confidence``       its confidence and visibility
``/objects/<name>/pose``              foxglove.PoseInFrame          box centre + orientation in
                                                                    ``world``; a sample is written
                                                                    only when the tag was visible
``/tf``                               foxglove.FrameTransforms      world -> object, world -> camera
``/camera/color/image_raw``           foxglove.RawImage (rgb8)      colour frames, or
``/camera/color/image_raw/compressed``  foxglove.CompressedImage    PNG / JPEG (``color_format``)
``/camera/depth/image_raw``           foxglove.RawImage (16UC1)     depth in millimetres
``/camera/color/camera_info``         foxglove.CameraCalibration    pinhole intrinsics
``/lfd/ground_truth``                 foxglove.Event                one skill label per message,
                                                                    ``log_time`` = label start;
                                                                    metadata ``skill``, ``object``
``/lfd/live/segments``                foxglove.Event                skills the live segmenter
                                                                    settled while recording
                                                                    (``lfd record --live-segment``),
                                                                    ``log_time`` = when settled;
                                                                    metadata ``skill``, ``object``,
                                                                    ``score``, ``confidence``
``/lfd/ground_truth/handovers``       foxglove.Event                one handover per message (two
                                                                    hands), ``log_time`` = start;
                                                                    metadata ``giver``, ``taker``,
                                                                    ``object``
====================================  ============================  ===============================

A file holds one hand or two (``<side>`` is ``right`` or ``left``; any other side under
``/hand/`` is refused). In a two-hand file every label and live segment names its hand (metadata
``hand``), and both hands must be on one clock (:mod:`lfd.io.hands`: each hand's time span
overlaps the other's and the objects'). The ``demo`` record's ``hand_side`` is the only hand,
or ``right`` of two; a two-hand file adds ``hands`` (JSON list, right first).

A metadata record named ``demo`` holds ``format``, ``version``, ``objects`` (JSON list of
``{name, tag_id, size}``), ``units``, ``task``, ``seed`` and ``metadata`` (free JSON). A second
record ``calibration`` (JSON: width, height, K, world_T_camera, frame_id) is written when the
camera calibration is known.
"""

from __future__ import annotations

from collections.abc import Iterable

FORMAT_NAME = "lfd-demo"
FORMAT_VERSION = 1
PROFILE = ""  # no ROS profile: plain protobuf messages

WORLD_FRAME = "world"
CAMERA_FRAME = "camera"

COLOR_TOPIC = "/camera/color/image_raw"
DEPTH_TOPIC = "/camera/depth/image_raw"
CAMERA_INFO_TOPIC = "/camera/color/camera_info"
TF_TOPIC = "/tf"
GROUND_TRUTH_TOPIC = "/lfd/ground_truth"
LIVE_SEGMENTS_TOPIC = "/lfd/live/segments"
HANDOVERS_TOPIC = "/lfd/ground_truth/handovers"

DEMO_METADATA = "demo"
CALIBRATION_METADATA = "calibration"

UNITS = {"length": "m", "depth": "mm", "time": "ns", "angle": "rad", "quaternion": "xyzw"}

HAND_SIDES = ("right", "left")

CONFIDENCE_SCHEMA = "lfd.HandConfidence"
CONFIDENCE_JSON_SCHEMA = {
    "title": CONFIDENCE_SCHEMA,
    "type": "object",
    "properties": {
        "confidence": {
            "type": "array",
            "items": {"type": "number"},
            "minItems": 21,
            "maxItems": 21,
        },
        "visible": {
            "type": "array",
            "items": {"type": "boolean"},
            "minItems": 21,
            "maxItems": 21,
        },
    },
    "required": ["confidence"],
}
"""Schema of the ``/hand/<side>/confidence`` messages. ``visible`` is optional (files written
before it was added lack it); readers default it to "observed with confidence > 0"."""

POSES_SCHEMA = "foxglove.PosesInFrame"
POSE_SCHEMA = "foxglove.PoseInFrame"
TF_SCHEMA = "foxglove.FrameTransforms"
RAW_IMAGE_SCHEMA = "foxglove.RawImage"
CALIBRATION_SCHEMA = "foxglove.CameraCalibration"
EVENT_SCHEMA = "foxglove.Event"


def hand_topic(side: str = "right") -> str:
    """Topic of the hand keypoints, ``/hand/<side>/keypoints``."""
    return f"/hand/{side}/keypoints"


def confidence_topic(side: str = "right") -> str:
    """Topic of the per-keypoint confidence, ``/hand/<side>/confidence``."""
    return f"/hand/{side}/confidence"


CAMERA_SUFFIX = "_camera"
"""Suffix of the hand topics in the camera frame (:func:`hand_camera_topic`)."""


def hand_camera_topic(side: str = "right") -> str:
    """Topic of the hand keypoints in the camera frame, ``/hand/<side>/keypoints_camera``: the
    samples taken before the world frame was known. Readers of a demonstration
    (:func:`lfd.io.load`, the segmentation) read only :func:`hand_topic`."""
    return hand_topic(side) + CAMERA_SUFFIX


def confidence_camera_topic(side: str = "right") -> str:
    """Topic of the confidence of :func:`hand_camera_topic`, ``/hand/<side>/confidence_camera``."""
    return confidence_topic(side) + CAMERA_SUFFIX


def object_topic(name: str) -> str:
    """Topic of an object's pose, ``/objects/<name>/pose``."""
    return f"/objects/{name}/pose"


def compressed_topic(image_topic: str) -> str:
    """Topic of the PNG/JPEG variant of an image topic, ``<topic>/compressed``."""
    return f"{image_topic}/compressed"


def object_name_from_topic(topic: str) -> str | None:
    """The object name of an ``/objects/<name>/pose`` topic, else None."""
    prefix, suffix = "/objects/", "/pose"
    if topic.startswith(prefix) and topic.endswith(suffix) and len(topic) > len(prefix + suffix):
        return topic[len(prefix) : -len(suffix)]
    return None


def decoded_topic(topic: str) -> bool:
    """Whether lfd decodes ``topic``'s messages into arrays (the hand keypoints and confidence,
    the object poses): such a topic carries one message type, and a recording with two there
    is refused."""
    sides = [f(side) for side in HAND_SIDES for f in (hand_topic, confidence_topic)]
    return topic in sides or object_name_from_topic(topic) is not None


def two_types_message(
    path: str, topic: str, first: tuple[str, str], second: tuple[str, str]
) -> str:
    """The error of a recording with two message types ``(schema, encoding)`` on ``topic``."""
    return (
        f"{path}: {topic} carries two message types, {first[0]} ({first[1]}) and {second[0]} "
        f"({second[1]}); an lfd recording has one per topic"
    )


HAND_PREFIX = "/hand/"


def hand_topic_side(topic: str) -> str | None:
    """The ``<side>`` of any ``/hand/<side>/...`` topic (known or not), else None."""
    if not topic.startswith(HAND_PREFIX):
        return None
    side, slash, _ = topic[len(HAND_PREFIX) :].partition("/")
    return side if slash else None


def unknown_hand_topics(topics: Iterable[str]) -> list[str]:
    """The ``/hand/<side>/...`` topics whose side is not one of :data:`HAND_SIDES`."""
    return sorted(t for t in topics if hand_topic_side(t) not in (None, *HAND_SIDES))


def hand_side_from_topic(topic: str) -> str | None:
    """The hand side of a ``/hand/<side>/keypoints`` topic, else None."""
    for side in HAND_SIDES:
        if topic == hand_topic(side):
            return side
    return None
