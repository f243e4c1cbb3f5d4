"""MCAP recordings: round trip, damaged files, ordering, the ``lfd info`` command."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import textwrap
import warnings
from pathlib import Path

import _paths
import lfd
import numpy as np
import pytest
from _synthetic import T0, make_demo
from hypothesis import given, settings
from hypothesis import strategies as st
from lfd.cli import main
from lfd.demo import KEYPOINT_LAYOUT, KEYPOINT_NAMES, SkillLabel
from lfd.errors import DemonstrationError, RecordingFormatError
from lfd.io import McapRecorder, RecoveredFileWarning, TimestampWarning, load, save, scan
from mcap.reader import make_reader

CUBE = [("cube", 3, (0.05, 0.05, 0.05))]


def _load_quiet(path: Path, **kw):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        demo = load(path, **kw)
    return demo, caught


def test_round_trip_is_exact(tmp_path: Path) -> None:
    demo = make_demo(images=4)
    path = tmp_path / "demo.mcap"
    save(demo, path)
    back, caught = _load_quiet(path)
    assert caught == []
    assert back.hand.side == "right"
    np.testing.assert_array_equal(back.hand.t_ns, demo.hand.t_ns)
    np.testing.assert_array_equal(back.hand.keypoints, demo.hand.keypoints)  # NaN == NaN here
    assert np.isnan(back.hand.keypoints[2, 7]).all()
    np.testing.assert_array_equal(back.hand.confidence, demo.hand.confidence)
    assert list(back.objects) == list(demo.objects)
    for name, obj in demo.objects.items():
        got, vis = back.objects[name], obj.visible
        assert got.tag_id == obj.tag_id
        np.testing.assert_array_equal(got.size, obj.size)
        # visibility = presence: invisible samples are not written
        np.testing.assert_array_equal(got.t_ns, obj.t_ns[vis])
        assert got.visible.all() and len(got) == vis.sum() < len(obj)
        np.testing.assert_array_equal(got.position, obj.position[vis])
        np.testing.assert_allclose(got.quaternion, obj.quaternion[vis], atol=1e-15)
    assert back.labels == demo.labels
    assert back.skill_sequence == ["pick_up", "place", "move"]
    assert back.camera is not None and demo.camera is not None
    assert (back.camera.width, back.camera.height) == (8, 6)
    np.testing.assert_array_equal(back.camera.K, demo.camera.K)
    np.testing.assert_array_equal(back.camera.world_T_camera, demo.camera.world_T_camera)
    assert back.color is not None and demo.color is not None
    assert back.depth is not None and demo.depth is not None
    np.testing.assert_array_equal(back.color.frames, demo.color.frames)
    np.testing.assert_array_equal(back.depth.frames, demo.depth.frames)
    assert back.depth.frames.dtype == np.uint16
    np.testing.assert_array_equal(back.color.t_ns, demo.color.t_ns)
    report = back.metadata.pop("load_report")
    assert back.metadata == demo.metadata
    assert report["complete"] and report["recovered"] is None
    # saving a loaded demo does not nest the load report
    save(back, tmp_path / "again.mcap")
    again, _ = _load_quiet(tmp_path / "again.mcap")
    assert "load_report" not in json.dumps(again.metadata["load_report"])


def test_images_optional_and_top_level_api(tmp_path: Path) -> None:
    path = tmp_path / "d.mcap"
    lfd.save(make_demo(images=2), path)
    demo = lfd.load(path, images=False)
    assert demo.color is None and demo.depth is None and len(demo.hand) == 30


def test_file_uses_foxglove_schemas(tmp_path: Path) -> None:
    path = tmp_path / "d.mcap"
    save(make_demo(images=1), path)
    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    by_topic = {c.topic: (summary.schemas[c.schema_id].name, c) for c in summary.channels.values()}
    assert by_topic["/hand/right/keypoints"][0] == "foxglove.PosesInFrame"
    meta = by_topic["/hand/right/keypoints"][1].metadata
    assert meta["layout"] == KEYPOINT_LAYOUT
    assert tuple(json.loads(meta["keypoints"])) == KEYPOINT_NAMES
    assert by_topic["/objects/cube0/pose"][0] == "foxglove.PoseInFrame"
    assert by_topic["/tf"][0] == "foxglove.FrameTransforms"
    assert by_topic["/camera/color/image_raw"][0] == "foxglove.RawImage"
    assert by_topic["/camera/depth/image_raw"][0] == "foxglove.RawImage"
    assert by_topic["/camera/color/camera_info"][0] == "foxglove.CameraCalibration"
    assert by_topic["/lfd/ground_truth"][0] == "foxglove.Event"
    assert all(c.message_encoding in ("protobuf", "json") for _, c in by_topic.values())
    assert {chunk.compression for chunk in summary.chunk_indexes} == {"zstd"}
    raw = scan(path)
    assert raw.complete
    assert raw.metadata["demo"]["format"] == "lfd-demo"
    obj = json.loads(raw.metadata["demo"]["objects"])[1]
    assert (obj["name"], obj["tag_id"]) == ("cube1", 2)
    np.testing.assert_allclose(obj["size"], [0.05, 0.05, 0.06], rtol=1e-15)
    assert raw.metadata["demo"]["task"] == "stack"
    assert abs(raw.channels["/objects/cube0/pose"].rate_hz - 30) < 1


def test_recorder_incremental_and_input_checks(tmp_path: Path) -> None:
    path = tmp_path / "r.mcap"
    kp = np.zeros((21, 3))
    kp[:, 0] = np.arange(21) * 0.01
    with McapRecorder(path, objects=CUBE, metadata={"task": "t"}) as rec:
        for i in range(5):
            rec.add_hand(T0 + i * 200_000_000, kp + i)
            rec.add_object_pose("cube", T0 + i * 200_000_000, (i, 0, 0), (0, 0, 0, 2.0))
        rec.add_label(SkillLabel("push", T0, T0 + 800_000_000, "cube"))
        with pytest.raises(DemonstrationError, match="unknown object"):
            rec.add_object_pose("sphere", T0, (0, 0, 0), (0, 0, 0, 1))
        with pytest.raises(DemonstrationError, match=r"\(21, 3\)"):
            rec.add_hand(T0, np.zeros((20, 3)))
        with pytest.raises(DemonstrationError, match="integer nanoseconds"):
            rec.add_hand(1.5, kp)  # type: ignore[arg-type]
        with pytest.raises(DemonstrationError, match="invisible"):
            rec.add_object_pose("cube", T0, (np.nan, 0, 0), (0, 0, 0, 1))
        with pytest.raises(DemonstrationError, match="uint8"):
            rec.add_color(T0, np.zeros((4, 4, 3), dtype=np.float32))
        with pytest.raises(DemonstrationError, match="uint16"):
            rec.add_depth(T0, np.zeros((4, 4), dtype=np.float32))
    with pytest.raises(DemonstrationError, match="closed"):
        rec.add_hand(T0, kp)
    with pytest.raises(DemonstrationError, match="'/'"):
        McapRecorder(tmp_path / "x.mcap", objects=[("a/b", 1, (1, 1, 1))])
    demo, caught = _load_quiet(path)
    assert caught == []
    np.testing.assert_array_equal(demo.hand.keypoints[3], kp + 3)
    np.testing.assert_array_equal(demo.hand.confidence, np.ones((5, 21)))  # default: observed
    np.testing.assert_array_equal(demo.objects["cube"].quaternion[0], [0, 0, 0, 1])  # normalised
    assert demo.labels == [SkillLabel("push", T0, T0 + 800_000_000, "cube")]


@pytest.fixture(scope="module")
def long_recording(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, bytes]:
    path = tmp_path_factory.mktemp("rec") / "long.mcap"
    save(make_demo(duration_s=20.0, n_objects=3), path)
    return path, path.read_bytes()


@pytest.mark.parametrize("fraction", [0.15, 0.4, 0.63, 0.9])
def test_truncated_file_keeps_complete_chunks(
    long_recording: tuple[Path, bytes], tmp_path: Path, fraction: float
) -> None:
    path, data = long_recording
    full, _ = _load_quiet(path)
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: int(len(data) * fraction)])
    with pytest.warns(RecoveredFileWarning, match=r"recovered \d+ messages covering [\d.]+ s"):
        demo = load(cut)
    report = demo.metadata["load_report"]
    assert not report["complete"] and "recovered" in report["recovered"]
    assert 0 < report["messages"] < scan(path).message_count
    n = len(demo.hand)
    assert 0 < n < len(full.hand)
    # what is kept is exactly the beginning of the recording
    np.testing.assert_array_equal(demo.hand.t_ns, full.hand.t_ns[:n])
    np.testing.assert_array_equal(demo.hand.keypoints, full.hand.keypoints[:n])
    for name, obj in demo.objects.items():
        np.testing.assert_array_equal(obj.position, full.objects[name].position[: len(obj)])
    # roughly proportional: chunks close every second of capture time
    assert demo.duration_s > fraction * full.duration_s - 2.5


def test_truncation_sweep_never_crashes(long_recording: tuple[Path, bytes], tmp_path: Path) -> None:
    _, data = long_recording
    cut = tmp_path / "cut.mcap"
    outcomes = set()
    for offset in np.linspace(0, len(data), 40).astype(int):
        cut.write_bytes(data[:offset])
        try:
            demo, caught = _load_quiet(cut)
        except RecordingFormatError:
            outcomes.add("error")
            continue
        kinds = {type(w.message) for w in caught}
        outcomes.add("recovered" if RecoveredFileWarning in kinds else "complete")
        assert len(demo.hand) > 0
    assert outcomes == {"error", "recovered", "complete"}  # cut in the summary loses nothing


_KILLED_WRITER = textwrap.dedent(
    """
    import sys, time
    import numpy as np
    from lfd.io import McapRecorder
    rec = McapRecorder(sys.argv[1], objects=[("cube", 3, (0.05, 0.05, 0.05))])
    t0 = 1_700_000_000_000_000_000
    for i in range(300):  # 10 s at 30 Hz, hand at 5 Hz
        t = t0 + i * 33_333_333
        if i % 6 == 0:
            rec.add_hand(t, np.full((21, 3), i * 0.001))
        rec.add_object_pose("cube", t, (i * 0.001, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
    print("written", flush=True)
    time.sleep(60)
    """
)


def test_writer_killed_mid_recording(tmp_path: Path) -> None:
    path = tmp_path / "killed.mcap"
    proc = subprocess.Popen(
        [sys.executable, "-c", _KILLED_WRITER, str(path)], stdout=subprocess.PIPE, text=True
    )
    try:
        assert proc.stdout is not None
        assert proc.stdout.readline().strip() == "written"
    finally:
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=10)
        if proc.stdout is not None:
            proc.stdout.close()
    # the unfinished recording is left beside the destination as .NAME.XXXXXXXX.partial
    assert not path.exists()
    (partial,) = tmp_path.glob(".killed.mcap.*.partial")
    with pytest.warns(RecoveredFileWarning, match="not closed"):
        demo = load(partial)
    # chunks are closed every second of capture time: at most ~1 s of the 10 s is lost
    assert len(demo.hand) >= 44
    assert len(demo.objects["cube"]) >= 265
    assert demo.metadata["load_report"]["complete"] is False


def test_unclosed_recorder_is_readable(tmp_path: Path) -> None:
    path = tmp_path / "open.mcap"
    rec = McapRecorder(path, objects=CUBE, max_chunk_duration_s=0.5)
    for i in range(30):
        t = T0 + i * 100_000_000
        rec.add_hand(t, np.full((21, 3), 0.01 * i))
        rec.add_object_pose("cube", t, (0, 0, 0), (0, 0, 0, 1))
    assert not path.exists()  # written beside it until closed
    with pytest.warns(RecoveredFileWarning):
        demo = load(rec.partial_path)
    assert 20 <= len(demo.hand) < 30
    rec.close()
    demo, caught = _load_quiet(path)
    assert caught == [] and len(demo.hand) == 30
    assert not Path(rec.partial_path).exists()


def test_failed_save_leaves_no_file(tmp_path: Path) -> None:
    path = tmp_path / "x.mcap"
    path.write_bytes(b"old")
    with McapRecorder(path, objects=CUBE) as rec:
        rec.add_hand(T0, np.zeros((21, 3)))
    good = path.read_bytes()
    with pytest.raises(RecordingFormatError, match="boom"):
        with McapRecorder(path, objects=CUBE) as rec:
            rec.add_hand(T0, np.zeros((21, 3)))
            raise RecordingFormatError("boom")
    assert path.read_bytes() == good  # the previous file is untouched
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.mcap"]  # no temporary file left


@pytest.mark.parametrize(
    ("content", "match"),
    [(b"", "empty"), (b"hello, world" * 10, "not an MCAP"), (b"\x89MCA", "cut inside")],
)
def test_not_mcap(tmp_path: Path, content: bytes, match: str) -> None:
    path = tmp_path / "bad.mcap"
    path.write_bytes(content)
    with pytest.raises(RecordingFormatError, match=match):
        load(path)
    assert main(["info", str(path)]) == 2


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(RecordingFormatError, match="cannot open"):
        load(tmp_path / "nope.mcap")


def test_missing_channels_listed(tmp_path: Path) -> None:
    path = tmp_path / "objects_only.mcap"
    with McapRecorder(path, objects=CUBE) as rec:
        rec.add_object_pose("cube", T0, (0, 0, 0), (0, 0, 0, 1))
    with pytest.raises(RecordingFormatError) as err:
        load(path)
    text = str(err.value)
    assert "missing hand keypoints" in text and "/objects/cube/pose" in text
    assert "object pose" not in text.split("it has")[0].split("missing")[1]
    path = tmp_path / "hand_only.mcap"
    with McapRecorder(path, objects=CUBE) as rec:
        rec.add_hand(T0, np.zeros((21, 3)))
    with pytest.raises(
        RecordingFormatError, match=r"missing at least one object pose.*/hand/right"
    ):
        load(path)


def test_unsorted_and_duplicate_timestamps(tmp_path: Path) -> None:
    path = tmp_path / "order.mcap"
    order = [0, 2, 1, 3, 3, 4, 2]  # two inversions, two duplicates (3 and 2)
    with McapRecorder(path, objects=CUBE) as rec:
        for k, i in enumerate(order):
            t = T0 + i * 200_000_000
            rec.add_hand(t, np.full((21, 3), float(i) + 0.1 * (k == 4)))
        for i in (1, 0, 2):
            rec.add_object_pose("cube", T0 + i * 33_000_000, (i, 0, 0), (0, 0, 0, 1))
    with pytest.warns(TimestampWarning, match="duplicate"):
        demo = load(path)
    np.testing.assert_array_equal(demo.hand.t_ns, T0 + np.arange(5) * 200_000_000)
    np.testing.assert_array_equal(demo.hand.keypoints[:, 0, 0], [0, 1, 2, 3, 4])  # first kept
    np.testing.assert_array_equal(demo.objects["cube"].position[:, 0], [0, 1, 2])
    report = demo.metadata["load_report"]
    assert report["unsorted"] == {"/hand/right/keypoints": 2, "/objects/cube/pose": 1}
    assert report["duplicates"] == {"/hand/right/keypoints": 2}


def test_info_command(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "d.mcap"
    save(make_demo(), path)
    assert main(["info", str(path), "--json", "-"]) == 0
    s = json.loads(capsys.readouterr().out)  # stdout is pure JSON, the tables went to stderr
    assert s["complete"] and s["error"] is None and s["warnings"] == []
    hand = next(c for c in s["channels"] if c["topic"] == "/hand/right/keypoints")
    assert hand["count"] == 30 and abs(hand["rate_hz"] - 5.0) < 1e-6
    assert [o["name"] for o in s["objects"]] == ["cube0", "cube1"]
    assert [lab["skill"] for lab in s["labels"]] == ["pick_up", "place", "move"]
    assert s["metadata"]["task"] == "stack"
    assert main(["info", str(path)]) == 0
    out = capsys.readouterr().out
    assert "pick_up -> place -> move" in out and "cube1" in out
    out_json = tmp_path / "info.json"
    assert main(["info", str(path), "--json", str(out_json)]) == 0
    assert json.loads(out_json.read_text()) == s
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(path.read_bytes()[:30000])
    assert main(["info", str(cut)]) == 0
    err = capsys.readouterr().err  # warnings: one line each on stderr
    assert err.startswith("lfd info: warning: ") and "truncated" in err


def test_rerun_opens_recording(tmp_path: Path) -> None:
    pytest.importorskip("rerun", reason="rerun-sdk not installed (optional viz extra)")
    exe = Path(sys.executable).with_name("rerun")
    if not exe.exists():
        pytest.skip("rerun CLI not found next to the interpreter")
    path = tmp_path / "d.mcap"
    save(make_demo(images=2), path)
    rrd = tmp_path / "d.rrd"
    env = {**os.environ, "RERUN_TELEMETRY": "0"}

    def rerun(*args: str) -> str:
        out = subprocess.run(
            [str(exe), *args], capture_output=True, text=True, env=env, timeout=120
        )
        assert out.returncode == 0, out.stderr
        return out.stdout

    checked = rerun("mcap", "check", "--full", str(path))
    assert "/hand/right/keypoints" in checked and "error" not in checked.lower()
    rerun("mcap", "convert", str(path), "-o", str(rrd))
    printed = rerun("rrd", "print", str(rrd))
    lines = printed.splitlines()

    def mapped(topic: str, archetype: str) -> bool:
        return any(f"- {topic} -" in line and archetype in line for line in lines)

    assert mapped("/hand/right/keypoints", "InstancePoses3D:translations")
    assert mapped("/objects/cube0/pose", "InstancePoses3D:quaternions")
    assert mapped("/tf", "Transform3D:translation")
    assert mapped("/camera/color/image_raw", "Image:buffer")
    assert mapped("/camera/depth/image_raw", "Image:buffer")
    assert mapped("/camera/color/camera_info", "Pinhole:image_from_camera")


def _have_image_codec() -> bool:
    import importlib.util

    return any(importlib.util.find_spec(m) is not None for m in ("cv2", "PIL"))


@pytest.mark.skipif(not _have_image_codec(), reason="needs opencv or pillow")
@pytest.mark.parametrize("fmt", ["png", "jpeg"])
def test_compressed_color_images(tmp_path: Path, fmt: str) -> None:
    demo = make_demo(images=3)
    assert demo.color is not None
    yy, xx = np.mgrid[0:6, 0:8]
    smooth = np.stack([xx * 20, yy * 30, xx + yy + 100], axis=-1).astype(np.uint8)
    demo.color.frames[:] = smooth
    path = tmp_path / f"{fmt}.mcap"
    save(demo, path, color_format=fmt)
    raw = scan(path)
    assert raw.channels["/camera/color/image_raw/compressed"].schema == "foxglove.CompressedImage"
    assert "/camera/color/image_raw" not in raw.channels
    back, _ = _load_quiet(path)
    assert back.color is not None and back.color.frames.shape == demo.color.frames.shape
    if fmt == "png":
        np.testing.assert_array_equal(back.color.frames, demo.color.frames)
    else:
        assert np.abs(back.color.frames.astype(int) - demo.color.frames).mean() < 12
    with pytest.raises(DemonstrationError, match="color_format"):
        McapRecorder(tmp_path / "x.mcap", color_format="gif")


def test_generic_mcap_tools_decode_every_message(tmp_path: Path) -> None:
    """A reader that knows nothing about lfd decodes the file from its embedded schemas."""
    from mcap_protobuf.decoder import DecoderFactory

    path = tmp_path / "d.mcap"
    demo = make_demo(images=1)
    save(demo, path)
    counts: dict[str, int] = {}
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _, channel, message in reader.iter_messages():
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
            if channel.message_encoding == "json":
                assert len(json.loads(message.data)["confidence"]) == 21
        for _, _, _, decoded in reader.iter_decoded_messages(topics=["/hand/right/keypoints"]):
            assert len(decoded.poses) == 21
            assert decoded.poses[0].orientation.w == 1.0
    assert counts["/hand/right/keypoints"] == counts["/hand/right/confidence"] == len(demo.hand)


@settings(max_examples=25, deadline=None)
@given(
    steps=st.lists(st.integers(1, 10**9), min_size=1, max_size=12),
    nan_mask=st.lists(st.booleans(), min_size=21 * 12, max_size=21 * 12),
    seed=st.integers(0, 2**16),
)
def test_round_trip_property(steps: list[int], nan_mask: list[bool], seed: int) -> None:
    """Any timestamps and unobserved keypoints come back bit for bit."""
    import tempfile

    rng = np.random.default_rng(seed)
    t = T0 + np.cumsum(steps, dtype=np.int64)
    n = t.size
    kp = rng.normal(scale=10.0, size=(n, 21, 3))
    kp[np.array(nan_mask[: n * 21]).reshape(n, 21)] = np.nan
    conf = rng.uniform(size=(n, 21))
    pos = rng.normal(size=(n, 3))
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "p.mcap"
        with McapRecorder(path, objects=CUBE, max_chunk_duration_s=rng.uniform(0, 1e-8)) as rec:
            for i in range(n):
                rec.add_hand(int(t[i]), kp[i], conf[i])
                rec.add_object_pose("cube", int(t[i]), pos[i], (0, 0, 0, 1))
        demo, caught = _load_quiet(path)
    assert caught == []
    np.testing.assert_array_equal(demo.hand.t_ns, t)
    np.testing.assert_array_equal(demo.hand.keypoints, kp)
    np.testing.assert_array_equal(demo.hand.confidence, conf)
    np.testing.assert_array_equal(demo.objects["cube"].position, pos)


def test_foreign_file_extra_topics_and_missing_sizes(tmp_path: Path) -> None:
    """A file from another tool: unknown topics are ignored, a box without size gets the
    default cube with a warning (tests/unit/io/test_object_sizes.py gives sizes)."""
    from foxglove_schemas_protobuf.Log_pb2 import Log
    from lfd.io import messages
    from mcap_protobuf.writer import Writer

    path = tmp_path / "foreign.mcap"
    with open(path, "wb") as f, Writer(f) as w:
        for i in range(3):
            t = T0 + i * 200_000_000
            w.write_message(
                "/hand/right/keypoints", messages.hand_poses(t, np.zeros((21, 3))), t, t
            )
            w.write_message(
                "/objects/box/pose", messages.object_pose(t, np.zeros(3), np.eye(4)[3]), t, t
            )
            w.write_message("/rosout", Log(message="hello"), t, t)
    from lfd.errors import DefaultSizeWarning

    with pytest.warns(DefaultSizeWarning, match="object box has no size; using 0.05 m cube"):
        demo = load(path)
    np.testing.assert_array_equal(demo.objects["box"].size, [0.05, 0.05, 0.05])


# --- malformed values and decompression bombs -----------------------------------------------
def _small_recording(path: Path, *, confidence: bool = True) -> Path:
    with McapRecorder(path, objects=CUBE) as rec:
        for i in range(3):
            t = T0 + i * 200_000_000
            rec.add_hand(t, np.zeros((21, 3)), np.ones(21) if confidence else None)
            rec.add_object_pose("cube", t, (i, 0, 0), (0, 0, 0, 1))
    return path


def _rewrite(src: Path, dst: Path, *, metadata=None, channel=None, message=None) -> Path:
    """Copy an MCAP record by record through the ``mcap`` writer, letting hooks change the
    metadata records ``(name, dict) -> dict``, the channel metadata ``(topic, dict) -> dict``
    and the messages ``(topic, log_time, data) -> (log_time, data)``."""
    from mcap.writer import Writer

    with open(src, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None
        records = list(reader.iter_metadata())
        msgs = list(reader.iter_messages(log_time_order=False))
    with open(dst, "wb") as out:
        w = Writer(out)
        w.start()
        schema_ids = {
            sid: w.register_schema(s.name, s.encoding, s.data) for sid, s in summary.schemas.items()
        }
        channel_ids = {}
        for cid, ch in summary.channels.items():
            meta = dict(ch.metadata)
            if channel is not None:
                meta = channel(ch.topic, meta)
            channel_ids[cid] = w.register_channel(
                ch.topic, ch.message_encoding, schema_ids.get(ch.schema_id, 0), meta
            )
        for _, ch, m in msgs:
            t, data = m.log_time, m.data
            if message is not None:
                t, data = message(ch.topic, t, data)
            w.add_message(channel_ids[ch.id], t, data, min(t, 2**64 - 1))
        for rec in records:
            meta = dict(rec.metadata)
            if metadata is not None:
                meta = metadata(rec.name, meta)
            w.add_metadata(rec.name, meta)
        w.finish()
    return dst


def _demo_objects(edit):
    """A metadata hook replacing the 'demo' record's objects list by ``edit(objects)``."""

    def hook(name: str, meta: dict) -> dict:
        if name == "demo":
            meta["objects"] = json.dumps(edit(json.loads(meta["objects"])))
        return meta

    return hook


def _set_first(key: str, value):
    def edit(objects: list) -> list:
        objects[0][key] = value
        return objects

    return edit


def _no_objects_metadata(name: str, meta: dict) -> dict:
    if name == "demo":
        meta["objects"] = "[]"
    return meta


def _channel_meta(key: str, value: str):
    def hook(topic: str, meta: dict) -> dict:
        if topic == "/objects/cube/pose":
            meta[key] = value
        return meta

    return hook


def _confidence(payload: bytes):
    def hook(topic: str, t: int, data: bytes) -> tuple[int, bytes]:
        return t, (payload if topic == "/hand/right/confidence" else data)

    return hook


def _late_hand(topic: str, t: int, data: bytes) -> tuple[int, bytes]:
    return (2**63 if topic == "/hand/right/keypoints" else t), data


MALFORMED = [
    ("string tag_id", {"metadata": _demo_objects(_set_first("tag_id", "three"))}, "tag_id"),
    ("float tag_id", {"metadata": _demo_objects(_set_first("tag_id", 3.5))}, "tag_id"),
    ("string size", {"metadata": _demo_objects(_set_first("size", "big"))}, "size must be"),
    ("short size", {"metadata": _demo_objects(_set_first("size", [0.05, 0.05]))}, "size must"),
    ("nested size", {"metadata": _demo_objects(_set_first("size", [[1], 2, 3]))}, "size must"),
    ("negative size", {"metadata": _demo_objects(_set_first("size", [0.05, -1, 0.05]))}, "size"),
    ("bool size", {"metadata": _demo_objects(_set_first("size", [True, 1, 1]))}, "size must"),
    ("name not a string", {"metadata": _demo_objects(_set_first("name", 7))}, "'name'"),
    ("objects not a list", {"metadata": _demo_objects(lambda o: {"cube": o})}, "JSON list"),
    (
        "channel size not JSON",
        {"metadata": _no_objects_metadata, "channel": _channel_meta("size", "[0.05, 0.05")},
        "/objects/cube/pose metadata: size is not JSON",
    ),
    (
        "channel size not numbers",
        {"metadata": _no_objects_metadata, "channel": _channel_meta("size", '["a", 1, 1]')},
        "/objects/cube/pose metadata: size must be",
    ),
    (
        "channel tag_id not an integer",
        {"metadata": _no_objects_metadata, "channel": _channel_meta("tag_id", "x1")},
        "/objects/cube/pose metadata: tag_id",
    ),
    (
        "string confidences",
        {"message": _confidence(json.dumps({"confidence": ["0.5"] * 21}).encode())},
        "/hand/right/confidence at",
    ),
    (
        "confidence out of range",
        {"message": _confidence(json.dumps({"confidence": [2.0] * 21}).encode())},
        "in [0, 1]",
    ),
    ("confidence not JSON", {"message": _confidence(b"\xff\x00")}, "/hand/right/confidence"),
    (
        "confidence not an object",
        {"message": _confidence(b"[1, 2]")},
        '{"confidence": [21 numbers]}',
    ),
    (
        "visible not booleans",
        {
            "message": _confidence(
                json.dumps({"confidence": [1] * 21, "visible": [1] * 21}).encode()
            )
        },
        "/hand/right/confidence at",
    ),
    (
        "visible too short",
        {"message": _confidence(json.dumps({"confidence": [1] * 21, "visible": [True]}).encode())},
        "visible must be 21 booleans",
    ),
    (
        "visible not a list",
        {"message": _confidence(json.dumps({"confidence": [1] * 21, "visible": "yes"}).encode())},
        "visible must be 21 booleans",
    ),
    ("log_time >= 2**63", {"message": _late_hand}, "log_time 9223372036854775808"),
]


@pytest.mark.parametrize(
    ("edits", "match"), [c[1:] for c in MALFORMED], ids=[c[0] for c in MALFORMED]
)
def test_malformed_values_are_format_errors(tmp_path: Path, edits: dict, match: str) -> None:
    src = _small_recording(tmp_path / "ok.mcap")
    _load_quiet(src)  # the unmodified copy loads
    bad = _rewrite(src, tmp_path / "bad.mcap", **edits)
    with pytest.raises(RecordingFormatError) as err:
        _load_quiet(bad)
    text = str(err.value)
    assert match in text and "\n" not in text, text


def test_malformed_value_through_the_cli(tmp_path: Path) -> None:
    src = _small_recording(tmp_path / "ok.mcap")
    bad = _rewrite(src, tmp_path / "bad.mcap", metadata=_demo_objects(_set_first("tag_id", "3")))
    proc = subprocess.run(
        [sys.executable, "-m", "lfd.cli", "segment", str(bad)], capture_output=True, text=True
    )
    assert proc.returncode == 2 and "Traceback" not in proc.stderr, proc.stderr
    assert "tag_id must be an integer" in proc.stderr


def test_rewrite_helper_keeps_a_good_recording(tmp_path: Path) -> None:
    src = _small_recording(tmp_path / "ok.mcap")
    demo, caught = _load_quiet(_rewrite(src, tmp_path / "copy.mcap"))
    assert caught == []
    assert demo.objects["cube"].tag_id == 3 and len(demo.hand) == 3
    # sizes and tag ids may also come from the channel metadata alone
    demo, _ = _load_quiet(_rewrite(src, tmp_path / "chan.mcap", metadata=_no_objects_metadata))
    np.testing.assert_array_equal(demo.objects["cube"].size, [0.05, 0.05, 0.05])
    assert demo.objects["cube"].tag_id == 3


def _zstd_bomb(path: Path, *, inflated: int, declared: int | None = None) -> Path:
    """An MCAP file with one zstd chunk of zeros that inflates to ``inflated`` bytes; its
    header declares ``declared`` (default: the truth)."""
    import zstandard
    from mcap.data_stream import RecordBuilder
    from mcap.records import Chunk, DataEnd, Footer, Header

    block = 16 * 2**20
    frame = zstandard.ZstdCompressor(level=19).compress(bytes(block))
    b = RecordBuilder()
    Header(profile="", library="bomb").write(b)
    Chunk(
        compression="zstd",
        data=frame * (inflated // block),
        message_start_time=0,
        message_end_time=0,
        uncompressed_size=inflated if declared is None else declared,
        uncompressed_crc=0,
    ).write(b)
    DataEnd(0).write(b)
    Footer(0, 0, 0).write(b)
    magic = b"\x89MCAP0\r\n"
    path.write_bytes(magic + b.end() + magic)
    return path


_PEAK_MEMORY = textwrap.dedent(
    """
    import sys, time
    from lfd.errors import RecordingFormatError
    from lfd.io import scan
    t = time.perf_counter()
    try:
        raw = scan(sys.argv[1])
        outcome = f"read: {raw.error}"
    except RecordingFormatError as err:
        outcome = f"refused: {err}"
    # peak RSS of this process image (ru_maxrss would include the forking parent's)
    status = open("/proc/self/status").read().split("VmHWM:")[1]
    rss_mb = int(status.split()[0]) / 1024
    print(f"{time.perf_counter() - t:.3f} {rss_mb:.0f} {outcome}")
    """
)


@pytest.mark.parametrize("declared", [None, 1000], ids=["honest header", "lying header"])
def test_decompression_bomb_is_refused_quickly(tmp_path: Path, declared: int | None) -> None:
    """67 KB of zstd zeros that inflate to 2 GiB: refused from the chunk header (honest) or
    stopped at the declared size (lying), in well under a second and under 300 MB."""
    path = _zstd_bomb(tmp_path / "bomb.mcap", inflated=2**31, declared=declared)
    assert path.stat().st_size < 100_000
    proc = subprocess.run(
        [sys.executable, "-c", _PEAK_MEMORY, str(path)], capture_output=True, text=True
    )
    assert proc.returncode == 0, proc.stderr
    seconds, rss_mb, outcome = proc.stdout.split(" ", 2)
    assert float(seconds) < 1.0 and float(rss_mb) < 300, proc.stdout
    if declared is None:
        assert outcome.startswith("refused") and "decompression bomb" in outcome, outcome
    else:
        assert "inflates to more than 1000 bytes" in outcome, outcome
    # the CLI: one line, exit 2
    proc = subprocess.run(
        [sys.executable, "-m", "lfd.cli", "info", str(path)], capture_output=True, text=True
    )
    assert proc.returncode == 2 and "Traceback" not in proc.stderr, proc.stderr


def test_inflation_limit_leaves_real_recordings_alone() -> None:
    from lfd.io.mcapfile import MAX_INFLATION, inflate_limit

    rendered = _paths.RECORDINGS / "rendered" / "exp1_short.mcap"
    with open(rendered, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
    assert summary is not None
    inflated = sum(c.uncompressed_size for c in summary.chunk_indexes)
    size = rendered.stat().st_size
    # the most compressible shipped recording (raw depth frames) is far inside the limit
    assert inflated < inflate_limit(size) / 10 and inflated / size < MAX_INFLATION / 10
    assert scan(rendered).complete


# --- keypoint visibility ----------------------------------------------------------------------
def test_visibility_round_trip(tmp_path: Path) -> None:
    """``visible`` goes through McapRecorder and save/load; the default is "observed with
    confidence > 0"."""
    rng = np.random.default_rng(3)
    kp = rng.normal(size=(4, 21, 3))
    kp[1, 7] = np.nan
    conf = rng.uniform(0.1, 1.0, size=(4, 21))
    conf[2, 3] = 0.0
    vis = rng.random((4, 21)) < 0.5
    path = tmp_path / "v.mcap"
    with McapRecorder(path, objects=CUBE) as rec:
        for i in range(4):
            t = T0 + i * 200_000_000
            rec.add_hand(t, kp[i], conf[i], vis[i] if i < 2 else None)
            rec.add_object_pose("cube", t, (i, 0, 0), (0, 0, 0, 1))
        with pytest.raises(DemonstrationError, match=r"v\.mcap: /hand/right/confidence .*visible"):
            rec.add_hand(T0, kp[0], conf[0], np.ones(21))  # not booleans
        with pytest.raises(DemonstrationError, match="visible must be 21 booleans"):
            rec.add_hand(T0, kp[0], conf[0], np.ones(20, dtype=bool))
    demo, caught = _load_quiet(path)
    assert caught == []
    assert demo.hand.visible.dtype == np.bool_ and demo.hand.visible.shape == (4, 21)
    np.testing.assert_array_equal(demo.hand.visible[:2], vis[:2])
    default = np.isfinite(kp[2:]).all(axis=2) & (conf[2:] > 0)
    assert not default[0, 3]
    np.testing.assert_array_equal(demo.hand.visible[2:], default)
    np.testing.assert_array_equal(demo.hand.confidence, conf)
    # the whole-demo writer keeps it
    save(demo, tmp_path / "again.mcap")
    again, _ = _load_quiet(tmp_path / "again.mcap")
    np.testing.assert_array_equal(again.hand.visible, demo.hand.visible)


def test_files_without_visibility_load_with_the_default(tmp_path: Path) -> None:
    """Recordings written before ``visible`` existed (only ``confidence``) still load."""
    src = _small_recording(tmp_path / "ok.mcap")
    conf = [0.0] * 3 + [0.5] * 18

    def old_format(topic: str, t: int, data: bytes) -> tuple[int, bytes]:
        if topic == "/hand/right/confidence":
            assert "visible" in json.loads(data)  # new files have it
            return t, json.dumps({"confidence": conf}).encode()
        return t, data

    demo, caught = _load_quiet(_rewrite(src, tmp_path / "old.mcap", message=old_format))
    assert caught == []
    np.testing.assert_array_equal(demo.hand.confidence, np.tile(conf, (3, 1)))
    np.testing.assert_array_equal(demo.hand.visible, np.tile(np.array(conf) > 0, (3, 1)))


def test_shipped_recordings_load_with_visibility() -> None:
    root = _paths.RECORDINGS
    demo = load(root / "exp1.mcap", images=False)
    h = demo.hand
    np.testing.assert_array_equal(
        h.visible, np.isfinite(h.keypoints).all(axis=2) & (h.confidence > 0)
    )


def test_hand_track_checks_visibility() -> None:
    from lfd.demo import HandTrack

    t = np.array([0, 1], dtype=np.int64)
    kp = np.zeros((2, 21, 3))
    with pytest.raises(DemonstrationError, match=r"visible must be booleans of shape \(2, 21\)"):
        HandTrack(t, kp, np.ones((2, 21)), visible=np.ones((2, 21)))
    with pytest.raises(DemonstrationError, match="visible"):
        HandTrack(t, kp, np.ones((2, 21)), visible=np.ones((2, 20), dtype=bool))
    assert (
        HandTrack(t, kp, np.ones((2, 21)), "right", np.zeros((2, 21), dtype=bool)).visible.sum()
        == 0
    )


def test_live_segments_are_kept_apart_from_ground_truth(tmp_path: Path) -> None:
    demo = make_demo()
    truth = list(demo.labels)
    assert truth
    path = tmp_path / "live.mcap"
    objects = [(o.name, o.tag_id, o.size) for o in demo.objects.values()]
    first = SkillLabel("pick_up", T0 + 1_000_000_000, T0 + 2_000_000_000, objects[0][0])
    second = SkillLabel("place", T0 + 2_000_000_000, T0 + 2_500_000_000, None)
    with McapRecorder(path, objects=objects) as rec:
        for i, t in enumerate(demo.hand.t_ns):
            rec.add_hand(int(t), demo.hand.keypoints[i], demo.hand.confidence[i])
        for obj in demo.objects.values():
            for i, t in enumerate(obj.t_ns):
                if obj.visible[i]:
                    rec.add_object_pose(obj.name, int(t), obj.position[i], obj.quaternion[i])
        for label in truth:
            rec.add_label(label)
        rec.add_live_segment(first, T0 + 3_000_000_000, {"score": "-12.5", "confidence": "0.9"})
        rec.add_live_segment(second, T0 + 3_500_000_000)
    back = load(path)
    assert back.labels == truth  # the ground truth is untouched
    assert back.live_segments == [first, second]
    with path.open("rb") as f:
        reader = make_reader(f)
        events = [
            (m.log_time, c.topic) for _, c, m in reader.iter_messages(topics=["/lfd/live/segments"])
        ]
    assert events == [
        (T0 + 3_000_000_000, "/lfd/live/segments"),
        (T0 + 3_500_000_000, "/lfd/live/segments"),
    ]
    again = tmp_path / "again.mcap"
    save(back, again)
    assert load(again).live_segments == [first, second]


def test_object_names_that_look_like_topics_are_objects_or_refused(tmp_path: Path) -> None:
    """An object named ``hand`` is an object (its own ``/objects/hand/pose``), not hand
    samples; a name that would collide with a topic part or a ``/tf`` frame is refused, naming
    it. Never mixed."""
    import dataclasses

    demo = make_demo()
    first = next(iter(demo.objects))
    renamed = {}
    for name, obj in demo.objects.items():
        new = "hand" if name == first else name
        renamed[new] = dataclasses.replace(obj, name=new)
    demo.objects = renamed
    path = tmp_path / "hand.mcap"
    save(demo, path)
    back, caught = _load_quiet(path)
    assert caught == []
    assert list(back.objects) == list(demo.objects)
    np.testing.assert_array_equal(back.hand.t_ns, demo.hand.t_ns)  # no object pose among them
    np.testing.assert_array_equal(back.hand.keypoints, demo.hand.keypoints)
    hand_box = demo.objects["hand"]
    np.testing.assert_array_equal(back.objects["hand"].t_ns, hand_box.t_ns[hand_box.visible])
    np.testing.assert_array_equal(
        back.objects["hand"].position, hand_box.position[hand_box.visible]
    )
    for bad, why in [
        ("camera", "reserved for the /tf frame"),
        ("world", "reserved for the /tf frame"),
        ("box/1", "no '/'"),
        ("", "non-empty"),
        (" box", "surrounding spaces"),
        ("box\n1", "control characters"),
        ("x" * 201, "at most 200 characters"),
    ]:
        demo.objects = {bad: dataclasses.replace(hand_box, name=bad)}
        out = tmp_path / "bad.mcap"
        with pytest.raises(DemonstrationError, match=f"object name {re.escape(repr(bad))} .*{why}"):
            save(demo, out)
        assert not out.exists() and list(tmp_path.glob(".bad.mcap*")) == []


def _camera_pose(edit):
    """A message hook that rewrites the camera's transforms (``foxglove.FrameTransforms``) or
    calibration (``foxglove.CameraCalibration``) with ``edit(message)``."""
    from foxglove_schemas_protobuf.CameraCalibration_pb2 import CameraCalibration
    from foxglove_schemas_protobuf.FrameTransforms_pb2 import FrameTransforms

    def hook(topic: str, t: int, data: bytes) -> tuple[int, bytes]:
        cls = {"/tf": FrameTransforms, "/camera/color/camera_info": CameraCalibration}.get(topic)
        if cls is None:
            return t, data
        msg = cls()
        msg.ParseFromString(data)
        edit(msg)
        return t, msg.SerializeToString()

    return hook


def _camera_metadata(edit):
    """A metadata hook rewriting the calibration record's camera with ``edit(camera dict)``."""

    def hook(name: str, meta: dict) -> dict:
        if name == "calibration":
            camera = json.loads(meta["camera"])
            edit(camera)
            meta["camera"] = json.dumps(camera)
        return meta

    return hook


def _zero_rotation(msg) -> None:
    if isinstance(msg, dict):
        msg["world_T_camera"] = [[0.0] * 4] * 3 + [[0, 0, 0, 1]]
    for tf in getattr(msg, "transforms", []):
        tf.rotation.x = tf.rotation.y = tf.rotation.z = tf.rotation.w = 0.0


def _nan_k(msg) -> None:
    if isinstance(msg, dict):
        msg["width"] = -8
    elif hasattr(msg, "K"):
        msg.K[0] = float("nan")


@pytest.mark.parametrize(
    ("edit", "match"),
    [(_zero_rotation, "no rotation in a transform"), (_nan_k, "K must be a finite")],
)
def test_a_camera_that_is_no_camera_is_skipped(tmp_path: Path, edit, match: str) -> None:
    """A camera transform with a zero quaternion, or a calibration with a NaN in K (and a
    calibration record with a zero rotation, or a negative width): the recording loads
    without that camera (reported as skipped), in ``lfd.load`` and in ``lfd segment --follow``
    alike; nothing raises scipy's error."""
    src = tmp_path / "ok.mcap"
    save(make_demo(), src)
    assert _load_quiet(src)[0].camera is not None
    bad = _rewrite(
        src, tmp_path / "bad.mcap", message=_camera_pose(edit), metadata=_camera_metadata(edit)
    )
    demo, caught = _load_quiet(bad)
    assert demo.camera is None and len(demo.hand) == len(load(src).hand)
    text = " ".join(str(w.message) for w in caught if w.category is RecoveredFileWarning)
    assert match in text and "calibration metadata: " in text, text
    proc = subprocess.run(
        [sys.executable, "-m", "lfd.cli", "segment", "--follow", str(bad), "--idle-timeout", "1"],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 0 and "Traceback" not in proc.stderr, proc.stderr
    if edit is _zero_rotation:  # the calibration is good: each bad pose is reported once
        assert proc.stderr.count(match) == 1, proc.stderr


_NUMBER = st.floats(allow_nan=True, allow_infinity=True, width=64)


@settings(max_examples=200, deadline=None)
@given(
    k=st.lists(_NUMBER, min_size=0, max_size=12),
    size=st.tuples(st.integers(-5, 5000), st.integers(-5, 5000)),
    quat=st.tuples(_NUMBER, _NUMBER, _NUMBER, _NUMBER),
    shift=st.tuples(_NUMBER, _NUMBER, _NUMBER),
)
def test_any_camera_message_is_a_camera_or_one_clear_error(k, size, quat, shift) -> None:
    """``camera_of`` of any calibration and transform values: a camera with a finite ``K`` and
    a finite rigid pose, or a RecordingFormatError of one line; never another exception."""
    from foxglove_schemas_protobuf.CameraCalibration_pb2 import CameraCalibration
    from foxglove_schemas_protobuf.FrameTransforms_pb2 import FrameTransforms
    from lfd.io.camera_pose import camera_of

    info = CameraCalibration(frame_id="camera", width=size[0] % 2**32, height=size[1] % 2**32)
    info.K.extend(k)
    tfs = FrameTransforms()
    tf = tfs.transforms.add()
    tf.child_frame_id = "camera"
    tf.rotation.x, tf.rotation.y, tf.rotation.z, tf.rotation.w = quat
    tf.translation.x, tf.translation.y, tf.translation.z = shift
    try:
        camera = camera_of(info, tfs)
    except RecordingFormatError as err:
        assert "\n" not in str(err)
        return
    assert camera is not None and camera.width > 0 and camera.height > 0
    assert np.isfinite(camera.K).all() and np.isfinite(camera.world_T_camera).all()
    rot = camera.world_T_camera[:3, :3]
    np.testing.assert_allclose(rot.T @ rot, np.eye(3), atol=1e-6)
