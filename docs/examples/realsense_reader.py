"""An Intel RealSense (D400 series) as an ``lfd record`` RGB-D source, through pyrealsense2.

    pip install pyrealsense2
    lfd record --source camera:0 --intrinsics camera.json -o demo.mcap \
        --depth-reader docs/examples/realsense_reader.py:make_reader

``read_frame()`` gives colour and depth from the same frameset, depth aligned to the colour
camera (``rs.align``) and in millimetres (the D400 default depth unit is 1 mm), so lfd opens no
separate video device. ``camera.json`` must hold the colour stream's intrinsics:
``write_camera_json()`` writes them (add your objects' names, tag ids and sizes).
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np

WIDTH, HEIGHT, FPS = 640, 480, 30


class RealSenseReader:
    def __init__(self, width: int = WIDTH, height: int = HEIGHT, fps: int = FPS) -> None:
        import pyrealsense2 as rs

        self.rs = rs
        self.pipeline = rs.pipeline()
        config = rs.config()
        config.enable_stream(rs.stream.color, width, height, rs.format.rgb8, fps)
        config.enable_stream(rs.stream.depth, width, height, rs.format.z16, fps)
        self.profile = self.pipeline.start(config)
        self.align = rs.align(rs.stream.color)
        scale = self.profile.get_device().first_depth_sensor().get_depth_scale()
        self.to_mm = scale * 1000.0  # depth units -> millimetres (1.0 on D400 defaults)

    def read_frame(self) -> tuple[np.ndarray, np.ndarray] | None:
        frames = self.align.process(self.pipeline.wait_for_frames())
        color, depth = frames.get_color_frame(), frames.get_depth_frame()
        if not color or not depth:
            return None
        d = np.asanyarray(depth.get_data())
        if self.to_mm != 1.0:
            d = np.clip(d * self.to_mm, 0, 65535).astype(np.uint16)
        return np.asanyarray(color.get_data()).copy(), d.copy()

    def read(self) -> np.ndarray | None:
        got = self.read_frame()
        return None if got is None else got[1]

    def intrinsics(self) -> dict[str, Any]:
        stream = self.profile.get_stream(self.rs.stream.color).as_video_stream_profile()
        i = stream.get_intrinsics()
        K = [[i.fx, 0.0, i.ppx], [0.0, i.fy, i.ppy], [0.0, 0.0, 1.0]]
        return {"width": i.width, "height": i.height, "K": K, "fps": FPS}

    def close(self) -> None:
        self.pipeline.stop()


def make_reader() -> RealSenseReader:
    """The factory ``--depth-reader`` calls."""
    return RealSenseReader()


def write_camera_json(path: str = "camera.json") -> None:
    """Write the colour intrinsics of the connected camera, with an example object list."""
    reader = RealSenseReader()
    try:
        doc = reader.intrinsics()
    finally:
        reader.close()
    doc["objects"] = [{"name": "box_1", "tag_id": 1, "size": [0.05, 0.05, 0.05]}]
    with open(path, "w") as fh:
        json.dump(doc, fh, indent=2)


if __name__ == "__main__":
    write_camera_json()
