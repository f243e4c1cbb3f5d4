"""Perception: object poses from ArUco tags and hand keypoints from depth (RGB-D frames).

- :mod:`lfd.perception.markers`: tag detection, depth-refined poses in the reference frame;
- :mod:`lfd.perception.hand`: the depth hand-pose network (needs the ``perception`` extra, torch);
- :mod:`lfd.perception.record`: ``lfd record`` (sources in :mod:`lfd.perception.sources`:
  simulator, image folder, camera, video file; colour-only ones place the hand from colour).
"""

from __future__ import annotations

from .stderr import quiet_opencv

quiet_opencv()  # before OpenCV opens anything: its and FFmpeg's own lines stay off stderr

from .markers import FrameObjects, MarkerConfig, MarkerTracker, TaggedBox, TagPose  # noqa: E402

__all__ = ["FrameObjects", "MarkerConfig", "MarkerTracker", "TagPose", "TaggedBox"]
