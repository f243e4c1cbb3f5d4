"""The engine's MCAP reader (``lfd.io.mcapfile.read``, Rust) against the pure-Python one
(``scan``): the same arrays from every shipped and simulated recording, the same recovery from
damaged files, the same refusals; the summary section (``read_summary``) against a full read."""

from __future__ import annotations

import warnings
from pathlib import Path

import _paths
import numpy as np
import pytest
from _mcapcopy import copy_records
from _synthetic import T0, make_demo
from lfd.demo import Demonstration
from lfd.errors import RecordingFormatError
from lfd.io import McapRecorder, save
from lfd.io.mcapfile import read, read_summary, scan
from lfd.io.reader import demonstration_of, is_ros_recording

ROOT = _paths.ROOT
RECORDINGS = sorted(p for p in (ROOT / "recordings").rglob("*.mcap"))


def _demo(raw, images: bool = True) -> tuple[Demonstration, list[str]]:  # type: ignore[no-untyped-def]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        demo = demonstration_of(raw, images=images)
    return demo, [str(w.message) for w in caught]


def assert_same_demo(a: Demonstration, b: Demonstration) -> None:
    """Every array bit for bit (NaN where NaN), every label, camera and metadata equal."""
    for name in ("t_ns", "keypoints", "confidence", "visible"):
        x, y = getattr(a.hand, name), getattr(b.hand, name)
        assert x.dtype == y.dtype and x.shape == y.shape, name
        np.testing.assert_array_equal(x, y, err_msg=name, strict=True)
    assert a.hand.side == b.hand.side
    assert list(a.objects) == list(b.objects)
    for key, o in a.objects.items():
        p = b.objects[key]
        assert (o.name, o.tag_id) == (p.name, p.tag_id)
        for name in ("size", "t_ns", "position", "quaternion", "visible"):
            np.testing.assert_array_equal(getattr(o, name), getattr(p, name), strict=True)
    assert a.labels == b.labels and a.live_segments == b.live_segments
    assert (a.camera is None) == (b.camera is None)
    if a.camera is not None and b.camera is not None:
        np.testing.assert_array_equal(a.camera.K, b.camera.K)
        np.testing.assert_array_equal(a.camera.world_T_camera, b.camera.world_T_camera)
    # the same report, but for the words each reader gives the damage
    ma, mb = dict(a.metadata), dict(b.metadata)
    ra, rb = dict(ma.pop("load_report")), dict(mb.pop("load_report"))
    assert ma == mb
    assert (ra.pop("recovered") is None) == (rb.pop("recovered") is None) and ra == rb
    for stream in ("color", "depth"):
        x, y = getattr(a, stream), getattr(b, stream)
        assert (x is None) == (y is None), stream
        if x is not None and y is not None:
            np.testing.assert_array_equal(x.t_ns, y.t_ns)
            np.testing.assert_array_equal(x.frames, y.frames, strict=True)


@pytest.mark.parametrize("path", RECORDINGS, ids=lambda p: str(p.relative_to(ROOT / "recordings")))
def test_engine_reader_gives_the_same_demonstration(path: Path) -> None:
    slow, fast = scan(path), read(path)
    assert fast.tracks and not slow.tracks
    assert fast.complete == slow.complete and fast.message_count == slow.message_count
    assert list(fast.channels) == list(slow.channels)
    for topic, c in slow.channels.items():
        assert fast.channels[topic] == c
    assert fast.metadata == slow.metadata and fast.library == slow.library
    if is_ros_recording(slow):
        return
    (a, wa), (b, wb) = _demo(slow), _demo(fast)
    assert_same_demo(a, b)
    assert wa == wb


def test_a_simulated_recording_with_gaps_reads_the_same(tmp_path: Path) -> None:
    """Unobserved keypoints (NaN), missing object samples, labels, camera and images."""
    demo = make_demo(images=3)
    path = tmp_path / "demo.mcap"
    save(demo, path)
    (a, wa), (b, wb) = _demo(scan(path)), _demo(read(path))
    assert_same_demo(a, b)
    assert wa == wb
    assert np.isnan(b.hand.keypoints).any()


def test_disorder_and_duplicates_are_resolved_the_same(tmp_path: Path) -> None:
    """Messages out of order, duplicate times (the first kept), a confidence message for a
    time with no hand frame and two for one frame: sorted, dropped and reported the same."""
    path = tmp_path / "order.mcap"
    rng = np.random.default_rng(3)
    with McapRecorder(path, objects=[("cube", 3, (0.05, 0.05, 0.05))]) as rec:
        for i in [0, 2, 1, 3, 3, 4, 2, 5]:
            t = T0 + i * 200_000_000
            rec.add_hand(
                t, rng.normal(size=(21, 3)), rng.uniform(size=21), rng.uniform(size=21) > 0.3
            )
        for i in (1, 0, 2, 2):
            rec.add_object_pose("cube", T0 + i * 33_000_000, rng.normal(size=3), (0, 0, 0, 1))
    (a, wa), (b, wb) = _demo(scan(path)), _demo(read(path))
    assert_same_demo(a, b)
    assert wa == wb and any("duplicate" in w for w in wb)
    assert a.metadata["load_report"]["duplicates"] == {
        "/hand/right/keypoints": 2,
        "/objects/cube/pose": 1,
    }


def test_images_are_decoded_only_when_used() -> None:
    path = ROOT / "recordings" / "rendered" / "exp1_short.mcap"
    demo, _ = _demo(read(path))
    assert demo.color is not None and not demo.color.decoded
    assert demo.color.frames.shape[0] == len(demo.color) and demo.color.decoded
    light, _ = _demo(read(path, images=False), images=False)
    assert light.color is None and light.depth is None
    assert not read(path, images=False).messages.get("/camera/color/image_raw")


@pytest.mark.parametrize("cut", [0.3, 0.6, 0.95])
def test_a_cut_file_recovers_the_same_chunks(tmp_path: Path, cut: float) -> None:
    src = ROOT / "recordings" / "exp1.mcap"
    data = src.read_bytes()
    path = tmp_path / "cut.mcap"
    path.write_bytes(data[: int(len(data) * cut)])
    slow, fast = scan(path), read(path)
    assert not fast.complete and not slow.complete
    assert fast.message_count == slow.message_count > 0
    assert fast.error is not None and slow.error is not None
    try:
        (a, wa), (b, wb) = _demo(slow), _demo(fast)
    except RecordingFormatError as err:  # too little left to use: the same refusal
        with pytest.raises(RecordingFormatError) as other:
            _demo(fast)
        assert str(other.value) == str(err)
        return
    assert_same_demo(a, b)
    # the same warnings, but for the words of the damage (each reader's own)
    assert len(wa) == len(wb) and any("truncated" in w for w in wb)


@pytest.mark.parametrize("content", [b"", b"\x89MCA", b"not an mcap file at all"])
def test_not_mcap_is_refused_in_the_same_words(tmp_path: Path, content: bytes) -> None:
    path = tmp_path / "bad.mcap"
    path.write_bytes(content)
    with pytest.raises(RecordingFormatError) as slow:
        scan(path)
    with pytest.raises(RecordingFormatError) as fast:
        read(path)
    assert str(fast.value) == str(slow.value)
    with pytest.raises(RecordingFormatError):
        read_summary(path)


def test_summary_section_agrees_with_a_full_read() -> None:
    for path in [
        ROOT / "recordings" / "exp1.mcap",
        *sorted(ROOT.glob("recordings/perceived/*.mcap")),
    ]:
        summary = read_summary(path, ["/lfd/ground_truth"])
        full = read(path, images=False)
        assert summary is not None
        assert summary.channels == full.channels
        assert summary.metadata == full.metadata and summary.message_count == full.message_count
        assert summary.messages["/lfd/ground_truth"] == full.messages.get("/lfd/ground_truth", [])


def test_a_killed_recording_has_no_summary(tmp_path: Path) -> None:
    data = (ROOT / "recordings" / "exp1.mcap").read_bytes()
    path = tmp_path / "killed.mcap"
    path.write_bytes(data[: len(data) // 2])
    assert read_summary(path) is None


def _without_calibration(src: Path, dst: Path) -> None:
    """``src`` rewritten without its ``calibration`` metadata record."""
    from mcap.reader import make_reader
    from mcap.writer import Writer

    with open(src, "rb") as f, open(dst, "wb") as out:
        reader = make_reader(f)
        writer = Writer(out)
        writer.start(profile="", library="test")
        copy_records(reader, writer, keep=lambda name: name != "calibration")
        writer.finish()


@pytest.mark.parametrize("calibration", [True, False])
def test_load_reads_only_the_topics_it_needs(tmp_path: Path, calibration: bool) -> None:
    """``load`` keeps the encoded messages of a few topics only, and reads ``/tf`` in a second
    pass when the camera pose is not in the metadata: the same demonstration as from ``scan``."""
    from lfd.io.reader import load

    path = ROOT / "recordings" / "exp1.mcap"
    if not calibration:
        path, src = tmp_path / "nocal.mcap", path
        _without_calibration(src, path)
    raw = read(path, images=False, topics=["/lfd/ground_truth"])
    assert raw.unread and "/tf" in raw.unread and not raw.messages["/tf"]
    assert raw.channels["/tf"].count > 0
    assert raw.encoded("/tf") == scan(path).messages["/tf"]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fast = load(path)
    a, wa = _demo(scan(path))
    assert_same_demo(a, fast)
    assert wa == [str(w.message) for w in caught]
    assert a.camera is not None
    if not calibration:
        assert not np.array_equal(a.camera.world_T_camera, np.eye(4))
