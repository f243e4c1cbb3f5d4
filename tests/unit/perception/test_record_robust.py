"""``lfd record`` keeps what it recorded whatever fails, and refuses bad camera inputs in one line.

The frames are the simulator's renders (tags, depth) served by a ``--depth-reader`` plug-in, an
image folder or a video file, as a camera, a user's folder or a phone video would give them.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("mujoco")
cv2 = pytest.importorskip("cv2")

from lfd.cli import main  # noqa: E402
from lfd.errors import LfdError  # noqa: E402
from lfd.io import load  # noqa: E402

GOOD_FRAMES = 30


@pytest.fixture(scope="module")
def scene(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """8 rendered frames of exp1 (colour, depth) and a camera.json describing them."""
    from lfd.sim import simulate
    from lfd.sim.render import render_frames

    r = simulate("exp1", seed=0)
    idx = np.linspace(0, r.truth.t_ns.size - 1, 8).astype(int)
    color, depth = render_frames(r.scene, r.truth, idx)
    d = tmp_path_factory.mktemp("scene")
    np.savez(d / "frames.npz", color=color.frames, depth=depth.frames)
    cam = r.demo.camera
    objects = [{"name": o.name, "tag_id": o.tag_id, "size": list(o.size)} for o in r.scene.objects]
    doc = {"width": cam.width, "height": cam.height, "K": cam.K.tolist(), "objects": objects}
    (d / "camera.json").write_text(json.dumps(doc))
    pose = cam.world_T_camera.tolist()
    return {"dir": d, "doc": doc, "color": color.frames, "depth": depth.frames, "pose": pose}


def _plugin(scene: dict[str, Any], tmp_path: Path, then: str, good: int = GOOD_FRAMES) -> str:
    """A ``--depth-reader`` plug-in whose ``read_frame()`` gives ``good`` good frames (the
    renders, in a loop) and then does ``then`` (a Python statement)."""
    path = tmp_path / "plugin.py"
    path.write_text(
        "import numpy as np\n"
        "class Reader:\n"
        "    def __init__(self):\n"
        f"        data = np.load({str(scene['dir'] / 'frames.npz')!r})\n"
        "        self.color, self.depth, self.n = data['color'], data['depth'], 0\n"
        "    def read(self):\n"
        "        return None\n"
        "    def read_frame(self):\n"
        f"        if self.n == {good}:\n"
        f"            {then}\n"
        "        k = self.n % len(self.color)\n"
        "        self.n += 1\n"
        "        return self.color[k], self.depth[k]\n"
        "def make():\n"
        "    return Reader()\n"
    )
    return f"{path}:make"


def _record_argv(scene: dict[str, Any], out: Path, *extra: str) -> list[str]:
    return [
        "record", "--source", "camera:0", "--intrinsics", str(scene["dir"] / "camera.json"),
        "--no-hand", "-o", str(out), *extra,
    ]  # fmt: skip


def _error_lines(err: str) -> list[str]:
    return [line for line in err.splitlines() if line.strip()]


@pytest.mark.parametrize(
    ("then", "why"),
    [
        ("raise RuntimeError('Frame did not arrive within 5000')", "RuntimeError: Frame did not"),
        ("return 'not a frame'", "returned str, not (rgb, depth)"),
        ("return self.color[0][:10], self.depth[0]", "gave a colour image uint8 (10, 640, 3)"),
        ("return self.color[0], self.depth[0].astype(float)", "gave depth float64"),
        ("raise SystemExit(0)", "the depth reader's read_frame() raised SystemExit: 0"),
    ],
)
def test_a_reader_failing_mid_recording_keeps_the_frames_before_it(
    scene: dict[str, Any], tmp_path: Path, capsys: pytest.CaptureFixture[str], then: str, why: str
) -> None:
    """30 good frames, then the plug-in raises (a RealSense timeout) or returns something that
    is not a frame: one line, exit 2, and the recording holds the 30 frames' samples."""
    out = tmp_path / "rec.mcap"
    argv = _record_argv(scene, out, "--depth-reader", _plugin(scene, tmp_path, then))
    assert main(argv) == 2
    lines = _error_lines(capsys.readouterr().err)
    assert len(lines) == 1, lines
    assert lines[0].startswith(f"lfd record: error: camera:0 failed after {GOOD_FRAMES} frames: ")
    assert (
        why in lines[0]
        and f"kept the {GOOD_FRAMES} frames recorded, complete, in {out}" in lines[0]
    )
    demo = load(out)
    assert len(demo.hand) == GOOD_FRAMES  # a hand sample (unobserved: --no-hand) per frame
    assert sorted(demo.objects) == ["box_1", "box_2", "box_3"]
    assert sum(len(o) for o in demo.objects.values()) >= GOOD_FRAMES
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []  # no .partial


def test_a_failure_before_the_first_frame_leaves_no_file(
    scene: dict[str, Any], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "rec.mcap"
    plugin = _plugin(scene, tmp_path, "raise OSError('usb')", good=0)
    assert main(_record_argv(scene, out, "--depth-reader", plugin)) == 2
    lines = _error_lines(capsys.readouterr().err)
    assert (
        len(lines) == 1
        and "failed before the first frame: the depth reader's read_frame() raised OSError: usb"
        in lines[0]
    ), lines
    assert list(tmp_path.glob("*.mcap")) == [] and list(tmp_path.glob(".rec*")) == []


@pytest.mark.parametrize(
    ("code", "why"),
    [
        (
            "def make():\n    raise RuntimeError('no device connected')\n",
            "make() raised RuntimeError: no device",
        ),
        ("def make(:\n    pass\n", "cannot load it: SyntaxError"),
        ("raise ValueError('bad config')\n", "cannot load it: ValueError: bad config"),
        ("def make():\n    return 3\n", "returned an object without read()"),
        ("import sys\nsys.exit(0)\n", "cannot load it: SystemExit: 0"),
        ("def make():\n    raise SystemExit(3)\n", "make() raised SystemExit: 3"),
    ],
)
def test_a_plugin_that_does_not_load_is_one_line(
    scene: dict[str, Any], tmp_path: Path, capsys: pytest.CaptureFixture[str], code: str, why: str
) -> None:
    plugin = tmp_path / "broken.py"
    plugin.write_text(code)
    out = tmp_path / "rec.mcap"
    assert main(_record_argv(scene, out, "--depth-reader", f"{plugin}:make")) == 2
    lines = _error_lines(capsys.readouterr().err)
    assert len(lines) == 1 and lines[0].startswith("lfd record: error: depth reader"), lines
    assert why in lines[0]
    assert not out.exists()


def test_a_reader_whose_close_exits_is_a_warning(
    scene: dict[str, Any], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The recording is made; the plug-in's close() exiting is its failure (a warning), not
    the end of ``lfd record`` with its status."""
    out = tmp_path / "rec.mcap"
    spec = _plugin(scene, tmp_path, "return None")
    path = Path(spec.rpartition(":")[0])
    path.write_text(path.read_text() + "Reader.close = lambda self: exit(0)\n")
    assert main(_record_argv(scene, out, "--depth-reader", spec)) == 0
    lines = [x for x in _error_lines(capsys.readouterr().err) if x.startswith("lfd ")]
    assert lines == [
        "lfd record: warning: camera:0: closing it failed: the depth reader's close() raised "
        "SystemExit: 0"
    ], lines
    assert len(load(out).hand) == GOOD_FRAMES


@pytest.mark.parametrize("index", ["-1", "2147483648", "64", "0x1", "1e3", ""])
def test_camera_index_is_checked_before_opencv_is_asked(
    scene: dict[str, Any],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    index: str,
) -> None:
    """``camera:-1`` crashed OpenCV (SIGSEGV), ``camera:2147483648`` overflowed: both are
    refused before any device is opened."""

    def never(*args: Any) -> None:
        raise AssertionError("cv2.VideoCapture must not be called")

    monkeypatch.setattr(cv2, "VideoCapture", never)
    argv = _record_argv(scene, tmp_path / "x.mcap")
    argv[argv.index("camera:0")] = f"camera:{index}"
    assert main(argv) == 2
    lines = _error_lines(capsys.readouterr().err)
    assert len(lines) == 1, lines
    assert "device index must be an integer in [0, 63]" in lines[0] or "expected" in lines[0]


# --- the recorder's own parts failing (library) -----------------------------------------------


def _folder(scene: dict[str, Any], tmp_path: Path, n: int = 8, pose: bool = False) -> Path:
    """An image folder of ``n`` renders (``pose``: camera.json gives the camera pose, so the
    hand is estimated from the first frame)."""
    d = tmp_path / "frames"
    (d / "color").mkdir(parents=True)
    (d / "depth").mkdir()
    for k in range(n):
        cv2.imwrite(str(d / "color" / f"{k:06d}.png"), scene["color"][k % 8][:, :, ::-1])
        cv2.imwrite(str(d / "depth" / f"{k:06d}.png"), scene["depth"][k % 8])
    doc = {**scene["doc"], **({"world_T_camera": scene["pose"]} if pose else {})}
    (d / "camera.json").write_text(json.dumps(doc))
    return d


class _Hand:
    """A depth hand model that answers ``good`` frames and then ``bad()``."""

    def __init__(self, good: int, bad: Any) -> None:
        self.calls, self.good, self.bad = 0, good, bad

    def estimate(self, depth: Any, K: Any, world_T_camera: Any, boxes: Any) -> Any:
        self.calls += 1
        if self.calls > self.good:
            return self.bad()
        return np.full((21, 3), 0.1)


def _raise(err: BaseException) -> Any:
    def go() -> Any:
        raise err

    return go


@pytest.mark.parametrize(
    ("bad", "why"),
    [
        (_raise(TypeError("unsupported operand")), "TypeError: unsupported operand"),
        (lambda: np.zeros((20, 3)), "it returned keypoints of float64 (20, 3)"),
        (lambda: "hand", "it returned keypoints of <U4 ()"),
    ],
)
def test_a_hand_model_failing_keeps_the_frames(
    scene: dict[str, Any], tmp_path: Path, bad: Any, why: str
) -> None:
    from lfd.perception.record import HAND_MODEL, RecordingFailed, record
    from lfd.perception.sources import open_source

    source = open_source(f"frames:{_folder(scene, tmp_path, pose=True)}")
    out = tmp_path / "rec.mcap"
    with pytest.raises(RecordingFailed, match=re.escape(why)) as failed:
        record(source, out, estimator=_Hand(5, bad), hand_rate_hz=None)
    assert failed.value.part == HAND_MODEL and failed.value.frames == 5
    assert str(failed.value).startswith("the hand model failed after 5 frames")
    demo = load(out)
    assert len(demo.hand) == 5 and np.allclose(demo.hand.keypoints, 0.1)


def test_an_observer_failing_keeps_the_frames(scene: dict[str, Any], tmp_path: Path) -> None:
    from lfd.perception.record import OBSERVER, RecordingFailed, record
    from lfd.perception.sources import open_source

    class Observer:
        frames = 0

        def on_frame(self, t_ns: int, color: Any, poses: Any) -> list[Any]:
            self.frames += 1
            if self.frames == 4:
                raise ZeroDivisionError("division by zero")
            return []

        def on_hand(self, *args: Any) -> list[Any]:
            return []

        def on_camera(self, camera: Any) -> list[Any]:
            return []

        def finish(self, t_ns: int) -> list[Any]:
            raise AssertionError("a failed observer is not asked to finish")

    source = open_source(f"frames:{_folder(scene, tmp_path)}")
    out = tmp_path / "rec.mcap"
    with pytest.raises(RecordingFailed, match="ZeroDivisionError") as failed:
        record(source, out, observer=Observer(), hand_rate_hz=None)
    assert failed.value.part == OBSERVER and failed.value.frames == 3
    assert len(load(out).hand) == 3


# --- camera.json ------------------------------------------------------------------------------

_ROT = [[1, 0, 0, 0], [0, -1, 0, 0], [0, 0, -1, 0.8], [0, 0, 0, 1]]


@pytest.mark.parametrize(
    ("change", "field"),
    [
        ({"world_T_camera": np.zeros((4, 4)).tolist()}, "world_T_camera last row"),
        ({"world_T_camera": (1000 * np.eye(4)).tolist()}, "world_T_camera last row"),
        ({"world_T_camera": (np.diag([1000, 1000, 1000, 1.0])).tolist()}, "orthonormal"),
        (
            {"world_T_camera": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, -1, 0], [0, 0, 0, 1]]},
            "determinant",
        ),
        ({"world_T_camera": [[*r[:3], r[3] * 1000] for r in _ROT[:3]] + [_ROT[3]]}, "translation"),
        ({"K": [[1e-300, 0, 320], [0, 1e-300, 240], [0, 0, 1]]}, "focal length fx"),
        ({"K": [[1e300, 0, 320], [0, 1e300, 240], [0, 0, 1]]}, "focal length fx"),
        ({"K": [[600, 0, 1e9], [0, 600, 240], [0, 0, 1]]}, "principal point cx"),
        ({"K": [[600, 0, 320], [0, 600, 240], [0, 0, 0]]}, "last row 0 0 1"),
        ({"K": [[600, 0, 320], [5, 600, 240], [0, 0, 1]]}, "upper triangular"),
        ({"K": [[600, 100, 320], [0, 600, 240], [0, 0, 1]]}, "skew"),
        ({"K": [[600, 0, 320], [0, 600, 240]]}, "finite 3x3"),
        ({"K": [["600", 0, 320], [0, 600, 240], [0, 0, 1]]}, "finite 3x3"),
        ({"fps": "abc"}, "fps must be a number"),
        ({"fps": 0}, "fps must be a number"),
        ({"fps": 1e6}, "fps must be a number"),
        ({"width": 640.5}, "width must be an integer"),
        ({"height": -480}, "height must be an integer"),
        ({"objects": {"box_1": 1}}, "objects must be a list"),
    ],
)
def test_camera_json_values_are_checked(
    scene: dict[str, Any], tmp_path: Path, change: dict[str, Any], field: str
) -> None:
    from lfd.perception.sources import read_camera_json

    path = tmp_path / "camera.json"
    path.write_text(json.dumps({**scene["doc"], **change}))
    with pytest.raises(LfdError, match=field) as err:
        read_camera_json(path)
    assert str(err.value).startswith(f"{path}: ") and "\n" not in str(err.value)


@pytest.mark.parametrize(
    ("change", "field"),
    [
        ({"size": [1e300, 0.05, 0.05]}, r"objects\[0\] \('box_1'\): size and tag_size"),
        ({"tag_size": 1e300}, r"size and tag_size must be a length in \[0.001, 2\] m"),
        ({"tag_size": float("nan")}, "size and tag_size"),
        ({"size": [0.05, 0.05]}, "must be 3 lengths"),
        ({"tag_id": -1}, r"tag_id of 'box_1' must be an integer in \[0, 1023\]"),
        ({"tag_id": 1.5}, "tag_id of 'box_1' must be an integer"),
        ({"tag_id": True}, "tag_id of 'box_1' must be an integer"),
        ({"tag_id": 10**400}, r"tag_id of 'box_1' must be an integer in \[0, 1023\], got 1000"),
        ({"name": "a/b"}, "no '/'"),
        ({"name": "camera"}, "reserved"),
        ({"name": ""}, "non-empty"),
    ],
)
def test_camera_json_objects_are_checked(
    scene: dict[str, Any], tmp_path: Path, change: dict[str, Any], field: str
) -> None:
    from lfd.perception.sources import read_camera_json

    doc = json.loads(json.dumps(scene["doc"]))
    doc["objects"][0].update(change)
    path = tmp_path / "camera.json"
    path.write_text(json.dumps(doc))  # NaN is written as JSON's NaN, which Python reads
    with pytest.raises(LfdError, match=field):
        read_camera_json(path)


def test_a_valid_camera_json_with_a_pose_is_read(scene: dict[str, Any], tmp_path: Path) -> None:
    from lfd.perception.sources import read_camera_json

    path = tmp_path / "camera.json"
    path.write_text(json.dumps({**scene["doc"], "world_T_camera": _ROT, "fps": 15}))
    camera, objects, meta, known = read_camera_json(path)
    assert known and meta["fps"] == 15.0 and np.array_equal(camera.world_T_camera, _ROT)
    assert [o["tag_id"] for o in objects] == [o["tag_id"] for o in scene["doc"]["objects"]]


def test_tag_ids_outside_the_dictionary_are_refused(scene: dict[str, Any], tmp_path: Path) -> None:
    from lfd.perception.record import record
    from lfd.perception.sources import open_source

    doc = json.loads(json.dumps(scene["doc"]))
    doc["objects"][0]["tag_id"] = 60  # DICT_4X4_50 has ids 0-49
    folder = _folder(scene, tmp_path, n=1)
    (folder / "camera.json").write_text(json.dumps(doc))
    with pytest.raises(LfdError, match=r"tag id 60 of 'box_1' is not in DICT_4X4_50 \(ids 0-49\)"):
        record(open_source(f"frames:{folder}"), tmp_path / "x.mcap")
    assert not (tmp_path / "x.mcap").exists()


@pytest.mark.parametrize("rate", ["1e-300", "0.05", "5000", "nan"])
def test_hand_rate_out_of_range_is_refused(
    scene: dict[str, Any], tmp_path: Path, capsys: pytest.CaptureFixture[str], rate: str
) -> None:
    argv = _record_argv(scene, tmp_path / "x.mcap", "--hand-rate", rate)
    with pytest.raises(SystemExit) as done:
        main(argv)
    assert done.value.code == 2
    assert "--hand-rate: must be a" in capsys.readouterr().err


def test_hand_rate_is_checked_by_the_library_too(scene: dict[str, Any], tmp_path: Path) -> None:
    from lfd.perception.record import record
    from lfd.perception.sources import open_source

    source = open_source(f"frames:{_folder(scene, tmp_path, n=1)}")
    with pytest.raises(LfdError, match=r"hand rate must be a number in \[0.1, 1000\] Hz"):
        record(source, tmp_path / "x.mcap", hand_rate_hz=1e-300)


# --- OpenCV's and FFmpeg's own lines ----------------------------------------------------------


def test_a_damaged_video_gives_only_lfd_lines_on_stderr(
    scene: dict[str, Any], tmp_path: Path
) -> None:
    """A video with damaged frames in the middle: FFmpeg's decoder complains on its own
    (``[mjpeg @ 0x...] overread 8``, a dozen lines), lfd records what decodes and says so; only
    lfd's lines reach stderr."""
    video = tmp_path / "damaged.avi"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"MJPG"), 15.0, (640, 480))
    assert writer.isOpened()
    for k in range(24):
        writer.write(np.ascontiguousarray(scene["color"][k % 8][:, :, ::-1]))
    writer.release()
    data = bytearray(video.read_bytes())
    noise = np.random.default_rng(0).integers(0, 256, 400, dtype=np.uint8).tobytes()
    for at in range(len(data) // 3, 2 * len(data) // 3, 5000):  # the middle frames damaged
        data[at : at + 400] = noise
    video.write_bytes(bytes(data))
    out = tmp_path / "rec.mcap"
    argv = [
        "record", "--source", f"video:{video}", "--intrinsics", str(scene["dir"] / "camera.json"),
        "--no-hand", "-o", str(out),
    ]  # fmt: skip
    proc = subprocess.run(
        [sys.executable, "-m", "lfd.cli", *argv], capture_output=True, text=True, timeout=120
    )
    said = " ".join(proc.stderr.split())  # however the console wraps it
    assert proc.returncode == 0, said
    assert said.startswith("done: ") and said.endswith(f"-> {out}"), said
    assert "[" not in said and "WARN" not in said, said
    assert 0 < len(load(out).hand) < 24  # the damaged frames are not in it


@pytest.mark.parametrize("index", ["-1", "2147483648"])
def test_camera_index_in_a_fresh_process(scene: dict[str, Any], tmp_path: Path, index: str) -> None:
    """Not a crash (SIGSEGV) nor a traceback: one line, exit 2."""
    argv = _record_argv(scene, tmp_path / "x.mcap")
    argv[argv.index("camera:0")] = f"camera:{index}"
    proc = subprocess.run(
        [sys.executable, "-m", "lfd.cli", *argv], capture_output=True, text=True, timeout=120
    )
    assert proc.returncode == 2
    assert _error_lines(proc.stderr) == [
        "lfd record: error: camera source: the device index must be an integer in [0, 63], "
        f"got {index!r}"
    ]


def test_two_objects_on_one_tag_are_refused_naming_the_file(
    scene: dict[str, Any], tmp_path: Path
) -> None:
    """One rule for every map of objects to tags (:func:`lfd.demo.shared_tag_problem`, the ROS
    topic mapping's too): refused when camera.json is read, naming it (was: by the tag
    tracker once recording began, without the file)."""
    from lfd.perception.sources import read_camera_json

    doc = json.loads(json.dumps(scene["doc"]))
    assert len(doc["objects"]) >= 2
    doc["objects"][1]["tag_id"] = doc["objects"][0]["tag_id"]
    path = tmp_path / "camera.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(LfdError, match=r"camera\.json.*have the same tag_id"):
        read_camera_json(path)
