"""Camera intrinsics from views of a printed chessboard (OpenCV's calibration).

A colour camera (a webcam, a phone) needs its intrinsics ``K`` before ``lfd record`` can turn
tags and hands into metres. Print a chessboard, measure one square, and show it to the camera
from a dozen directions; :func:`calibrate` finds its inner corners in each view
(``cv2.findChessboardCorners``, refined to sub-pixel) and fits ``K`` and the lens distortion
(``cv2.calibrateCamera``). ``lfd perception calibrate`` writes the result as the
``camera.json`` the sources read (``lfd.perception.sources``).

The perception path projects with ``K`` alone (a pinhole camera): the distortion
coefficients are reported and saved (``"dist"``) for information. A lens whose distortion moves
points by more than a few pixels should have its frames undistorted first.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import LfdError, LfdWarning

MIN_VIEWS = 4
"""Views with the whole board found needed for a calibration (OpenCV needs 3; a dozen from
different directions give a good one)."""
BOARD_RANGE = (3, 100)
"""Inner corners of a chessboard along each side (OpenCV's detector needs at least 3)."""
SQUARE_RANGE_M = (0.001, 1.0)
"""Plausible side of a chessboard square (m)."""
MAX_VIEWS = 200
"""Views read at most; a calibration needs a dozen."""
MAX_TOTAL_PIXELS = 500_000_000
"""Pixels read at most over all views (40 photos of 12 megapixels, 240 full-HD video frames):
the corner search costs time per pixel."""


def board_problem(cols: int, rows: int, square_m: float) -> str | None:
    """What is wrong with a chessboard of ``cols`` x ``rows`` inner corners and squares of
    ``square_m`` metres (None: usable)."""
    lo, hi = BOARD_RANGE
    if not (lo <= cols <= hi and lo <= rows <= hi):
        return f"a chessboard has {lo} to {hi} inner corners along each side, got {cols} x {rows}"
    s_lo, s_hi = SQUARE_RANGE_M
    if not (math.isfinite(square_m) and s_lo <= square_m <= s_hi):
        return f"a chessboard square is {s_lo:g} to {s_hi:g} m, got {square_m:g} m"
    return None


@dataclass(frozen=True)
class Calibration:
    """Intrinsics fitted to chessboard views."""

    K: np.ndarray
    """(3, 3) camera matrix, pixels."""
    dist: np.ndarray
    """OpenCV's distortion coefficients ``(k1, k2, p1, p2, k3)``."""
    width: int
    height: int
    rms_px: float
    """Root-mean-square reprojection error of the board's corners, pixels."""
    views: int
    """Views in which the whole board was found (and used)."""
    skipped: int
    """Views without the whole board."""

    def camera_json(self) -> dict[str, object]:
        """The ``camera.json`` document of ``lfd.perception.sources`` (no objects yet)."""
        return {
            "width": self.width,
            "height": self.height,
            "K": [[float(v) for v in row] for row in self.K],
            "dist": [float(v) for v in self.dist.ravel()],
            "calibration": {"rms_px": self.rms_px, "views": self.views},
            "objects": [],
        }


def board_points(cols: int, rows: int, square_m: float) -> np.ndarray:
    """The inner corners of a ``cols`` x ``rows`` chessboard on its plane (z = 0), metres,
    in OpenCV's order (row by row)."""
    grid = np.mgrid[0:cols, 0:rows].T.reshape(-1, 2).astype(np.float32)
    return np.hstack([grid * np.float32(square_m), np.zeros((len(grid), 1), np.float32)])


def calibrate(images: Iterable[np.ndarray], cols: int, rows: int, square_m: float) -> Calibration:
    """Fit the intrinsics to views of a chessboard of ``cols`` x ``rows`` inner corners and
    squares of ``square_m`` metres; ``images`` are colour (H, W, 3) or grey (H, W) uint8 arrays
    of one size.

    Raises
    ------
    LfdError
        A bad board (:func:`board_problem`), images of different sizes, or fewer than
        :data:`MIN_VIEWS` views with the whole board. Views past :data:`MAX_VIEWS` or
        :data:`MAX_TOTAL_PIXELS` are not read (an :class:`~lfd.errors.LfdWarning` says so).
    """
    import cv2

    problem = board_problem(cols, rows, square_m)
    if problem is not None:
        raise LfdError(problem)
    obj = board_points(cols, rows, square_m)
    found_obj, found_img = [], []
    size: tuple[int, int] | None = None
    skipped = 0
    criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 50, 1e-3)
    pixels = 0
    for n, image in enumerate(images):
        pixels += image.shape[0] * image.shape[1]
        if n == MAX_VIEWS or pixels > MAX_TOTAL_PIXELS:
            warnings.warn(
                f"calibrated from the first {n} views: the bound is {MAX_VIEWS} views and "
                f"{MAX_TOTAL_PIXELS / 1e6:g} megapixels; the rest were not read",
                LfdWarning,
                stacklevel=2,
            )
            break
        grey = image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_RGB2GRAY)
        here = (int(grey.shape[1]), int(grey.shape[0]))
        if size is None:
            size = here
        elif here != size:
            raise LfdError(f"view {n} is {here[0]}x{here[1]}, the first was {size[0]}x{size[1]}")
        ok, corners = cv2.findChessboardCorners(
            grey, (cols, rows), flags=cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE
        )
        if not ok:
            skipped += 1
            continue
        corners = cv2.cornerSubPix(grey, corners, (5, 5), (-1, -1), criteria)
        found_obj.append(obj)
        found_img.append(corners)
    if size is None:
        raise LfdError("no image to calibrate from")
    if len(found_obj) < MIN_VIEWS:
        raise LfdError(
            f"the whole {cols}x{rows} board was found in {len(found_obj)} of "
            f"{len(found_obj) + skipped} views; at least {MIN_VIEWS} are needed (check the "
            "inner-corner count: a board of 10 x 7 squares has 9 x 6 inner corners)"
        )
    rms, K, dist, _, _ = cv2.calibrateCamera(found_obj, found_img, size, None, None)
    return Calibration(
        K=np.asarray(K, dtype=np.float64),
        dist=np.asarray(dist, dtype=np.float64).ravel(),
        width=size[0],
        height=size[1],
        rms_px=float(rms),
        views=len(found_obj),
        skipped=skipped,
    )


VIDEO_SUFFIXES = (".mp4", ".mov", ".avi", ".mkv", ".webm", ".m4v")
"""Files read as videos (every ``every``-th frame a view); any other file is an image."""


def views(paths: Iterable[str | Path], every: int = 10) -> Iterator[np.ndarray]:
    """The views in image files and videos (:data:`VIDEO_SUFFIXES`; every ``every``-th frame),
    as (H, W, 3) uint8 RGB arrays, in order; a file that cannot be read is a one-line
    :class:`LfdError` naming it."""
    import cv2

    from ..inputs import check_input_file
    from .hand.stills import read_image
    from .stderr import quiet_stderr

    for path in paths:
        if Path(path).suffix.lower() not in VIDEO_SUFFIXES:
            yield read_image(path)
            continue
        p = check_input_file(path, "video", LfdError)
        with quiet_stderr():  # FFmpeg's own line for a damaged file: the error below says it
            cap = cv2.VideoCapture(str(p))
            ok, frame = cap.read()
        try:
            n = 0
            if not ok:
                raise LfdError(f"{p}: not a readable video (OpenCV decodes no frame of it)")
            while ok:
                if n % every == 0:
                    yield np.asarray(cv2.cvtColor(frame, cv2.COLOR_BGR2RGB))
                n += 1
                ok, frame = cap.read()
        finally:
            cap.release()
