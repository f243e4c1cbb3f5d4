"""Image payloads: foxglove.RawImage (rgb8, 16UC1) and PNG/JPEG foxglove.CompressedImage.

Compression uses OpenCV (the ``sim`` extra) or Pillow, whichever is installed; raw images need
neither.
"""

from __future__ import annotations

import io
from typing import Any

import numpy as np

from ..errors import DemonstrationError

__all__ = ["COLOR_FORMATS", "decode_compressed", "decode_raw", "encode_compressed"]

COLOR_FORMATS = ("raw", "png", "jpeg")
"""Colour image storage: ``raw`` (RawImage rgb8) or a CompressedImage format."""


def _backend() -> tuple[str, Any]:
    try:
        import cv2

        return "cv2", cv2
    except ImportError:
        pass
    try:
        from PIL import Image

        return "pil", Image
    except ImportError:
        raise DemonstrationError(
            "PNG/JPEG images need opencv-python-headless (pip install 'lfd[sim]') or pillow"
        ) from None


def encode_compressed(rgb: np.ndarray, fmt: str, *, jpeg_quality: int = 90) -> bytes:
    """Encode an RGB image, shape (H, W, 3) uint8, as ``png`` or ``jpeg`` bytes."""
    if fmt not in ("png", "jpeg"):
        raise DemonstrationError(f"image format must be png or jpeg, got {fmt!r}")
    name, lib = _backend()
    if name == "cv2":
        ext = ".png" if fmt == "png" else ".jpg"
        params = [lib.IMWRITE_JPEG_QUALITY, jpeg_quality] if fmt == "jpeg" else []
        ok, buf = lib.imencode(ext, np.ascontiguousarray(rgb[..., ::-1]), params)
        if not ok:
            raise DemonstrationError(f"OpenCV could not encode a {rgb.shape} image as {fmt}")
        return bytes(buf.tobytes())
    out = io.BytesIO()
    kwargs = {"quality": jpeg_quality} if fmt == "jpeg" else {}
    lib.fromarray(rgb).save(out, format=fmt.upper(), **kwargs)
    return out.getvalue()


def decode_compressed(data: bytes, fmt: str) -> np.ndarray:
    """Decode PNG/JPEG bytes to RGB, shape (H, W, 3) uint8."""
    name, lib = _backend()
    if name == "cv2":
        img = lib.imdecode(np.frombuffer(data, dtype=np.uint8), lib.IMREAD_COLOR)
        if img is None:
            raise ValueError(f"cannot decode a {fmt!r} image of {len(data)} bytes")
        return np.ascontiguousarray(img[..., ::-1])
    try:
        with lib.open(io.BytesIO(data)) as im:
            return np.asarray(im.convert("RGB")).copy()
    except Exception as err:  # Pillow raises many kinds of errors on bad data
        raise ValueError(f"cannot decode a {fmt!r} image of {len(data)} bytes: {err}") from err


def decode_raw(m: Any) -> np.ndarray:
    """Decode a foxglove.RawImage (rgb8, bgr8, mono8 or 16UC1) to (H, W, 3) or (H, W)."""
    channels = {"rgb8": (3, "u1"), "bgr8": (3, "u1"), "mono8": (1, "u1"), "16UC1": (1, "u2")}
    if m.encoding not in channels:
        raise ValueError(f"unsupported image encoding {m.encoding!r}")
    c, kind = channels[m.encoding]
    dtype = np.dtype(kind).newbyteorder("<")  # foxglove.RawImage data is little-endian
    row = m.width * c * dtype.itemsize
    step = m.step or row
    if step < row or len(m.data) < step * m.height:
        raise ValueError(f"image data too short: {len(m.data)} bytes for {m.width}x{m.height}")
    buf = np.frombuffer(m.data, dtype=np.uint8)[: step * m.height].reshape(m.height, step)
    img = buf[:, :row].copy().view(dtype).reshape(m.height, m.width, c)
    img = img.astype(dtype.newbyteorder("="))
    if m.encoding == "bgr8":
        img = img[..., ::-1]
    return np.ascontiguousarray(img[..., 0] if c == 1 else img)
