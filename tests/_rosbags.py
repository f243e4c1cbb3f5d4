"""Small ROS bags made with ``rosbags`` itself from a demonstration (tests of lfd.io.ros).

Three layouts, one per bag format, so the reader's paths are all exercised:

- :func:`write_ros1` (``.bag``): objects as tf frames under a static ``world -> camera``
  (``/tf_static``) and dynamic ``camera -> box_i`` (``/tf``); the hand a ``PoseArray`` in
  ``camera``;
- :func:`write_ros2` with ``storage="sqlite3"``: objects ``PoseStamped`` in ``world``, the hand a
  ``MarkerArray`` (one SPHERE_LIST marker), everything in millimetres;
- :func:`write_ros2` with ``storage="mcap"``: objects ``PoseStamped`` in ``world``, the hand a
  ``PoseArray`` whose poses are in reverse order (mapped back with ``hand.order``).

Each returns the matching topic mapping (TOML text).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import lfd
import numpy as np
from scipy.spatial.transform import Rotation

WORLD_T_CAMERA = np.eye(4)
WORLD_T_CAMERA[:3, :3] = Rotation.from_euler("xyz", [2.4, 0.1, -0.7]).as_matrix()
WORLD_T_CAMERA[:3, 3] = (0.3, -0.2, 0.8)


def _header(store: Any, t: int, frame: str) -> Any:
    T = store.types
    stamp = T["builtin_interfaces/msg/Time"](sec=t // 1_000_000_000, nanosec=t % 1_000_000_000)
    H = T["std_msgs/msg/Header"]
    if "seq" in H.__dataclass_fields__:
        return H(seq=0, stamp=stamp, frame_id=frame)
    return H(stamp=stamp, frame_id=frame)


def _pose(store: Any, p: np.ndarray, q: np.ndarray) -> Any:
    T = store.types
    return T["geometry_msgs/msg/Pose"](
        position=T["geometry_msgs/msg/Point"](x=float(p[0]), y=float(p[1]), z=float(p[2])),
        orientation=T["geometry_msgs/msg/Quaternion"](
            x=float(q[0]), y=float(q[1]), z=float(q[2]), w=float(q[3])
        ),
    )


def _tf(store: Any, t: int, parent: str, child: str, m: np.ndarray) -> Any:
    T = store.types
    q = Rotation.from_matrix(m[:3, :3]).as_quat()
    tr = T["geometry_msgs/msg/Transform"](
        translation=T["geometry_msgs/msg/Vector3"](x=m[0, 3], y=m[1, 3], z=m[2, 3]),
        rotation=T["geometry_msgs/msg/Quaternion"](x=q[0], y=q[1], z=q[2], w=q[3]),
    )
    return T["geometry_msgs/msg/TransformStamped"](
        header=_header(store, t, parent), child_frame_id=child, transform=tr
    )


def _matrix(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = Rotation.from_quat(q).as_matrix()
    m[:3, 3] = p
    return m


def _objects_toml(demo: lfd.Demonstration, how: str) -> str:
    out = []
    for o in demo.objects.values():
        size = ", ".join(f"{v!r}" for v in o.size.tolist())
        where = f'frame = "{o.name}"' if how == "frame" else f'topic = "/{o.name}/pose"'
        out.append(f"[objects.{o.name}]\n{where}\nsize = [{size}]\ntag_id = {o.tag_id}\n")
    return "\n".join(out)


def write_ros1(demo: lfd.Demonstration, path: Path, *, compression: str | None = None) -> str:
    """A ROS 1 bag of ``demo`` (layout in the module docstring), chunks compressed with
    ``compression`` (``bz2``, ``lz4``) if given; returns its mapping."""
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    if "tf2_msgs/msg/TFMessage" not in store.types:  # not in rosbags' noetic store
        store.register(
            get_types_from_msg(
                "geometry_msgs/TransformStamped[] transforms", "tf2_msgs/msg/TFMessage"
            )
        )
    T = store.types
    cam_T_world = np.linalg.inv(WORLD_T_CAMERA)
    msgs: list[tuple[int, str, Any]] = []
    t0 = demo.start_ns
    msgs.append((t0, "/tf_static", T["tf2_msgs/msg/TFMessage"](
        transforms=[_tf(store, t0, "world", "camera", WORLD_T_CAMERA)])))  # fmt: skip
    for o in demo.objects.values():
        for t, p, q in zip(o.t_ns, o.position, o.quaternion, strict=True):
            m = cam_T_world @ _matrix(p, q)
            msgs.append((int(t), "/tf", T["tf2_msgs/msg/TFMessage"](
                transforms=[_tf(store, int(t), "camera", o.name, m)])))  # fmt: skip
    # one hand: /hand/keypoints; two: the left hand's on /hand/keypoints_left too
    topic_of = {"right": "/hand/keypoints", "left": "/hand/keypoints_left"}
    if demo.other_hand is None:
        topic_of[demo.hand.side] = "/hand/keypoints"
    for hand in demo.hands.values():
        for t, kp in zip(hand.t_ns, hand.keypoints, strict=True):
            pts = kp @ cam_T_world[:3, :3].T + cam_T_world[:3, 3]
            poses = [_pose(store, p, np.array([0, 0, 0, 1.0])) for p in pts]
            msgs.append((int(t), topic_of[hand.side], T["geometry_msgs/msg/PoseArray"](
                header=_header(store, int(t), "camera"), poses=poses)))  # fmt: skip
    types = {
        "/tf": "tf2_msgs/msg/TFMessage",
        "/tf_static": "tf2_msgs/msg/TFMessage",
        **{topic_of[side]: "geometry_msgs/msg/PoseArray" for side in demo.hands},
    }
    w = Writer(path)
    if compression is not None:
        w.set_compression(Writer.CompressionFormat[compression.upper()])
    with w:
        conns = {k: w.add_connection(k, v, typestore=store) for k, v in types.items()}
        for t, topic, msg in sorted(msgs, key=lambda m: m[0]):
            w.write(conns[topic], t, store.serialize_ros1(msg, types[topic]))
    if demo.other_hand is not None:
        hands = "".join(f'[hands.{side}]\ntopic = "{topic_of[side]}"\n\n' for side in demo.hands)
        return 'reference_frame = "world"\nunits = "m"\n\n' + hands + _objects_toml(demo, "frame")
    return (
        'reference_frame = "world"\nunits = "m"\n\n[hand]\ntopic = "/hand/keypoints"\n'
        'order = "mediapipe"\nside = "right"\n\n' + _objects_toml(demo, "frame")
    )


def write_ros2(demo: lfd.Demonstration, path: Path, storage: str) -> str:
    """A ROS 2 bag directory of ``demo`` with ``storage`` ``sqlite3`` or ``mcap``."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    T = store.types
    mm = storage == "sqlite3"
    scale = 1000.0 if mm else 1.0
    msgs: list[tuple[int, str, Any]] = []
    types: dict[str, str] = {}
    for o in demo.objects.values():
        topic = f"/{o.name}/pose"
        types[topic] = "geometry_msgs/msg/PoseStamped"
        for t, p, q in zip(o.t_ns, o.position, o.quaternion, strict=True):
            msgs.append((int(t), topic, T["geometry_msgs/msg/PoseStamped"](
                header=_header(store, int(t), "world"), pose=_pose(store, p * scale, q))))  # fmt: skip
    if mm:
        types["/hand/markers"] = "visualization_msgs/msg/MarkerArray"
        Marker = T["visualization_msgs/msg/Marker"]
        for t, kp in zip(demo.hand.t_ns, demo.hand.keypoints, strict=True):
            marker = Marker(
                header=_header(store, int(t), "world"),
                ns="hand",
                id=0,
                type=Marker.SPHERE_LIST,
                action=Marker.ADD,
                pose=_pose(store, np.zeros(3), np.array([0, 0, 0, 1.0])),
                scale=T["geometry_msgs/msg/Vector3"](x=0.01, y=0.01, z=0.01),
                color=T["std_msgs/msg/ColorRGBA"](r=1.0, g=0.0, b=0.0, a=1.0),
                lifetime=T["builtin_interfaces/msg/Duration"](sec=0, nanosec=0),
                frame_locked=False,
                points=[T["geometry_msgs/msg/Point"](x=p[0], y=p[1], z=p[2]) for p in kp * scale],
                colors=[],
                texture_resource="",
                texture=T["sensor_msgs/msg/CompressedImage"](
                    header=_header(store, 0, ""), format="", data=np.zeros(0, np.uint8)
                ),
                uv_coordinates=[],
                text="",
                mesh_resource="",
                mesh_file=T["visualization_msgs/msg/MeshFile"](
                    filename="", data=np.zeros(0, np.uint8)
                ),
                mesh_use_embedded_materials=False,
            )
            msgs.append((int(t), "/hand/markers",
                         T["visualization_msgs/msg/MarkerArray"](markers=[marker])))  # fmt: skip
        hand = '[hand]\ntopic = "/hand/markers"\n'
    else:
        types["/hand/poses"] = "geometry_msgs/msg/PoseArray"
        for t, kp in zip(demo.hand.t_ns, demo.hand.keypoints, strict=True):
            poses = [_pose(store, p, np.array([0, 0, 0, 1.0])) for p in kp[::-1]]
            msgs.append((int(t), "/hand/poses", T["geometry_msgs/msg/PoseArray"](
                header=_header(store, int(t), "world"), poses=poses)))  # fmt: skip
        order = ", ".join(str(20 - i) for i in range(21))
        hand = f'[hand]\ntopic = "/hand/poses"\norder = [{order}]\n'
    plugin = StoragePlugin.SQLITE3 if storage == "sqlite3" else StoragePlugin.MCAP
    with Writer(path, version=9, storage_plugin=plugin) as w:
        conns = {k: w.add_connection(k, v, typestore=store) for k, v in types.items()}
        for t, topic, msg in sorted(msgs, key=lambda m: m[0]):
            w.write(conns[topic], t, store.serialize_cdr(msg, types[topic]))
    units = "mm" if mm else "m"
    return f'units = "{units}"\n\n{hand}\n' + _objects_toml(demo, "topic")


if __name__ == "__main__":  # regenerates recordings/ros/exp1.bag (see recordings/README.md)
    import sys

    src, dst = sys.argv[1:3]
    Path(dst).unlink(missing_ok=True)
    write_ros1(lfd.load(src, images=False), Path(dst), compression="bz2")
