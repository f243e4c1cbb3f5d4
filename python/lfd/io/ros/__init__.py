"""ROS 1 and ROS 2 bags as demonstrations, through ``rosbags`` (pure Python, no ROS install).

A bag holds its hand keypoints and object poses on topics of its own; a small TOML file, the
topic mapping (:func:`read_mapping`, schema in docs/ros.md), says which:

- the hand: a ``geometry_msgs/PoseArray`` or ``visualization_msgs/MarkerArray`` topic with the
  21 keypoints (MediaPipe order, or ``order``), or 21 tf child frames;
- each object: a ``geometry_msgs/PoseStamped`` topic or a tf child frame, with its size;
- the reference frame every pose is expressed in (tf chains from ``/tf`` and ``/tf_static``
  composed at each sample's time), and the units (``m`` or ``mm``).

:func:`load_ros` reads a ROS 1 ``.bag``, a ROS 2 bag directory (``metadata.yaml`` with sqlite3
or mcap storage, or its ``.db3``), or a lone ROS 2 ``.mcap`` file; :func:`lfd.load` calls it for
such paths. ``rosbags`` is imported only in this package, inside the functions (the ``ros``
extra).

The modules: :mod:`~lfd.io.ros.mapping` (the topic mapping), :mod:`~lfd.io.ros.bag` (a bag
opened through rosbags), :mod:`~lfd.io.ros.tf` (tf chains), :mod:`~lfd.io.ros.read` (a bag
read into a demonstration, :func:`bag_summary`).
"""

from __future__ import annotations

from .mapping import HAND_TYPES, OBJECT_TYPES, HandSource, ObjectSource, RosMapping, read_mapping
from .read import bag_summary as bag_summary
from .read import load_ros

__all__ = [
    "HAND_TYPES",
    "OBJECT_TYPES",
    "HandSource",
    "ObjectSource",
    "RosMapping",
    "load_ros",
    "read_mapping",
]
