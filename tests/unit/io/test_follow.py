"""Following a recording that another thread is still writing (lfd.io.follow)."""

from __future__ import annotations

import itertools
import signal
import subprocess
import sys
import threading
import time
import warnings
from pathlib import Path

import _paths
import numpy as np
import pytest
from _signals import ctrl_c_as_from_a_terminal
from lfd.errors import RecordingFormatError, RecoveredFileWarning
from lfd.io import McapRecorder, follow, load, scan
from lfd.io.follow import STOPPED_GROWING, partial_files

ROOT = _paths.ROOT
EXP1 = ROOT / "recordings" / "exp1.mcap"


def _file_messages(path: Path) -> list[tuple[str, int, bytes]]:
    """Every message of a finished file in file order, as (topic, log_time, payload)."""
    from mcap.reader import make_reader

    with open(path, "rb") as f:
        return [
            (ch.topic, m.log_time, m.data)
            for _, ch, m in make_reader(f).iter_messages(log_time_order=False)
        ]


def _trickle(src: bytes, dest: Path, pieces: int, seconds: float, *, stop_at: int | None = None):
    """Write ``src`` to ``dest`` in ``pieces`` slices of random length over ``seconds``."""
    rng = np.random.default_rng(7)
    cuts = np.sort(rng.choice(np.arange(1, len(src)), size=pieces - 1, replace=False))
    bounds = [0, *cuts.tolist(), len(src) if stop_at is None else stop_at]
    with open(dest, "wb") as f:
        for a, b in itertools.pairwise(bounds):
            if a >= bounds[-1]:
                break
            f.write(src[a : min(b, bounds[-1])])
            f.flush()
            time.sleep(seconds / pieces)


def test_follow_a_file_written_byte_slice_by_byte_slice() -> None:
    """Records cut anywhere (a chunk half written) are waited for: the follower yields exactly
    the messages of the finished file, and the first ones long before the writer is done."""
    src = EXP1.read_bytes()
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        dest = Path(tmp) / "live.mcap"
        dest.touch()
        writer = threading.Thread(target=_trickle, args=(src, dest, 400, 2.0))
        follower = follow(dest, poll_s=0.01, idle_timeout_s=5.0)
        writer.start()
        got, first_at, t0 = [], None, time.monotonic()
        for msg in follower:
            if first_at is None:
                first_at = time.monotonic() - t0
            got.append((msg.topic, msg.t_ns, msg.data))
        writer.join()
        assert follower.stop_reason == "end" and follower.complete
        assert got == _file_messages(dest)
        assert len(got) == scan(EXP1).message_count
        assert first_at is not None and first_at < 1.5  # the writer needs 2 s


def test_follow_a_recorder_while_it_records(tmp_path: Path) -> None:
    """McapRecorder writes exp1 at 4x real time; the follower decodes the same hand and object
    samples as lfd.io.load reads from the finished file, each within about a second."""
    demo = load(EXP1, images=False)
    out = tmp_path / "rec.mcap"
    events = [(int(t), "hand", i) for i, t in enumerate(demo.hand.t_ns)]
    for name, obj in demo.objects.items():
        events += [(int(t), name, i) for i, t in enumerate(obj.t_ns)]
    events.sort(key=lambda e: e[0])
    written: dict[int, float] = {}  # hand sample time -> wall time it was written

    def record() -> None:
        objects = [(o.name, o.tag_id, o.size) for o in demo.objects.values()]
        with McapRecorder(out, objects=objects, max_chunk_duration_s=60.0) as rec:
            t_prev = events[0][0]
            for t, stream, i in events:
                time.sleep(max(0.0, (t - t_prev) * 1e-9 / 4))
                t_prev = t
                if stream == "hand":
                    h = demo.hand
                    rec.add_hand(t, h.keypoints[i], h.confidence[i], h.visible[i])
                    written[t] = time.monotonic()
                else:
                    o = demo.objects[stream]
                    rec.add_object_pose(stream, t, o.position[i], o.quaternion[i])

    thread = threading.Thread(target=record)
    thread.start()
    follower = follow(out, poll_s=0.02, idle_timeout_s=10.0)
    hands, objects, delays = [], 0, []
    for msg in follower:
        if msg.kind == "hand":
            hands.append((msg.t_ns, msg.value))
            delays.append(time.monotonic() - written[msg.t_ns])
        elif msg.kind == "object":
            objects += 1
    thread.join()
    assert follower.stop_reason == "end"
    assert follower.source is not None and follower.source.endswith(".partial")
    assert [o[0] for o in follower.objects] == list(demo.objects)
    final = load(out, images=False)
    np.testing.assert_array_equal([t for t, _ in hands], final.hand.t_ns)
    np.testing.assert_array_equal(np.stack([k for _, k in hands]), final.hand.keypoints)
    assert objects == sum(len(o) for o in final.objects.values())
    # chunks are flushed every wall-clock second although they span 60 s of capture time
    assert max(delays) < 2.0, max(delays)
    assert partial_files(out) == []


def test_follow_stops_when_the_file_stops_growing(tmp_path: Path) -> None:
    src = EXP1.read_bytes()
    dest = tmp_path / "cut.mcap"
    _trickle(src, dest, 10, 0.0, stop_at=len(src) // 2)  # a writer killed halfway
    follower = follow(dest, poll_s=0.01, idle_timeout_s=0.3)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        got = [(m.topic, m.t_ns, m.data) for m in follower]
    assert follower.stop_reason == "idle" and not follower.complete
    assert [str(w.message) for w in caught if w.category is RecoveredFileWarning]
    assert STOPPED_GROWING in str(caught[0].message)
    # exactly the messages of the complete chunks, as the damage-tolerant scan recovers them
    raw = scan(dest)
    assert 0 < len(got) == raw.message_count < scan(EXP1).message_count
    assert got == _file_messages(EXP1)[: len(got)]


_FOLLOW_UNTIL_CTRL_C = """
import sys
from lfd.io import follow
follower = follow(sys.argv[1], poll_s=0.01, idle_timeout_s=60.0)
print("following", flush=True)
n = 0
for _ in follower:
    n += 1
print(follower.stop_reason, n, flush=True)
"""


def test_follow_stops_on_ctrl_c_and_on_stop(tmp_path: Path) -> None:
    """A real Ctrl+C (SIGINT) to a process following a file that never grows ends the follower
    (the idle timeout is a fail-safe, never reached); so does ``stop`` from another thread."""
    dest = tmp_path / "open.mcap"
    src = EXP1.read_bytes()
    dest.write_bytes(src[: len(src) // 3])
    proc = subprocess.Popen(
        [sys.executable, "-c", _FOLLOW_UNTIL_CTRL_C, str(dest)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=ctrl_c_as_from_a_terminal,
    )
    try:
        assert proc.stdout is not None and proc.stdout.readline().strip() == "following"
        time.sleep(1.5)  # it reads the third of exp1 in milliseconds, then waits
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    reason, n = out.split()
    assert proc.returncode == 0 and reason == "interrupted", err
    assert int(n) == scan(dest).message_count > 0

    follower = follow(dest, poll_s=0.01, idle_timeout_s=None)
    threading.Timer(0.3, follower.stop).start()
    assert sum(1 for _ in follower) == int(n) and follower.stop_reason == "stopped"


def _shrink(path: Path) -> None:
    """Truncate ``path`` to 1000 bytes and append 5 KB of random bytes (a file rewritten in
    place while followed)."""
    import os

    with open(path, "r+b") as f:
        f.truncate(1000)
        f.seek(0, os.SEEK_END)
        f.write(os.urandom(5000))


def _rewrite_tail(path: Path, end: int) -> None:
    """Overwrite the 100 bytes before ``end`` with others and append some (same size, then
    longer: a prefix already read changed)."""
    import os

    with open(path, "r+b") as f:
        f.seek(end - 100)
        old = f.read(100)
        f.seek(end - 100)
        f.write(bytes(b ^ 0xFF for b in old))
        f.seek(0, os.SEEK_END)
        f.write(os.urandom(64))


@pytest.mark.parametrize("how", ["shrunk", "rewritten"])
def test_follow_refuses_a_file_truncated_or_rewritten_while_followed(
    how: str, tmp_path: Path
) -> None:
    """A followed file that gets shorter than what was read, or whose bytes already read
    change, is refused (the messages read are no longer the file's); it was followed on, the
    idle warning counting ``126936 of its 6000 bytes``."""
    src = EXP1.read_bytes()
    dest = tmp_path / "g.mcap"
    dest.write_bytes(src[: len(src) * 6 // 10])
    follower = follow(dest, poll_s=0.01, idle_timeout_s=10.0)

    def damage() -> None:
        if how == "shrunk":
            _shrink(dest)
        else:
            _rewrite_tail(dest, follower.bytes_read)

    got = []
    timer = threading.Timer(1.0, damage)
    timer.start()
    try:
        with pytest.raises(RecordingFormatError) as refused:
            for msg in follower:
                got.append(msg)
    finally:
        timer.cancel()
    expected = "truncated or replaced" if how == "shrunk" else "bytes already read"
    assert expected in str(refused.value) and str(dest) in str(refused.value), refused.value
    assert len(got) > 1000  # the messages read before it were yielded


def test_follow_refuses_what_is_not_a_recording(tmp_path: Path) -> None:
    with pytest.raises(RecordingFormatError, match="appeared within"):
        list(follow(tmp_path / "never.mcap", poll_s=0.01, start_timeout_s=0.1))
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(b"not an mcap file at all")
    with pytest.raises(RecordingFormatError, match="not an MCAP file"):
        list(follow(bad, poll_s=0.01, idle_timeout_s=0.2))


def test_follower_gives_the_recordings_metadata(tmp_path: Path) -> None:
    """``Follower.demo_metadata`` is the metadata ``lfd.load`` gives the demonstration (the
    live segmentation of ``lfd segment --follow`` preprocesses with it: a recording without
    depth has its hand filtered like the batch run's)."""
    demo = load(EXP1, images=False)
    out = tmp_path / "rec.mcap"
    objects = [(o.name, o.tag_id, o.size) for o in demo.objects.values()]
    meta = {"depth": False, "hand_lifting": "colour pnp", "source": "video:x.mp4"}
    with McapRecorder(out, objects=objects, metadata=meta) as rec:
        h = demo.hand
        for i in range(3):
            rec.add_hand(int(h.t_ns[i]), h.keypoints[i], h.confidence[i], h.visible[i])
        name, o = next(iter(demo.objects.items()))
        rec.add_object_pose(name, int(o.t_ns[0]), o.position[0], o.quaternion[0])
    follower = follow(out, poll_s=0.02, idle_timeout_s=2.0)
    assert follower.demo_metadata == {}  # nothing read yet
    for _ in follower:
        pass
    got = follower.demo_metadata
    assert got["depth"] is False and got["hand_lifting"] == "colour pnp"
    assert {k: v for k, v in load(out, images=False).metadata.items() if k in meta} == {
        k: got[k] for k in meta
    }


def test_the_followed_camera_is_the_calibration_records_as_load_reads_it() -> None:
    """``FollowedCamera`` (``lfd segment --follow``) poses the camera as ``lfd.load`` does: the
    ``calibration`` record's camera over the messages' while it describes one; one that
    describes none, or a bad transform, is a problem returned once (never printed) and the
    messages pose the camera; a record that is not JSON raises, naming the file and record."""
    import json

    from foxglove_schemas_protobuf.CameraCalibration_pb2 import CameraCalibration
    from foxglove_schemas_protobuf.FrameTransforms_pb2 import FrameTransforms
    from lfd.io.camera_pose import FollowedCamera

    K = [600.0, 0.0, 320.0, 0.0, 600.0, 240.0, 0.0, 0.0, 1.0]
    info = CameraCalibration(frame_id="camera", width=640, height=480, K=K)
    pose = np.eye(4)
    pose[:3, 3] = (0.1, -0.2, 1.0)
    record = {"width": 640, "height": 480, "K": K, "world_T_camera": pose.tolist()}
    meta = {"calibration": {"camera": json.dumps(record)}}
    good_tf, bad_tf = FrameTransforms(), FrameTransforms()
    good_tf.transforms.add(child_frame_id="camera").rotation.w = 1.0
    good_tf.transforms[0].translation.z = 2.0
    bad_tf.transforms.add(child_frame_id="camera")  # a zero rotation
    posed = np.eye(4)
    posed[2, 3] = 2.0  # the camera as good_tf poses it

    cam = FollowedCamera("rec.mcap")
    assert cam.camera is None and cam.add("hand", None) == [] and cam.read_record({}) == []
    assert cam.add("camera_info", info) == [] and cam.camera is not None
    assert np.array_equal(cam.camera.world_T_camera, np.eye(4))  # the message, not yet posed
    assert cam.add("tf", good_tf) == []
    assert np.array_equal(cam.camera.world_T_camera, posed)
    assert cam.read_record(meta) == [] and cam.read_record(meta) == []
    assert np.array_equal(cam.camera.world_T_camera, pose)  # the record's, over the message's
    problems = cam.add("tf", bad_tf)
    assert len(problems) == 1 and "no rotation in a transform" in problems[0], problems
    assert cam.add("tf", bad_tf) == [] and np.array_equal(cam.camera.world_T_camera, pose)

    no_camera = {"calibration": {"camera": json.dumps({**record, "width": -8})}}
    problems = cam.read_record(no_camera)
    assert len(problems) == 1, problems
    assert problems[0].startswith("calibration metadata: image size -8 x 480 px"), problems
    assert np.array_equal(cam.camera.world_T_camera, posed)  # the messages' last good pose
    assert cam.read_record(meta) == [] and np.array_equal(cam.camera.world_T_camera, pose)
    assert cam.read_record(no_camera) == []  # told once
    with pytest.raises(
        RecordingFormatError, match=r"^rec\.mcap: metadata calibration/camera is not valid JSON"
    ):
        cam.read_record({"calibration": {"camera": "{"}})
