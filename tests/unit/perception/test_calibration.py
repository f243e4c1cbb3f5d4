"""``lfd perception calibrate``: intrinsics from views of a chessboard, rendered here through a
known camera (the board's plane mapped by ``K [r1 r2 t]``), as photos and as a video."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

cv2 = pytest.importorskip("cv2")

K_TRUE = np.array([[600.0, 0.0, 318.0], [0.0, 605.0, 242.0], [0.0, 0.0, 1.0]])
COLS, ROWS, SQUARE = 9, 6, 0.025
W, H = 640, 480


def _views(n: int, seed: int = 0) -> list[np.ndarray]:
    """``n`` grey 640x480 views of a 10 x 7-square board from random directions."""
    px = 4000.0  # board texture pixels per metre
    side = int(SQUARE * px)
    tex = np.full(((ROWS + 3) * side, (COLS + 3) * side), 255, np.uint8)
    for i in range(COLS + 1):
        for j in range(ROWS + 1):
            if (i + j) % 2 == 0:
                tex[(j + 1) * side : (j + 2) * side, (i + 1) * side : (i + 2) * side] = 0
    # texture pixel (u, v) -> board point (u / px - 2 s, v / px - 2 s, 0): the first inner
    # corner is the origin
    to_board = np.array([[1 / px, 0, -2 * SQUARE], [0, 1 / px, -2 * SQUARE], [0, 0, 1]])
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        R, _ = cv2.Rodrigues(rng.normal(0.0, 0.35, 3))
        t = np.array([rng.uniform(-0.08, 0.0), rng.uniform(-0.06, 0.0), rng.uniform(0.35, 0.6)])
        hom = K_TRUE @ np.column_stack([R[:, 0], R[:, 1], t]) @ to_board
        out.append(cv2.warpPerspective(tex, hom, (W, H), borderValue=200))
    return out


def _photos(tmp_path: Path, n: int = 14) -> list[Path]:
    paths = []
    for k, view in enumerate(_views(n)):
        p = tmp_path / f"board_{k:02d}.png"
        cv2.imwrite(str(p), view)
        paths.append(p)
    return paths


def _check_camera_json(path: Path) -> dict[str, object]:
    from lfd.perception.sources import read_camera_json

    camera, objects, doc, _ = read_camera_json(path)  # what lfd record reads
    assert (camera.width, camera.height) == (W, H)
    assert objects == []
    np.testing.assert_allclose(camera.K, K_TRUE, rtol=0, atol=0.01 * K_TRUE[0, 0])
    return doc


def test_calibrate_photos(tmp_path: Path, lfd_main: Callable[..., object]) -> None:
    photos = _photos(tmp_path)
    out = tmp_path / "camera.json"
    argv = ["perception", "calibrate", *photos, "--board", "9x6", "--square", SQUARE, "-o", out]
    proc = lfd_main(argv)
    assert proc.returncode == 0, proc.stderr  # type: ignore[attr-defined]
    assert "reprojection error" in proc.stdout  # type: ignore[attr-defined]
    doc = _check_camera_json(out)
    cal = doc["calibration"]
    assert isinstance(cal, dict) and cal["rms_px"] < 0.5 and cal["views"] >= 6, cal
    assert len(json.loads(out.read_text())["dist"]) == 5


def test_calibrate_video(tmp_path: Path, lfd_main: Callable[..., object]) -> None:
    video = tmp_path / "board.avi"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"MJPG"), 10.0, (W, H), False)
    assert writer.isOpened()
    for view in _views(14, seed=1):
        for _ in range(3):  # each view held for 3 frames; --every 3 takes one of each
            writer.write(view)
    writer.release()
    out = tmp_path / "camera.json"
    argv = ["perception", "calibrate", video, "--board", "9x6", "--square", SQUARE]
    proc = lfd_main([*argv, "--every", "3", "-o", out])
    assert proc.returncode == 0, proc.stderr  # type: ignore[attr-defined]
    _check_camera_json(out)


@pytest.mark.parametrize(
    ("extra", "expected"),
    [
        (["--board", "8x6"], "the whole 8x6 board was found in 0 of 5 views"),
        (["--board", "9"], "expected COLSxROWS inner corners"),
        (["--board", "9x6", "--square", "0"], "--square"),
        (["--board", "2x2"], "each side must have 3 to 100 inner corners"),
        (["--board", "100000x100000"], "expected COLSxROWS inner corners"),
        (["--board", "101x6"], "each side must have 3 to 100 inner corners"),
        (["--board", "9x6", "--square", "1e308"], "must be a number in [0.001, 1]"),
        (["--board", "9x6", "--square", "5e-324"], "must be a number in [0.001, 1]"),
        (["--board", "9x6", "--square", "nan"], "must be a finite number"),
    ],
)
def test_calibrate_refuses_in_one_line(
    extra: list[str], expected: str, tmp_path: Path, lfd_main: Callable[..., object]
) -> None:
    photos = _photos(tmp_path, n=5)
    out = tmp_path / "camera.json"
    square = [] if "--square" in extra else ["--square", str(SQUARE)]
    proc = lfd_main(["perception", "calibrate", *photos, *extra, *square, "-o", out])
    err = proc.stderr  # type: ignore[attr-defined]
    lines = [line for line in err.splitlines() if line.strip()]
    assert proc.returncode == 2, err  # type: ignore[attr-defined]
    assert len(lines) == 1 and expected in lines[0], err
    assert not out.exists()


def test_calibrate_does_not_write_onto_a_view(
    tmp_path: Path, lfd_main: Callable[..., object]
) -> None:
    photos = _photos(tmp_path, n=5)
    before = photos[0].read_bytes()
    argv = ["perception", "calibrate", *photos, "--board", "9x6", "--square", SQUARE]
    proc = lfd_main([*argv, "-o", photos[0]])
    assert proc.returncode == 2  # type: ignore[attr-defined]
    assert photos[0].read_bytes() == before


def test_calibrate_an_unreadable_video(tmp_path: Path, lfd_main: Callable[..., object]) -> None:
    bad = tmp_path / "broken.mp4"
    bad.write_bytes(b"\x00not a video" * 100)
    argv = ["perception", "calibrate", bad, "--board", "9x6", "--square", SQUARE]
    proc = lfd_main([*argv, "-o", tmp_path / "camera.json"])
    err = proc.stderr  # type: ignore[attr-defined]
    assert proc.returncode == 2, err  # type: ignore[attr-defined]
    assert [line for line in err.splitlines() if line.strip()] == [
        f"lfd perception: error: {bad}: not a readable video (OpenCV decodes no frame of it)"
    ], err


def _claiming(path: Path, width: int, height: int) -> Path:
    """An image file whose header claims ``width`` x ``height`` pixels (its data is a small
    image's: a decoder would allocate the claimed size first)."""
    import struct
    import zlib

    small = cv2.imencode(path.suffix, np.zeros((8, 8), np.uint8))[1].tobytes()
    if path.suffix == ".png":
        ihdr = struct.pack(">II", width, height) + small[24:29]
        data = small[:16] + ihdr + struct.pack(">I", zlib.crc32(b"IHDR" + ihdr)) + small[33:]
    else:  # JPEG: the baseline frame header (SOF0) holds height, width
        at = small.index(b"\xff\xc0")
        data = small[: at + 5] + struct.pack(">HH", height, width) + small[at + 9 :]
    path.write_bytes(data)
    return path


@pytest.mark.parametrize(("name", "size"), [("big.png", 100_000), ("big.jpg", 20_000)])
def test_calibrate_refuses_a_huge_image_from_its_header(
    tmp_path: Path, lfd_main: Callable[..., object], name: str, size: int
) -> None:
    """A PNG claiming 100000 x 100000 pixels (a MemoryError, or 30 GB), four 20000 x 20000
    JPEGs (minutes of corner search): refused from the header, before decoding, in one line."""
    import time

    from lfd.perception.image_header import image_size

    big = _claiming(tmp_path / name, size, size)
    assert image_size(big.read_bytes()) == (size, size)
    views = [big] if size > 50_000 else [big, big, big, big]
    start = time.perf_counter()
    argv = ["perception", "calibrate", *views, "--board", "9x6", "--square", SQUARE]
    proc = lfd_main([*argv, "-o", tmp_path / "camera.json"])
    assert time.perf_counter() - start < 5.0
    err = proc.stderr  # type: ignore[attr-defined]
    assert proc.returncode == 2, err  # type: ignore[attr-defined]
    assert [line for line in err.splitlines() if line.strip()] == [
        f"lfd perception: error: {big}: the image claims {size} x {size} pixels, more than the "
        "50 megapixels lfd decodes"
    ], err


def test_calibrate_reads_a_bounded_number_of_views(monkeypatch: pytest.MonkeyPatch) -> None:
    from lfd.errors import LfdWarning
    from lfd.perception import calibration

    monkeypatch.setattr(calibration, "MAX_VIEWS", 6)
    read = []

    def views():  # type: ignore[no-untyped-def]
        for view in _views(14):
            read.append(1)
            yield view

    with pytest.warns(LfdWarning, match="calibrated from the first 6 views"):
        cal = calibration.calibrate(views(), COLS, ROWS, SQUARE)
    assert cal.views + cal.skipped == 6 and len(read) == 7  # the 7th is read, not searched
    np.testing.assert_allclose(cal.K, K_TRUE, rtol=0, atol=0.02 * K_TRUE[0, 0])
