"""An image file's size from its header, read before it is decoded: a file that claims more
than :data:`MAX_IMAGE_PIXELS` is refused without allocating its pixels.

PNG, JPEG, BMP, GIF, WebP, TIFF and PNM headers are read; :func:`image_size` returns None for
any other format (OpenCV then decodes it as before).
"""

from __future__ import annotations

import os
import struct
from pathlib import Path

import numpy as np

MAX_IMAGE_PIXELS = 50_000_000
"""Largest image lfd decodes, pixels: 50 megapixels (an 8000 x 6000 photo)."""


def image_size(data: bytes) -> tuple[int, int] | None:
    """(width, height) that the header of an encoded image claims, or None when the format is
    not one of those read here or the header is cut short."""
    try:
        for reader in (_png, _jpeg, _bmp, _gif, _webp, _tiff, _pnm):
            size = reader(data)
            if size is not None:
                return size
    except (struct.error, IndexError, ValueError):
        return None
    return None


def _png(d: bytes) -> tuple[int, int] | None:
    if not d.startswith(b"\x89PNG\r\n\x1a\n") or d[12:16] != b"IHDR":
        return None
    w, h = struct.unpack(">II", d[16:24])
    return int(w), int(h)


_JPEG_SOF = {0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF}


def _jpeg(d: bytes) -> tuple[int, int] | None:
    if not d.startswith(b"\xff\xd8"):
        return None
    i = 2
    while i + 4 <= len(d):
        if d[i] != 0xFF:
            return None
        marker = d[i + 1]
        if marker == 0xFF:  # fill byte
            i += 1
            continue
        if marker in (0xD8, 0x01) or 0xD0 <= marker <= 0xD7:  # no length
            i += 2
            continue
        (length,) = struct.unpack(">H", d[i + 2 : i + 4])
        if marker in _JPEG_SOF:
            h, w = struct.unpack(">HH", d[i + 5 : i + 9])
            return int(w), int(h)
        i += 2 + length
    return None


def _bmp(d: bytes) -> tuple[int, int] | None:
    if not d.startswith(b"BM") or len(d) < 26:
        return None
    (header,) = struct.unpack("<I", d[14:18])
    if header == 12:  # OS/2 BITMAPCOREHEADER
        w, h = struct.unpack("<HH", d[18:22])
    else:
        w, h = struct.unpack("<ii", d[18:26])
    return abs(int(w)), abs(int(h))


def _gif(d: bytes) -> tuple[int, int] | None:
    if d[:6] not in (b"GIF87a", b"GIF89a"):
        return None
    w, h = struct.unpack("<HH", d[6:10])
    return int(w), int(h)


def _webp(d: bytes) -> tuple[int, int] | None:
    if d[:4] != b"RIFF" or d[8:12] != b"WEBP":
        return None
    kind = d[12:16]
    if kind == b"VP8X":
        w = int.from_bytes(d[24:27], "little") + 1
        h = int.from_bytes(d[27:30], "little") + 1
        return w, h
    if kind == b"VP8L":
        bits = int.from_bytes(d[21:25], "little")
        return (bits & 0x3FFF) + 1, ((bits >> 14) & 0x3FFF) + 1
    if kind == b"VP8 ":
        w, h = struct.unpack("<HH", d[26:30])
        return int(w) & 0x3FFF, int(h) & 0x3FFF
    return None


def _tiff(d: bytes) -> tuple[int, int] | None:
    order = {b"II": "<", b"MM": ">"}.get(d[:2])
    if order is None or struct.unpack(order + "H", d[2:4])[0] != 42:
        return None
    (ifd,) = struct.unpack(order + "I", d[4:8])
    (count,) = struct.unpack(order + "H", d[ifd : ifd + 2])
    size: dict[int, int] = {}
    for k in range(count):
        entry = d[ifd + 2 + 12 * k : ifd + 14 + 12 * k]
        tag, kind = struct.unpack(order + "HH", entry[:4])
        if tag in (256, 257):  # ImageWidth, ImageLength: SHORT or LONG
            fmt = "H" if kind == 3 else "I"
            size[tag] = int(struct.unpack(order + fmt, entry[8 : 8 + struct.calcsize(fmt)])[0])
    if 256 not in size or 257 not in size:
        return None
    return size[256], size[257]


def _pnm(d: bytes) -> tuple[int, int] | None:
    if len(d) < 3 or d[0:1] != b"P" or d[1:2] not in b"123456" or d[2:3] not in b" \t\r\n":
        return None
    fields: list[bytes] = []
    for line in d[2:512].splitlines():
        fields += line.split(b"#", 1)[0].split()
        if len(fields) >= 2:
            return int(fields[0]), int(fields[1])
    return None


def decode(path: str | os.PathLike[str], what: str, flags: int) -> np.ndarray:
    """The decoded image file (OpenCV ``flags``), or a one-line :class:`LfdError` naming it: a
    file that is not a regular file, that claims more than :data:`MAX_IMAGE_PIXELS` (refused
    from its header, before decoding) or that OpenCV cannot decode."""
    import cv2

    from ..errors import LfdError
    from ..inputs import check_input_file

    p = Path(check_input_file(path, what, LfdError))  # a FIFO or a device: refused
    if not p.is_file():
        raise LfdError(f"{p}: {what} not found")
    data = np.fromfile(p, np.uint8)
    size = image_size(data.tobytes())
    if size is not None and size[0] * size[1] > MAX_IMAGE_PIXELS:
        raise LfdError(
            f"{p}: the {what} claims {size[0]} x {size[1]} pixels, more than the "
            f"{MAX_IMAGE_PIXELS / 1e6:g} megapixels lfd decodes"
        )
    # OpenCV logs its own "[ WARN ]" line for a truncated file; the error below says it once.
    level = cv2.utils.logging.getLogLevel()
    cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_SILENT)
    try:
        img = cv2.imdecode(data, flags) if data.size else None
    except cv2.error:
        img = None
    finally:
        cv2.utils.logging.setLogLevel(level)
    if img is None:
        raise LfdError(f"{p}: not a readable {what} (OpenCV cannot decode it)")
    return np.asarray(img)
