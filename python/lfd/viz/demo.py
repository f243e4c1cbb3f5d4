"""Log a demonstration (and its preprocessed trajectory) to Rerun: the 3-D scene and images."""

from __future__ import annotations

import io
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..demo import HAND_BONES, KEYPOINT_NAMES, Demonstration, HandTrack, ImageStream
from ..errors import DemonstrationError
from ..trajectory import Trajectory
from .paths import HAND, hand_path, object_path
from .recording import get_recording, import_rerun
from .timeline import time_columns, time_origin

HAND_CLASS_ID = 0
"""Class id of the hand skeleton in the ``/world/hand`` annotation context."""
HAND_COLOR = (240, 170, 60)
HAND_COLORS = {"right": HAND_COLOR, "left": (120, 200, 90)}
"""Each hand's colour in a two-hand view (one hand: :data:`HAND_COLOR`)."""
TCP_COLOR = (60, 160, 255)
OBJECT_PALETTE = ((230, 80, 80), (80, 200, 120), (150, 110, 230), (240, 200, 60), (60, 200, 220))
MARKER_SIZE_M = 0.05
"""Edge length drawn for the reference marker (tag 0)."""


def log_static_scene(recording: Any = None, sides: Sequence[str] = ()) -> None:
    """Log the static parts of the scene: Z-up world, reference marker, hand skeleton classes
    (with two ``sides``, one per hand, in its colour: ``/world/hand/<side>``)."""
    rr = import_rerun()
    rec = get_recording(recording)
    rec.log("/world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    rec.log("/world/reference_marker", rr.TransformAxes3D(0.1), static=True)
    rec.log(
        "/world/reference_marker/tag",
        rr.Boxes3D(
            half_sizes=[[MARKER_SIZE_M / 2, MARKER_SIZE_M / 2, 0.0005]],
            labels=["reference (tag 0)"],
            colors=[(220, 220, 220)],
        ),
        static=True,
    )
    rec.log(HAND, _skeleton("hand", HAND_COLOR), static=True)
    if len(sides) > 1:
        for side in sides:
            color = HAND_COLORS.get(side, HAND_COLOR)
            rec.log(f"{HAND}/{side}", _skeleton(f"{side} hand", color), static=True)


def _skeleton(label: str, color: tuple[int, int, int]) -> Any:
    """The hand skeleton's annotation context: the keypoints' names and bones."""
    rr = import_rerun()
    return rr.AnnotationContext(
        [
            rr.ClassDescription(
                info=rr.AnnotationInfo(id=HAND_CLASS_ID, label=label, color=color),
                keypoint_annotations=[
                    rr.AnnotationInfo(id=i, label=name) for i, name in enumerate(KEYPOINT_NAMES)
                ],
                keypoint_connections=list(HAND_BONES),
            )
        ]
    )


def log_hand(demo: Demonstration, origin_ns: int, rec: Any) -> None:
    """Hand keypoints per sample (finite ones only) and the raw TCP path ``(I + T) / 2``; of
    two hands, each under ``/world/hand/<side>`` in its colour."""
    two = len(demo.sides) > 1
    for side, hand in demo.hands.items():
        _log_hand_track(hand, origin_ns, rec, side if two else None)


def _log_hand_track(hand: HandTrack, origin_ns: int, rec: Any, side: str | None) -> None:
    rr = import_rerun()
    keypoints = hand_path(side, "keypoints")
    color = HAND_COLOR if side is None else HAND_COLORS.get(side, HAND_COLOR)
    n = len(hand)
    if n == 0:
        return
    kp = hand.keypoints
    finite = np.all(np.isfinite(kp), axis=2)  # (n, 21)
    lengths = finite.sum(axis=1)
    ids = np.broadcast_to(np.arange(21), (n, 21))[finite]
    rec.send_columns(
        keypoints,
        indexes=time_columns(hand.t_ns, origin_ns, frame=np.arange(n)),
        columns=rr.Points3D.columns(
            positions=kp[finite], keypoint_ids=ids, class_ids=np.full(ids.shape, HAND_CLASS_ID)
        ).partition(lengths),
    )
    rec.log(keypoints, rr.Points3D.from_fields(show_labels=False), static=True)
    tcp = 0.5 * (kp[:, 4] + kp[:, 8])
    ok = np.all(np.isfinite(tcp), axis=1)
    if ok.sum() >= 2:
        rec.log(
            hand_path(side, "path"),
            rr.LineStrips3D([tcp[ok]], colors=[(*color, 120)], radii=0.0015),
            static=True,
        )


def log_objects(demo: Demonstration, origin_ns: int, rec: Any) -> None:
    """Object frames over time (visible samples) and their boxes labelled with the tag id."""
    rr = import_rerun()
    for k, (name, obj) in enumerate(demo.objects.items()):
        path = object_path(name)
        color = OBJECT_PALETTE[k % len(OBJECT_PALETTE)]
        rec.log(path, rr.TransformAxes3D(0.5 * float(obj.size.max()) + 0.02), static=True)
        rec.log(
            f"{path}/box",
            rr.Boxes3D(
                half_sizes=[obj.size / 2],
                labels=[f"{name} (tag {obj.tag_id})"],
                colors=[color],
                fill_mode="transparentfillmajorwireframe",
            ),
            static=True,
        )
        ok = obj.visible & np.all(np.isfinite(obj.position), axis=1)
        ok &= np.all(np.isfinite(obj.quaternion), axis=1)
        if not ok.any():
            continue
        idx = np.flatnonzero(ok)
        rec.send_columns(
            path,
            indexes=time_columns(obj.t_ns[idx], origin_ns, frame=idx),
            columns=rr.Transform3D.columns(
                translation=obj.position[idx], quaternion=obj.quaternion[idx]
            ),
        )


def _jpeg(frame: np.ndarray, quality: int) -> bytes:
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(frame).save(buf, format="JPEG", quality=quality)
    return buf.getvalue()


def log_camera(
    demo: Demonstration, origin_ns: int, rec: Any, *, jpeg_quality: int | None = 85
) -> None:
    """Camera pose + pinhole, colour images (JPEG unless ``jpeg_quality`` is None), depth (mm)."""
    rr = import_rerun()
    cam = demo.camera
    base = "/world/camera"
    if cam is not None:
        rec.log(
            base,
            rr.Transform3D(
                translation=cam.world_T_camera[:3, 3], mat3x3=cam.world_T_camera[:3, :3]
            ),
            static=True,
        )
        rec.log(
            f"{base}/image",
            rr.Pinhole(
                image_from_camera=cam.K,
                resolution=[cam.width, cam.height],
                camera_xyz=rr.ViewCoordinates.RDF,
                image_plane_distance=0.1,
            ),
            static=True,
        )
    if demo.color is not None and len(demo.color):
        _log_color(demo.color, origin_ns, rec, f"{base}/image/rgb", jpeg_quality)
    if demo.depth is not None and len(demo.depth):
        depth = demo.depth.frames
        if depth.ndim != 3:
            raise DemonstrationError(f"depth images must be (n, H, W), got {depth.shape}")
        n, h, w = depth.shape
        fmt = rr.components.ImageFormat(width=w, height=h, color_model="L", channel_datatype="U16")
        rec.log(
            f"{base}/image/depth", rr.DepthImage.from_fields(format=fmt, meter=1000.0), static=True
        )
        rec.send_columns(
            f"{base}/image/depth",
            indexes=time_columns(demo.depth.t_ns, origin_ns, frame=np.arange(n)),
            columns=rr.DepthImage.columns(
                buffer=depth.astype(np.uint16, copy=False).reshape(n, -1).view(np.uint8)
            ),
        )


def _log_color(
    stream: ImageStream, origin_ns: int, rec: Any, path: str, jpeg_quality: int | None
) -> None:
    rr = import_rerun()
    frames = stream.frames
    if frames.ndim != 4 or frames.shape[3] != 3 or frames.dtype != np.uint8:
        raise DemonstrationError(
            f"colour images must be uint8 (n, H, W, 3), got {frames.dtype} {frames.shape}"
        )
    n, h, w, _ = frames.shape
    indexes = time_columns(stream.t_ns, origin_ns, frame=np.arange(n))
    if jpeg_quality is not None:
        blobs = [_jpeg(f, jpeg_quality) for f in frames]
        rec.log(path, rr.EncodedImage.from_fields(media_type="image/jpeg"), static=True)
        rec.send_columns(path, indexes=indexes, columns=rr.EncodedImage.columns(blob=blobs))
    else:
        fmt = rr.components.ImageFormat(width=w, height=h, color_model="RGB", channel_datatype="U8")
        rec.log(path, rr.Image.from_fields(format=fmt), static=True)
        rec.send_columns(
            path, indexes=indexes, columns=rr.Image.columns(buffer=frames.reshape(n, -1))
        )


def log_trajectory(
    traj: Trajectory,
    origin_ns: int,
    rec: Any,
    *,
    trail_s: float = 2.0,
    trail_stride: int = 1,
    side: str | None = None,
) -> None:
    """The preprocessed gripper: TCP frame over time, its recent trail, full path, opening;
    with ``side``, one of two hands' (under ``/world/hand/<side>``, ``/trajectory/<side>``)."""
    rr = import_rerun()
    n = len(traj)
    if n == 0:
        return
    tcp = np.asarray(traj.tcp, dtype=np.float64)
    rot = np.asarray(traj.rotation, dtype=np.float64)
    if tcp.shape != (n, 3) or rot.shape != (n, 3, 3):
        raise DemonstrationError(
            f"trajectory tcp/rotation must be ({n}, 3)/({n}, 3, 3), got {tcp.shape}/{rot.shape}"
        )
    ok = np.all(np.isfinite(tcp), axis=1) & np.all(np.isfinite(rot), axis=(1, 2))
    idx = np.flatnonzero(ok)
    if idx.size == 0:
        return
    gripper = hand_path(side, "gripper")
    color = TCP_COLOR if side is None else HAND_COLORS.get(side, TCP_COLOR)
    rec.log(gripper, rr.TransformAxes3D(0.05), static=True)
    rec.send_columns(
        gripper,
        indexes=time_columns(traj.t_ns[idx], origin_ns, frame=idx),
        columns=rr.Transform3D.columns(translation=tcp[idx], mat3x3=rot[idx]),
    )
    rec.log(
        hand_path(side, "tcp_path"),
        rr.LineStrips3D([tcp[idx]], colors=[(*color, 160)], radii=0.001),
        static=True,
    )
    # The trail: at each sample the TCP path over the last `trail_s` seconds.
    dt = traj.dt if traj.dt > 0 else 1.0
    span = max(2, round(trail_s / dt))
    sel = idx[:: max(1, trail_stride)]
    strips = [tcp[max(0, i - span) : i + 1][ok[max(0, i - span) : i + 1]] for i in sel]
    trail = hand_path(side, "gripper_trail")
    rec.log(trail, rr.LineStrips3D.from_fields(colors=[color]), static=True)
    rec.send_columns(
        trail,
        indexes=time_columns(traj.t_ns[sel], origin_ns, frame=sel),
        columns=rr.LineStrips3D.columns(strips=strips, radii=np.full(len(strips), 0.003)),
    )
    opening = np.asarray(traj.opening, dtype=np.float64)
    if opening.shape == (n,):
        good = np.flatnonzero(np.isfinite(opening))
        series = "/trajectory/opening" if side is None else f"/trajectory/{side}/opening"
        name = "gripper opening (m)" if side is None else f"{side} gripper opening (m)"
        rec.log(series, rr.SeriesLines(names=name, colors=[color]), static=True)
        rec.send_columns(
            series,
            indexes=time_columns(traj.t_ns[good], origin_ns, frame=good),
            columns=rr.Scalars.columns(scalars=opening[good]),
        )


def log_demonstration(
    demo: Demonstration,
    *,
    trajectory: Trajectory | Mapping[str, Trajectory] | None = None,
    recording: Any = None,
    origin_ns: int | None = None,
    images: bool = True,
    jpeg_quality: int | None = 85,
    trail_s: float = 2.0,
) -> int:
    """Log a demonstration: hand skeleton, objects, reference marker, camera, images.

    Parameters
    ----------
    demo : Demonstration
        The recording.
    trajectory : Trajectory or dict side -> Trajectory, optional
        Its preprocessed form: adds the gripper frame, the TCP path and trail, the opening; of
        a two-hand demonstration, each hand's by side (one Trajectory: the right hand's).
    recording : rerun.RecordingStream, optional
        Where to log (default: the current recording, see :func:`lfd.viz.init`).
    origin_ns : int, optional
        Absolute time that becomes ``demo_time = 0`` (default: the recording's origin, or the
        demonstration's start when nothing was logged before).
    images : bool
        Log the colour and depth images when the demonstration has them.
    jpeg_quality : int or None
        JPEG-compress colour images at this quality (None: raw RGB).
    trail_s : float
        Length of the TCP trail in seconds.

    Returns
    -------
    int
        The ``demo_time`` origin used (absolute nanoseconds).
    """
    rec = get_recording(recording)
    origin = time_origin(rec, first_ns=demo.start_ns, origin_ns=origin_ns)
    log_static_scene(rec, demo.sides)
    log_hand(demo, origin, rec)
    log_objects(demo, origin, rec)
    if images:
        log_camera(demo, origin, rec, jpeg_quality=jpeg_quality)
    two = len(demo.sides) > 1
    trajectories = (
        trajectory
        if isinstance(trajectory, Mapping)
        else {}
        if trajectory is None
        else {demo.sides[0]: trajectory}
    )
    for side, traj in trajectories.items():
        log_trajectory(traj, origin, rec, trail_s=trail_s, side=side if two else None)
    return origin
