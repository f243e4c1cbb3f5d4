"""RGB-D frames with REAL hands: the hands of ../shared/realhands/tfjs_hands.jpg cut out (white
background) and moved over a table, with a depth image in which each hand is a flat sheet at a
known height. A left hand and its mirror image (a right hand) cross each other, so tests can
check hand selection, tracking and lifting through ``lfd record --source frames:DIR``."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

W, H = 640, 480
K = np.array([[600.0, 0.0, 320.0], [0.0, 600.0, 240.0], [0.0, 0.0, 1.0]])
CAMERA_HEIGHT = 0.80
"""The camera looks straight down from this height (m) on the table (world z = 0)."""
WORLD_T_CAMERA = np.array(
    [[1.0, 0, 0, 0], [0, -1.0, 0, 0], [0, 0, -1.0, CAMERA_HEIGHT], [0, 0, 0, 1.0]]
)
HAND_HEIGHT = {"left": 0.06, "right": 0.10}
"""Height (m) of each hand's top (the sheet the depth image shows) above the table."""
TABLE_RGB = (150, 140, 125)
BOX = {"name": "box_1", "tag_id": 1, "size": [0.08, 0.08, 0.08], "tag_size": 0.06}
BOX_CENTRE = np.array([0.288, 0.168, 0.04])
"""A tagged cube on the table, seen at pixel (560, 100), where the hands never pass."""


def _box_pixels() -> tuple[np.ndarray, np.ndarray, int]:
    """The box top's white square and the tag (uint8 RGB patches) and its top-left pixel."""
    import cv2

    z = CAMERA_HEIGHT - 2 * BOX_CENTRE[2]
    top = round(BOX["size"][0] * K[0, 0] / z)
    tag = round(BOX["tag_size"] * K[0, 0] / z)
    white = np.full((top, top, 3), 255, np.uint8)
    d = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_50)
    marker = cv2.aruco.generateImageMarker(d, BOX["tag_id"], tag)
    o = (top - tag) // 2
    white[o : o + tag, o : o + tag] = marker[:, :, None]
    return white, np.array([560 - top / 2, 100 - top / 2]).round().astype(int), round(z * 1000)


def cutouts(realhands: Path, scale: float = 0.5) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """{"left": (rgb, mask), "right": (rgb, mask)}: the left hand of hands.jpg and its mirror."""
    import cv2

    bgr = cv2.imread(str(realhands / "tfjs_hands.jpg"))
    rgb = cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)[:, :360]
    rgb = cv2.resize(rgb, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
    mask = rgb.min(axis=2) < 235
    mask = cv2.morphologyEx(mask.astype(np.uint8), cv2.MORPH_OPEN, np.ones((3, 3), np.uint8)) > 0
    return {"left": (rgb, mask), "right": (rgb[:, ::-1].copy(), mask[:, ::-1].copy())}


def frame(
    hands: dict[str, tuple[np.ndarray, np.ndarray]], f: int
) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """Colour, depth (mm) and each hand's pixel mask of frame ``f``: the hands pass each other."""
    color = np.empty((H, W, 3), np.uint8)
    color[:] = TABLE_RGB
    depth = np.full((H, W), round(CAMERA_HEIGHT * 1000), np.uint16)
    box, (bu, bv), bz = _box_pixels()
    color[bv : bv + box.shape[0], bu : bu + box.shape[1]] = box
    depth[bv : bv + box.shape[0], bu : bu + box.shape[1]] = bz
    masks = {}
    places = {"left": (20 + 7 * f, 40), "right": (W - 200 - 7 * f, 250)}
    for side in ("left", "right"):
        rgb, mask = hands[side]
        x, y = places[side]
        h, w = mask.shape
        x0, y0 = max(0, x), max(0, y)
        x1, y1 = min(W, x + w), min(H, y + h)
        m = mask[y0 - y : y1 - y, x0 - x : x1 - x]
        region = color[y0:y1, x0:x1]
        region[m] = rgb[y0 - y : y1 - y, x0 - x : x1 - x][m]
        depth[y0:y1, x0:x1][m] = round((CAMERA_HEIGHT - HAND_HEIGHT[side]) * 1000)
        full = np.zeros((H, W), bool)
        full[y0:y1, x0:x1] = m
        masks[side] = full
    return color, depth, masks


def write_folder(out: Path, realhands: Path, n: int = 20, fps: float = 15.0) -> Path:
    """A ``frames:DIR`` source folder (colour + depth PNGs, camera.json with the camera pose)."""
    import cv2

    hands = cutouts(realhands)
    (out / "color").mkdir(parents=True, exist_ok=True)
    (out / "depth").mkdir(exist_ok=True)
    for f in range(n):
        color, depth, _ = frame(hands, f)
        cv2.imwrite(str(out / "color" / f"{f:06d}.png"), cv2.cvtColor(color, cv2.COLOR_RGB2BGR))
        cv2.imwrite(str(out / "depth" / f"{f:06d}.png"), depth)
    doc = {
        "width": W,
        "height": H,
        "K": K.tolist(),
        "fps": fps,
        "world_T_camera": WORLD_T_CAMERA.tolist(),
        "objects": [BOX],
    }
    (out / "camera.json").write_text(json.dumps(doc))
    return out


def project(points_world: np.ndarray) -> np.ndarray:
    """World points (n, 3) -> pixels (n, 2)."""
    cam = (np.asarray(points_world) - WORLD_T_CAMERA[:3, 3]) @ WORLD_T_CAMERA[:3, :3]
    uv = cam @ K.T
    return np.asarray(uv[:, :2] / uv[:, 2:3])
