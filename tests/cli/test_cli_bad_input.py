"""Bad input of every kind ends as one line on stderr and exit status 2 (issue 30, part 2).

Each test is one kind of damaged or unusual input: nested or garbage JSON/TOML, corrupt sizes
inside a recording, damaged ROS bags and tf, files that are not regular files, a closed stdout,
two schemas on the hand topic, a damaged file being followed, a ROS 2 bag directory given where
recordings are expanded, a batch whose worker dies. They run ``lfd.cli.main`` in this process
where they can (fast), in a subprocess where the case needs one (closed stdout, a FIFO).
"""

from __future__ import annotations

import json
import os
import shutil
import socket
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from test_cli_errors import EXP1, _assert_one_error_line, _run


def _one_line(capsys: pytest.CaptureFixture[str], argv: list[Any], expected: str = "") -> str:
    """Run ``lfd ARGV`` in this process: exit 2, one ``lfd CMD: error:`` line, no traceback."""
    from lfd.cli import main

    try:
        status = main([str(a) for a in argv])
    except SystemExit as stop:  # a usage error, reported by argparse
        status = stop.code  # type: ignore[assignment]
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert status == 2, err
    assert "Traceback" not in err, err
    assert len(lines) == 1, err
    assert lines[0].startswith("lfd ") and ": error: " in lines[0], lines[0]
    assert expected in lines[0], lines[0]
    assert len(lines[0]) < 600, lines[0]  # a message, not a dump of the input
    return lines[0]


@pytest.fixture
def rec(tmp_path: Path) -> Path:
    """A copy of exp1.mcap (an input: it must come out unchanged)."""
    p = tmp_path / "exp1.mcap"
    shutil.copyfile(EXP1, p)
    return p


def _rewrite(
    src: Path,
    dst: Path,
    *,
    metadata: Callable[[str, dict[str, str]], dict[str, str]] | None = None,
    channel: Callable[[str, dict[str, str]], dict[str, str]] | None = None,
    extra: tuple[str, str, bytes] | None = None,
) -> Path:
    """``src`` copied to ``dst`` with its metadata records and channel metadata changed, and
    with ``extra`` = (topic, schema name, payload): one more channel and message."""
    from mcap.reader import make_reader
    from mcap.writer import CompressionType, Writer

    with open(src, "rb") as f, open(dst, "wb") as out:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None
        w = Writer(out, compression=CompressionType.ZSTD)
        w.start(profile="", library="test")
        sids = {
            i: w.register_schema(s.name, s.encoding, s.data) for i, s in summary.schemas.items()
        }
        cids = {}
        for i, ch in sorted(summary.channels.items()):
            meta = dict(ch.metadata)
            if channel is not None:
                meta = channel(ch.topic, meta)
            cids[i] = w.register_channel(ch.topic, ch.message_encoding, sids[ch.schema_id], meta)
        for rec in reader.iter_metadata():
            meta = dict(rec.metadata)
            w.add_metadata(rec.name, metadata(rec.name, meta) if metadata else meta)
        first = None
        for _, _, msg in reader.iter_messages(log_time_order=False):
            first = msg.log_time if first is None else first
            w.add_message(cids[msg.channel_id], msg.log_time, msg.data, msg.publish_time)
        if extra is not None:
            topic, schema, payload = extra
            sid = w.register_schema(schema, "protobuf", b"")
            cid = w.register_channel(topic, "protobuf", sid, {})
            w.add_message(cid, first or 0, payload, first or 0)
        w.finish()
    return dst


# --- 1. deeply nested or garbage JSON/TOML, huge numbers, non-UTF-8 ----------------------------
NESTED = 100_000


@pytest.mark.parametrize(
    ("case", "expected"),
    [
        ("templates-nested", "nested too deeply"),
        ("sidecar-garbage", "sizes.toml"),
        ("sidecar-nested", "sizes.toml"),
        ("sidecar-not-utf8", "not UTF-8"),
        ("labels-1e400", "finite number"),
        ("labels-40-digits", "label 0"),
        ("labels-end-1e300", "end_s"),
        ("labels-5000-digits-json", "labels.json"),
        ("labels-5000-digits-csv", "end_s"),
        ("labels-underscore-csv", "end_s must be a number of seconds, got '1_0'"),
        ("labels-nested", "nested too deeply"),
        ("labels-huge-file", "larger than"),
    ],
)
def test_nested_huge_or_garbage_text_input(
    case: str, expected: str, rec: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    side = tmp_path / "exp1.mcap.sizes.toml"
    labels = tmp_path / "labels.json"
    entry = '{"skill": "pick_up", "start_s": %s, "end_s": %s, "object": "box_2"}'
    argv: list[Any] = ["label", rec, "--from", labels]
    if case == "templates-nested":
        t = tmp_path / "t.json"
        t.write_text("[" * NESTED + "]" * NESTED)
        argv = ["segment", rec, "--templates", t]
    elif case.startswith("sidecar"):
        argv = ["segment", rec]
        side.write_bytes(
            {
                "sidecar-garbage": b"\x00\x01 = = [[ garbage",
                "sidecar-nested": b"[sizes]\nbox_1 = " + b"[" * NESTED + b"]" * NESTED,
                "sidecar-not-utf8": b"[sizes]\nbox_1 = [0.1, 0.1, 0.1] # \xff\xfe\n",
            }[case]
        )
    elif case == "labels-1e400":
        labels.write_text(f"[{entry % ('1e400', '2')}]")
    elif case == "labels-40-digits":
        labels.write_text(f"[{entry % ('1', '1' + '0' * 39)}]")
    elif case == "labels-end-1e300":
        labels.write_text(f"[{entry % ('1', '1e300')}]")
    elif case == "labels-5000-digits-json":
        labels.write_text(f"[{entry % ('1', '9' * 5000)}]")
    elif case == "labels-5000-digits-csv":
        labels = tmp_path / "labels.csv"
        labels.write_text(f"pick_up,1,{'9' * 5000},box_2\n")
        argv[-1] = labels
    elif case == "labels-underscore-csv":  # float("1_0") is 10: a plain number is asked for
        labels = tmp_path / "labels.csv"
        labels.write_text("pick_up,1,1_0,box_2\n")
        argv[-1] = labels
    elif case == "labels-nested":
        labels.write_text("[" * NESTED)
    elif case == "labels-huge-file":
        from lfd.inputs import MAX_TEXT_BYTES

        with open(labels, "wb") as f:
            f.truncate(MAX_TEXT_BYTES + 1)  # sparse: no disk used
    before = rec.read_bytes()
    line = _one_line(capsys, argv, expected)
    assert rec.read_bytes() == before, line


LABEL_FILES = {
    "ns-start-without-end": (
        '[{"skill": "move", "start_ns": 1700000000100000000}]',
        "label 0 needs skill, start_s and end_s (or start_ns and end_ns: both times in one "
        "unit); it has start_ns but no end_ns",
    ),
    "ns-start-s-end": (
        '[{"skill": "move", "start_ns": 1700000000100000000, "end_s": 2}]',
        "it mixes start_ns with end_s",
    ),
    "csv-huge-field": ("move,0," + "1" * 200_000 + "\n", "line 1 is not CSV: field larger"),
    "csv-duplicate-column": ("skill,skill,start_s,end_s\nmove,move,0,1\n", "names skill twice"),
    "count": ("".join(f"move,{i},{i + 1}\n" for i in range(4)), "more than 3 labels"),
}


@pytest.mark.parametrize("case", list(LABEL_FILES))
def test_bad_label_file(
    case: str,
    rec: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A label file with one mistake: one line, the recording unchanged and no OUT (a start_ns
    without end_ns was a KeyError, a field over 131072 characters a _csv.Error traceback, a
    repeated header column was accepted, any number of labels was read)."""
    text, expected = LABEL_FILES[case]
    if case == "count":
        monkeypatch.setattr("lfd.io.labels.MAX_LABELS", 3)
    labels = tmp_path / ("labels.json" if text.startswith("[") else "labels.csv")
    labels.write_text(text, encoding="utf-8")
    out = tmp_path / "out.mcap"
    before = rec.read_bytes()
    _one_line(capsys, ["label", rec, "--from", labels, "-o", out], expected)
    assert rec.read_bytes() == before and not out.exists()


# --- 2. corrupt object sizes inside a recording; garbage appended to a followed file -----------
SIZE_CASES = {
    "string": '"big"',
    "nested": "[[0.05, 0.05, 0.05]]",
    "two-values": "[0.05, 0.05]",
}


@pytest.mark.parametrize("where", ["demo", "channel"])
@pytest.mark.parametrize("bad", list(SIZE_CASES))
@pytest.mark.parametrize("follow", [False, True], ids=["offline", "follow"])
def test_corrupt_sizes_in_recording(
    bad: str, where: str, follow: bool, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    value = SIZE_CASES[bad]

    def meta(name: str, m: dict[str, str]) -> dict[str, str]:
        if name == "demo" and where == "demo":
            objects = json.loads(m["objects"])
            objects[1]["size"] = json.loads(value)
            m["objects"] = json.dumps(objects)
        elif name == "demo":  # the objects declared by their pose channels only
            del m["objects"]
        return m

    def chan(topic: str, m: dict[str, str]) -> dict[str, str]:
        if where == "channel" and topic == "/objects/box_2/pose":
            m["size"] = value
        return m

    bad_rec = _rewrite(EXP1, tmp_path / "bad.mcap", metadata=meta, channel=chan)
    argv: list[Any] = (
        ["segment", bad_rec, "--follow", "--idle-timeout", "1"]
        if follow
        else [
            "segment",
            bad_rec,
        ]
    )
    _one_line(capsys, argv, "box_2")


def test_follow_garbage_appended(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A file cut mid-write with garbage after it: read as the offline reader reads it (its
    complete chunks, one warning), not a traceback."""
    from lfd.cli import main

    data = EXP1.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) * 3 // 4] + os.urandom(4096))
    offline = main(["segment", str(cut)])
    offline_err = capsys.readouterr().err
    status = main(["segment", str(cut), "--follow", "--idle-timeout", "1"])
    err = capsys.readouterr().err
    assert "Traceback" not in err, err
    assert status == offline, (err, offline_err)
    assert all(line.startswith("lfd segment: ") for line in err.splitlines() if line.strip()), err


def test_follow_a_file_that_shrinks_is_refused_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """60 % of exp1 followed, then truncated to 1000 bytes and 5 KB of random bytes appended:
    one error line (no blank line before it), exit 2, the skills printed before kept (it went
    on segmenting data no longer in the file, exit 0)."""
    import threading

    from lfd.cli import main

    data = EXP1.read_bytes()
    grown = tmp_path / "g.mcap"
    grown.write_bytes(data[: len(data) * 6 // 10])

    def shrink() -> None:
        with open(grown, "r+b") as f:
            f.truncate(1000)
            f.seek(0, os.SEEK_END)
            f.write(os.urandom(5000))

    timer = threading.Timer(3.0, shrink)  # the 60 % is read in well under a second
    timer.start()
    try:
        status = main(["segment", str(grown), "--follow", "--idle-timeout", "10"])
    finally:
        timer.cancel()
    out, err = capsys.readouterr()
    assert status == 2, err
    assert len(err.splitlines()) == 1 and "Traceback" not in err, repr(err)
    assert err.startswith(f"lfd segment: error: {grown} was truncated or replaced"), err
    assert "settled: pick_up" in out  # what was printed before stays


# --- 3. damaged ROS bags; tf with a zero, NaN or inf quaternion --------------------------------
@pytest.fixture(scope="module")
def ros1(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    import lfd
    from _rosbags import write_ros1

    d = tmp_path_factory.mktemp("ros1")
    text = write_ros1(lfd.load(EXP1, images=False), d / "exp1.bag")
    (d / "map.toml").write_text(text)
    return d / "exp1.bag", d / "map.toml"


@pytest.mark.parametrize("damage", ["flipped", "zeroed"])
def test_damaged_ros_bag(
    damage: str, ros1: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bag, mapping = ros1
    data = bytearray(bag.read_bytes())
    mid = len(data) // 2
    for i in range(mid, mid + 256):
        data[i] = data[i] ^ 0xFF if damage == "flipped" else 0
    broken = tmp_path / "broken.bag"
    broken.write_bytes(bytes(data))
    _one_line(capsys, ["segment", broken, "--map", mapping], "broken.bag")


@pytest.mark.parametrize("quat", ["zero", "nan", "inf"])
def test_tf_bad_quaternion(
    quat: str, tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """A tf transform whose rotation is no rotation is refused, naming the topic and time."""
    import _rosbags
    import lfd
    import numpy as np

    value = {"zero": 0.0, "nan": float("nan"), "inf": float("inf")}[quat]
    tf = _rosbags._tf
    calls = [0]

    def bad_tf(store: Any, t: int, parent: str, child: str, m: np.ndarray) -> Any:
        msg = tf(store, t, parent, child, m)
        calls[0] += 1
        if calls[0] == 50:  # one dynamic transform in the middle
            r = msg.transform.rotation
            r.x = r.y = r.z = r.w = value
            if quat != "zero":
                r.x, r.y, r.z, r.w = 0.0, 0.0, 0.0, value
        return msg

    monkeypatch.setattr(_rosbags, "_tf", bad_tf)
    text = _rosbags.write_ros1(lfd.load(EXP1, images=False), tmp_path / "q.bag")
    (tmp_path / "map.toml").write_text(text)
    line = _one_line(capsys, ["segment", tmp_path / "q.bag", "--map", tmp_path / "map.toml"], "/tf")
    assert "quaternion" in line and " ns" in line, line


# --- 4. export where every input is broken -----------------------------------------------------
def test_export_every_input_broken(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("lerobot", reason="lerobot not installed (optional export extra)")
    from lfd.cli import main

    data = EXP1.read_bytes()
    (tmp_path / "a.mcap").write_bytes(b"garbage")
    (tmp_path / "b.mcap").write_bytes(data[:2000])
    sizes = tmp_path / "c.mcap"

    def meta(name: str, m: dict[str, str]) -> dict[str, str]:
        if name == "demo":
            objects = json.loads(m["objects"])
            objects[0]["size"] = "big"
            m["objects"] = json.dumps(objects)
        return m

    _rewrite(EXP1, sizes, metadata=meta)
    inputs = [tmp_path / n for n in ("a.mcap", "b.mcap", "c.mcap")]
    for jobs in ("1", "2"):
        status = main(
            ["export", "lerobot", *map(str, inputs), "-o", str(tmp_path / "ds"), "--jobs", jobs]
        )
        err = capsys.readouterr().err
        assert status == 2, err
        assert "Traceback" not in err, err
        lines = err.splitlines()
        assert all(
            line.startswith(("lfd export: error: ", "lfd export: warning: ")) for line in lines
        ), err
        assert lines[-1] == "lfd export: error: no recording could be exported (3 failed)", err
        assert not (tmp_path / "ds").exists()


# --- 5. --ray ADDRESS where no cluster runs ----------------------------------------------------
def test_ray_address_without_cluster(
    rec: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    pytest.importorskip("ray", reason="ray not installed (optional extra)")
    import lfd.batch

    monkeypatch.setattr(lfd.batch, "RAY_CONNECT_TIMEOUT_S", 1.0)
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    t0 = time.monotonic()
    line = _one_line(capsys, ["segment", rec, rec, f"--ray=127.0.0.1:{port}"], f"127.0.0.1:{port}")
    assert time.monotonic() - t0 < 30, line
    assert "no Ray cluster" in line, line


def test_ray_address_where_something_else_listens(
    rec: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # a web server (HTTP/1.1) on the port: Ray itself would retry its handshake for minutes
    pytest.importorskip("ray", reason="ray not installed (optional extra)")
    import threading

    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen()
    port = srv.getsockname()[1]

    def serve() -> None:
        with srv:
            while True:
                try:
                    conn, _ = srv.accept()
                except OSError:
                    return
                with conn:
                    conn.recv(1024)
                    conn.sendall(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n")

    threading.Thread(target=serve, daemon=True).start()
    t0 = time.monotonic()
    try:
        line = _one_line(capsys, ["segment", rec, rec, f"--ray=127.0.0.1:{port}"], "not a Ray")
    finally:
        srv.close()
    assert time.monotonic() - t0 < 20, line


# --- 6. reproduce --randomise N: bounded -------------------------------------------------------
@pytest.mark.parametrize("n", ["1000000000", str(2**63 - 1), "100001"])
def test_randomise_bounded(n: str, rec: Path, capsys: pytest.CaptureFixture[str]) -> None:
    _one_line(capsys, ["reproduce", rec, "--randomise", n], "from 1 to 100000")


def test_randomise_plans_as_it_goes(monkeypatch: pytest.MonkeyPatch) -> None:
    """Each layout is drawn just before its runs, not every layout before the first run."""
    import lfd
    from lfd.preprocessing import preprocess
    from lfd.reproduce import randomise
    from lfd.reproduce.program import from_labels

    demo = lfd.load(EXP1, images=False)
    traj = preprocess(demo)
    program = from_labels(demo.labels, int(traj.t_ns[0]))
    events: list[str] = []

    def drawn(*args: Any, **kwargs: Any) -> None:
        events.append("draw")
        return None

    def run(*args: Any, **kwargs: Any) -> Any:
        events.append("run")
        raise lfd.errors.LfdError("not simulated here")

    monkeypatch.setattr(randomise, "check_layout", drawn)
    res = randomise.run_randomised(traj, program, 3, run, modes=("replay",))
    assert events == ["draw", "run"] * 3
    assert len(res.layouts) == 3 and len(res.runs) == 3


# --- 7. non-regular files: /dev/zero, a FIFO ---------------------------------------------------
@pytest.mark.parametrize("option", ["--map", "--templates", "recording", "sidecar", "--from"])
def test_dev_zero_refused(
    option: str, rec: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv: list[Any] = {
        "--map": ["segment", rec, "--map", "/dev/zero"],
        "--templates": ["segment", rec, "--templates", "/dev/zero"],
        "recording": ["segment", "/dev/zero"],
        "sidecar": ["segment", rec],
        "--from": ["label", rec, "--from", "/dev/zero"],
    }[option]
    if option == "sidecar":
        (tmp_path / "exp1.mcap.sizes.toml").symlink_to("/dev/zero")
    line = _one_line(capsys, argv, "not a regular file")
    assert "/dev/zero" in line or "sizes.toml" in line, line


@pytest.mark.parametrize("option", ["--map", "--templates", "recording", "--from"])
def test_fifo_refused(option: str, rec: Path, tmp_path: Path) -> None:
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    argv = {
        "--map": ["segment", str(rec), "--map", str(fifo)],
        "--templates": ["segment", str(rec), "--templates", str(fifo)],
        "recording": ["segment", str(fifo)],
        "--from": ["label", str(rec), "--from", str(fifo)],
    }[option]
    proc = _run(*argv)  # a hang is a timeout error here
    _assert_one_error_line(proc, "not a regular file")


# --- 8. --json - with stdout closed ------------------------------------------------------------
def test_json_to_closed_stdout() -> None:
    proc = subprocess.run(
        [sys.executable, "-m", "lfd.cli", "segment", str(EXP1), "--json", "-"],
        stdin=subprocess.DEVNULL,
        stdout=None,
        stderr=subprocess.PIPE,
        text=True,
        timeout=120,
        close_fds=True,
        pass_fds=(),
        preexec_fn=lambda: os.close(1),
    )
    _assert_one_error_line(proc, "standard output")


# --- 9. two message types on the hand topic ----------------------------------------------------
def test_two_message_types_on_hand_topic(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A bag whose hand topic carries PoseArray and PoseStamped messages: refused by name."""
    pytest.importorskip("rosbags", reason="rosbags not installed (optional ros extra)")
    import numpy as np
    from _rosbags import _header, _pose
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    T = store.types
    bag = tmp_path / "two.bag"
    pose = _pose(store, np.zeros(3), np.array([0, 0, 0, 1.0]))
    with Writer(bag) as w:
        arr = w.add_connection("/hand", "geometry_msgs/msg/PoseArray", typestore=store)
        one = w.add_connection("/hand", "geometry_msgs/msg/PoseStamped", typestore=store)
        box = w.add_connection("/box", "geometry_msgs/msg/PoseStamped", typestore=store)
        for i in range(10):
            t = 10**9 + i * 10**8
            msg = T["geometry_msgs/msg/PoseArray"](
                header=_header(store, t, "world"), poses=[pose] * 21
            )
            w.write(arr, t, store.serialize_ros1(msg, "geometry_msgs/msg/PoseArray"))
            ps = T["geometry_msgs/msg/PoseStamped"](header=_header(store, t, "world"), pose=pose)
            w.write(one, t + 1, store.serialize_ros1(ps, "geometry_msgs/msg/PoseStamped"))
            w.write(box, t, store.serialize_ros1(ps, "geometry_msgs/msg/PoseStamped"))
    mapping = tmp_path / "map.toml"
    mapping.write_text(
        'reference_frame = "world"\n[hand]\ntopic = "/hand"\n'
        '[objects.box_1]\ntopic = "/box"\nsize = [0.05, 0.05, 0.05]\n'
    )
    line = _one_line(capsys, ["segment", bag, "--map", mapping], "/hand")
    assert "PoseArray" in line and "PoseStamped" in line, line


def _two_types_on_hand_topic(dst: Path) -> Path:
    """exp1 with a second channel on the hand topic, of another schema and encoding."""
    from mcap.reader import make_reader
    from mcap.writer import Writer

    with open(EXP1, "rb") as f, open(dst, "wb") as g:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None
        w = Writer(g)
        w.start()
        schemas = {
            i: w.register_schema(s.name, s.encoding, s.data) for i, s in summary.schemas.items()
        }
        chans = {
            i: w.register_channel(c.topic, c.message_encoding, schemas.get(c.schema_id, 0))
            for i, c in summary.channels.items()
        }
        other = w.register_channel(
            "/hand/right/keypoints",
            "json",
            w.register_schema("acme.Keypoints", "jsonschema", b"{}"),
        )
        for _, channel, message in reader.iter_messages():
            w.add_message(chans[channel.id], message.log_time, message.data, message.publish_time)
            if channel.topic == "/hand/right/keypoints":
                w.add_message(other, message.log_time + 1, b'{"x": 1}', message.publish_time)
        w.finish()
    return dst


@pytest.mark.parametrize("how", ["offline", "follow", "python reader"])
def test_two_message_types_on_an_lfd_hand_topic(
    how: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Refused naming both types, by the engine's reader, --follow and the Python reader."""
    rec = _two_types_on_hand_topic(tmp_path / "two.mcap")
    both = "/hand/right/keypoints carries two message types, foxglove.PosesInFrame (protobuf) "
    both += "and acme.Keypoints (json)"
    if how == "python reader":
        from lfd.errors import RecordingFormatError
        from lfd.io.mcapfile import scan

        with pytest.raises(RecordingFormatError, match=r"acme\.Keypoints \(json\)"):
            scan(rec)
        return
    follow = ["--follow", "--idle-timeout", "5"] if how == "follow" else []
    _one_line(capsys, ["segment", rec, *follow], both)


# --- 10. --follow of a corrupt zstd chunk or malformed metadata --------------------------------
def _corrupt_chunk(dst: Path) -> Path:
    """exp1 with bytes in the middle of one chunk's compressed data changed, CRCs left."""
    from mcap.reader import make_reader

    data = bytearray(EXP1.read_bytes())
    with open(EXP1, "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    idx = sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset)[2]
    mid = idx.chunk_start_offset + idx.chunk_length // 2
    for i in range(mid, mid + 32):
        data[i] ^= 0x5A
    dst.write_bytes(bytes(data))
    return dst


def _malformed_metadata(dst: Path) -> Path:
    def meta(name: str, m: dict[str, str]) -> dict[str, str]:
        if name == "demo":
            m["objects"] = '[{"name": "box_1", "tag_id": "one"}, 7]'
        return m

    return _rewrite(EXP1, dst, metadata=meta)


@pytest.mark.parametrize("damage", ["zstd-chunk", "metadata"])
def test_follow_reads_damage_as_offline(
    damage: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from lfd.cli import main

    make = _corrupt_chunk if damage == "zstd-chunk" else _malformed_metadata
    bad = make(tmp_path / "bad.mcap")
    offline = main(["segment", str(bad)])
    offline_err = capsys.readouterr().err
    status = main(["segment", str(bad), "--follow", "--idle-timeout", "1"])
    err = capsys.readouterr().err
    assert "Traceback" not in err, err
    assert status == offline, (err, offline_err)
    if status == 2:
        lines = [line for line in err.splitlines() if line.strip()]
        assert len(lines) == 1 and lines[0].startswith("lfd segment: error: "), err


# --- 11. a ROS 2 bag directory where recordings are expanded -----------------------------------
def test_ros2_bag_directory_is_one_recording(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    pytest.importorskip("rosbags", reason="rosbags not installed (optional ros extra)")
    import lfd
    from _rosbags import write_ros2
    from lfd.batch import recording_paths
    from lfd.cli import main

    bag = tmp_path / "bag"
    text = write_ros2(lfd.load(EXP1, images=False), bag, "sqlite3")
    (tmp_path / "map.toml").write_text(text)
    assert recording_paths([bag]) == [str(bag)]
    assert recording_paths([tmp_path]) == [str(bag)]  # a folder of bags: each bag
    status = main(["segment", str(bag), "--map", str(tmp_path / "map.toml"), "--json", "-"])
    out, err = capsys.readouterr()
    assert status == 0, err
    assert json.loads(out)["segments"]


# --- 12. a worker dies: the rest of the batch keeps a pool -------------------------------------
def _die_on_first(item: tuple[int, str]) -> int:
    n, _ = item
    if n == 0:
        os._exit(3)
    time.sleep(0.05)
    return os.getpid()


def test_worker_death_keeps_the_pool() -> None:
    from lfd.batch import WORKER_DIED, run_batch

    items = [(i, "x") for i in range(12)]
    res = run_batch(_die_on_first, items, jobs=2)
    assert res[0].error is not None and WORKER_DIED in res[0].error
    pids = {r.value for r in res[1:] if r.ok}
    assert all(r.ok for r in res[1:]), [r.error for r in res]
    assert len(pids) <= 4, pids  # a pool, not one process per item


# --- 13. reproduce --task PROGRAM: every key checked, times within the recording ---------------
def _program(*segments: dict[str, Any], **key: Any) -> str:
    """A task program of ``segments``, each a ``pick_up`` of box_2 at 0.5-1.5 s unless given."""
    base = {"skill": "pick_up", "start_s": 0.5, "end_s": 1.5, "object": "box_2", "params": {}}
    return json.dumps({"segments": [{**base, **s} for s in segments or ({},)], **key})


def _segment(key: str, value: str) -> str:
    """One segment of box_2 with ``key`` given as raw JSON text (a number JSON's parser reads
    but ``json.dumps`` would not write: 1e400, 1 followed by 400 zeros, -Infinity)."""
    return _program({key: 0.0}).replace(f'"{key}": 0.0', f'"{key}": {value}')


TASK_CASES = {
    "end-400-digits": (_segment("end_s", "1" + "0" * 400), "end_s must be within +-9e+09 s"),
    "start-negative-400-digits": (_segment("start_s", "-1" + "0" * 400), "within +-9e+09 s"),
    "end-1e400": (_segment("end_s", "1e400"), "end_s must be a finite number of seconds"),
    "end-inf-text": (_program({"end_s": "inf"}), "end_s must be a finite number of seconds"),
    "end-1e300": (_program({"end_s": 1e300}), "end_s must be within +-9e+09 s"),
    "start-minus-infinity": (_segment("start_s", "-Infinity"), "start_s must be a finite"),
    "start-true": (_program({"start_s": True}), "start_s must be a number of seconds, got True"),
    "start-null": (_program({"start_s": None}), "start_s must be a number of seconds, got None"),
    "start-negative": (_program({"start_s": -5}), "segment 0 (pick_up -5.000-1.500 s): starts "),
    "shifted-past-end": (
        _program({"start_s": 1000.5, "end_s": 1001.5}, {"start_s": 1001.5, "end_s": 1003}),
        "ends after the recording (it spans 0-14.700 s)",
    ),
    "object-list": (_program({"object": ["box_2"]}), "object must be an object's name or null"),
    "object-dict": (_program({"object": {"name": "box_2"}}), "object must be an object's name"),
    "object-int": (_program({"object": 3}), "object must be an object's name or null, got 3"),
    "skill-list": (_program({"skill": ["pick_up"]}), "skill must be a skill's name"),
    "support-list": (_program({"params": {"support": ["box_1"]}}), "params.support must be"),
    "missing-end": (
        json.dumps({"segments": [{"skill": "pick_up", "start_s": 0.5}]}),
        'segment 0: missing "end_s"',
    ),
    "params-list": (_program({"params": ["support"]}), "params must be a JSON object"),
    "params-text": (_program({"params": "box_1"}), "params must be a JSON object"),
    "too-many": (
        json.dumps({"segments": [{"skill": "move", "start_s": 0, "end_s": 0}] * 2001}),
        "has 2001 segments; at most 2000 are run",
    ),
    "two-hand": (
        json.dumps({"hands": {"right": json.loads(_program())}, "sync": []}),
        "is a two-hand program ('hands'), which a one-arm run does not read",
    ),
    "two-hand-wrapped": (
        json.dumps({"recording": "x.mcap", "program": {"hands": {}, "sync": []}}),
        "two-hand program",
    ),
}


@pytest.mark.parametrize("case", list(TASK_CASES))
def test_task_program_refused(
    case: str, rec: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``lfd reproduce --task`` refuses a bad program in one line, exit 2, before any work:
    nothing is written (``--program --json``)."""
    text, expected = TASK_CASES[case]
    program = tmp_path / "program.json"
    program.write_text(text)
    out = tmp_path / "out.json"
    _one_line(capsys, ["reproduce", rec, "--task", program, "--program", "--json", out], expected)
    assert not out.exists()


def test_task_program_refused_before_a_run(
    rec: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A run (not ``--program``) refuses a program outside the recording before simulating:
    before, it ran and reported success, and its ``--json`` held a bare ``Infinity``."""
    pytest.importorskip("mujoco")
    program = tmp_path / "program.json"
    out = tmp_path / "out.json"
    for text in (_segment("end_s", "1e400"), _program({"start_s": -5})):
        program.write_text(text)
        argv = ["reproduce", rec, "--task", program, "--mode", "replay", "--json", out]
        _one_line(capsys, argv, "task")
        assert not out.exists()


def test_program_json_round_trips_into_task(
    rec: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--program --json`` writes ``{"recording", "program"}``; ``--task`` reads it back."""
    from lfd.cli import main

    first, second = tmp_path / "first.json", tmp_path / "second.json"
    assert main(["reproduce", str(rec), "--program", "--json", str(first)]) == 0
    argv = ["reproduce", str(rec), "--task", str(first), "--program", "--json", str(second)]
    assert main(argv) == 0, capsys.readouterr().err
    program = json.loads(first.read_text())["program"]
    assert len(program["segments"]) == 8
    assert json.loads(second.read_text())["program"] == program
