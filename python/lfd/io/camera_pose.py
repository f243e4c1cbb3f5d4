"""A recording's camera: a ``foxglove.CameraCalibration`` posed by ``foxglove.FrameTransforms``
(:func:`camera_of`), one message at a time as :func:`lfd.load` and ``lfd segment --follow``
read them (:class:`CameraPoses`); a followed recording's, its ``calibration`` metadata record
first, as :func:`lfd.load` prefers it (:class:`FollowedCamera`)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from ..demo import MAX_IMAGE_SIDE, CameraInfo, k_problem, pose_problem
from ..errors import RecordingFormatError


def camera_problem(camera: CameraInfo) -> str | None:
    """What makes ``camera`` no camera (None if nothing): the rules of a ``camera.json``
    (:func:`lfd.demo.k_problem` with the image size, :func:`lfd.demo.pose_problem`)."""
    if not (0 < camera.width <= MAX_IMAGE_SIDE and 0 < camera.height <= MAX_IMAGE_SIDE):
        return f"image size {camera.width} x {camera.height} px, each in [1, {MAX_IMAGE_SIDE}]"
    problem = k_problem(camera.K, camera.width, camera.height)
    if problem is None:
        problem = pose_problem(camera.world_T_camera)
        problem = None if problem is None else f"world_T_camera {problem}"
    return problem


def calibration_camera(rec: dict[str, Any]) -> CameraInfo:
    """The camera of a recording's ``calibration`` metadata record (its ``camera`` JSON object:
    width, height, K, world_T_camera, frame_id), which :func:`lfd.load` and ``lfd segment
    --follow`` prefer to the calibration and ``/tf`` messages. One that describes no camera is
    a :class:`~lfd.errors.RecordingFormatError` naming what is wrong."""
    from .topics import CAMERA_FRAME

    try:
        camera = CameraInfo(
            width=int(rec["width"]),
            height=int(rec["height"]),
            K=np.array(rec["K"], dtype=np.float64),
            world_T_camera=np.array(rec["world_T_camera"], dtype=np.float64),
            frame_id=str(rec.get("frame_id", CAMERA_FRAME)),
        )
    except (KeyError, ValueError, TypeError, OverflowError) as err:
        raise RecordingFormatError(str(err)) from err
    problem = camera_problem(camera)
    if problem is not None:
        raise RecordingFormatError(problem)
    return camera


def camera_of(info: Any, transforms: Any) -> CameraInfo | None:
    """The camera of a ``foxglove.CameraCalibration`` posed by a ``foxglove.FrameTransforms``
    that holds its frame (None if it does not; no transforms: the identity pose). A calibration
    or pose that describes no camera (:func:`camera_problem`, a ``K`` of other than 9 entries,
    a zero rotation) is a :class:`~lfd.errors.RecordingFormatError` naming what is wrong."""
    what = f"camera {info.frame_id!r}"
    k = np.array(info.K, dtype=np.float64)
    if k.shape != (9,):
        raise RecordingFormatError(f"{what}: K must be 9 numbers, got {k.tolist()}")
    pose = np.eye(4)
    if transforms is not None:
        found = [tf for tf in transforms.transforms if tf.child_frame_id == info.frame_id]
        if not found:
            return None
        r, tr = found[-1].rotation, found[-1].translation
        q = np.array([r.x, r.y, r.z, r.w], dtype=np.float64)
        scale = float(np.abs(q).max()) if np.isfinite(q).all() else 0.0
        if not scale > 0:  # zero or not finite (scaled first: no overflow in the norm)
            raise RecordingFormatError(f"{what}: no rotation in a transform: {q.tolist()}")
        q = q / scale
        from scipy.spatial.transform import Rotation

        pose[:3, :3] = Rotation.from_quat(q).as_matrix()
        pose[:3, 3] = (tr.x, tr.y, tr.z)
    camera = CameraInfo(
        width=info.width, height=info.height, K=k, world_T_camera=pose, frame_id=info.frame_id
    )
    problem = camera_problem(camera)
    if problem is not None:
        raise RecordingFormatError(f"{what}: {problem}")
    return camera


class CameraPoses:
    """A recording's camera as its calibration and ``/tf`` messages pose it, one message at a
    time (:func:`lfd.load` and ``lfd segment --follow``): the identity pose until a transform
    of its frame, then the last good one; a bad transform before any good one leaves no pose
    (:attr:`camera` None). ``info``: its ``foxglove.CameraCalibration``; a calibration that
    describes no camera raises :class:`~lfd.errors.RecordingFormatError` (:func:`camera_of`)."""

    def __init__(self, info: Any) -> None:
        self.info = info
        self.camera: CameraInfo | None = camera_of(info, None)
        self.posed: Any = None  # the last good transform of its frame

    def add(self, transforms: Any) -> None:
        """One more ``foxglove.FrameTransforms``; one that poses the camera badly raises
        :class:`~lfd.errors.RecordingFormatError` after the camera is kept or dropped."""
        try:
            found = camera_of(self.info, transforms)
        except RecordingFormatError:
            if self.posed is None:
                self.camera = None
            raise
        if found is not None:
            self.camera, self.posed = found, transforms

    def recalibrate(self, info: Any) -> None:
        """A newer calibration, posed by the last good transform (one that describes no camera
        leaves none, and raises as the constructor)."""
        self.info, self.camera = info, None
        self.camera = camera_of(info, self.posed)


class FollowedCamera:
    """The camera of a recording being followed (``lfd segment --follow``) as :func:`lfd.load`
    poses it: its ``calibration`` metadata record's (:func:`calibration_camera`) while that
    describes one, else its calibration and ``/tf`` messages' (:class:`CameraPoses`).
    :meth:`add` takes the messages and :meth:`read_record` the metadata records as they are
    read; both return the problems they skipped (a calibration or pose that describes no
    camera: the messages keep the last good pose, a bad record leaves the messages' camera),
    each problem once. ``path`` names the recording in the error of a record that is not JSON.
    """

    def __init__(self, path: str) -> None:
        self.path = path
        self._poses: CameraPoses | None = None  # the camera as the messages pose it so far
        self._text: str | None = None  # the calibration record's camera as last read
        self._recorded: CameraInfo | None = None  # the camera it describes, if any
        self._seen: set[str] = set()  # the problems returned so far

    @property
    def camera(self) -> CameraInfo | None:
        """The camera as the file poses it so far (None: none yet)."""
        return self._recorded or (self._poses.camera if self._poses is not None else None)

    def add(self, kind: str, value: Any) -> list[str]:
        """One more message (:attr:`lfd.io.LiveMessage.kind` and ``value``: a ``camera_info``
        one recalibrates the camera, a ``tf`` one may pose it; other kinds change nothing): the
        problem skipped, if not returned before (a bad transform leaves the last good pose)."""
        if kind not in ("camera_info", "tf"):
            return []
        try:
            if kind == "tf":
                if self._poses is not None:
                    self._poses.add(value)
            elif self._poses is None:
                self._poses = CameraPoses(value)
            else:
                self._poses.recalibrate(value)
        except RecordingFormatError as err:
            return self._new(err)
        return []

    def read_record(self, metadata: Mapping[str, Mapping[str, str]]) -> list[str]:
        """The metadata records read so far (:attr:`lfd.io.Follower.metadata`): the camera of
        the ``calibration`` record, read again when its text changed; one that describes no
        camera is the problem returned (if not before). A record that is not JSON raises
        :class:`~lfd.errors.RecordingFormatError` (:func:`lfd.io.mcapfile.metadata_json`)."""
        from . import topics as T
        from .mcapfile import metadata_json

        text = metadata.get(T.CALIBRATION_METADATA, {}).get("camera")
        if text is None or text == self._text:
            return []
        self._text, self._recorded = text, None
        rec = metadata_json(self.path, T.CALIBRATION_METADATA, "camera", text)
        if not isinstance(rec, dict):
            return []
        try:
            self._recorded = calibration_camera(rec)
        except RecordingFormatError as err:
            return self._new(err, "calibration metadata: ")
        return []

    def _new(self, err: RecordingFormatError, what: str = "") -> list[str]:
        """``what`` and ``err`` as the one problem to return, unless ``err`` was before."""
        new = str(err) not in self._seen
        self._seen.add(str(err))
        return [f"{what}{err}"] if new else []
