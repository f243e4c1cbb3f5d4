"""Rerun views: log pipeline data to an .rrd, read it back with rr.chunk.RrdReader, compare."""

from __future__ import annotations

import argparse
import os
import urllib.request
from pathlib import Path
from typing import Any

import _paths
import numpy as np
import pytest
from lfd import CameraInfo, Demonstration, HandTrack, ImageStream, ObjectTrack, SkillLabel
from lfd.errors import DemonstrationError, LfdError

rr = pytest.importorskip("rerun")

import lfd.viz as viz  # noqa: E402
from _rrd import Rrd  # noqa: E402
from lfd.viz.screenshot import free_port  # noqa: E402

T0 = 1_700_000_000_123_456_789  # absolute capture time of the first sample (ns)
EXP1 = _paths.RECORDINGS / "exp1.mcap"


# --- reading an .rrd back ---------------------------------------------------------------------
# --- synthetic data ---------------------------------------------------------------------------
def make_demo(n: int = 40, m: int = 120, images: bool = True) -> Demonstration:
    rng = np.random.default_rng(1)
    t = T0 + np.arange(n, dtype=np.int64) * 200_000_000
    path = np.linspace([0.2, 0.0, 0.1], [0.4, 0.1, 0.2], n)
    keypoints = path[:, None, :] + 0.03 * rng.standard_normal((1, 21, 3))
    keypoints[7, 3] = np.nan  # one missing keypoint
    keypoints[9] = np.nan  # one frame without a hand
    hand = HandTrack(t, keypoints, np.ones((n, 21)))
    to = T0 + 5_000_000 + np.arange(m, dtype=np.int64) * 33_333_333
    pos = np.column_stack([np.linspace(0.4, 0.5, m), np.zeros(m), np.full(m, 0.025)])
    quat = np.tile([0.0, 0.0, np.sin(0.2), np.cos(0.2)], (m, 1))
    visible = np.ones(m, bool)
    visible[50:60] = False
    cube = ObjectTrack("cube_a", 3, [0.05, 0.05, 0.05], to, pos, quat, visible)
    labels = [
        SkillLabel("pick_up", t[0], t[15], "cube_a"),
        SkillLabel("place", t[15], t[30], "cube_a"),
    ]
    kwargs: dict[str, Any] = {}
    if images:
        K = np.array([[300.0, 0, 32], [0, 300.0, 24], [0, 0, 1]])
        pose = np.eye(4)
        pose[:3, 3] = [0.3, -0.6, 0.5]
        ti = to[::10]
        kwargs = {
            "camera": CameraInfo(64, 48, K, pose),
            "color": ImageStream(ti, rng.integers(0, 255, (len(ti), 48, 64, 3), dtype=np.uint8)),
            "depth": ImageStream(ti, rng.integers(300, 900, (len(ti), 48, 64), dtype=np.uint16)),
        }
    return Demonstration(hand, {"cube_a": cube}, labels, **kwargs)


def feature_arrays(n: int = 40) -> tuple[list[str], np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(2)
    values = rng.standard_normal((n, 10))
    values[3, 0] = np.nan
    thresholds = np.abs(rng.standard_normal((n, 10)))
    t = T0 + np.arange(n, dtype=np.int64) * 200_000_000
    return list(viz.FEATURE_NAMES), values, thresholds, t


@pytest.fixture
def session(tmp_path: Path):
    path = tmp_path / "out.rrd"
    s = viz.open_session("lfd_test", save=path, make_default=False)
    yield s
    s.recording.disconnect()


def finish(session: viz.Session) -> Rrd:
    assert session.save_path is not None
    session.close()
    return Rrd(session.save_path)


# --- demonstration ----------------------------------------------------------------------------
def test_demonstration_roundtrip(session: viz.Session) -> None:
    demo = make_demo()
    origin = viz.log_demonstration(demo, recording=session.recording, jpeg_quality=None)
    assert origin == T0
    data = finish(session)

    # hand: demo_time = t - origin, frame = sample index, finite keypoints with their ids
    rows = data.entity("/world/hand/keypoints")
    assert [r["frame"] for r in rows] == list(range(len(demo.hand)))
    np.testing.assert_array_equal(data.times("/world/hand/keypoints"), demo.hand.t_ns - T0)
    for i, row in enumerate(rows):
        ok = np.all(np.isfinite(demo.hand.keypoints[i]), axis=1)
        ids = row["Points3D:keypoint_ids"] or []
        assert ids == list(np.flatnonzero(ok))
        if ok.any():
            got = np.array(row["Points3D:positions"])
            np.testing.assert_allclose(got, demo.hand.keypoints[i][ok], atol=1e-6)
    assert 3 not in rows[7]["Points3D:keypoint_ids"]
    assert not rows[9]["Points3D:positions"]

    # the skeleton: 21 named keypoints and the bones
    ctx = data.static["/world/hand"]["AnnotationContext:context"][0][0]["class_description"]
    assert [k["label"] for k in ctx["keypoint_annotations"]][:2] == ["wrist", "thumb_cmc"]
    assert len(ctx["keypoint_connections"]) == 21

    # object: visible samples only, translation + quaternion, box labelled with the tag id
    cube = demo.objects["cube_a"]
    vis = np.flatnonzero(cube.visible)
    np.testing.assert_array_equal(data.times("/world/objects/cube_a"), cube.t_ns[vis] - T0)
    trans = np.array(data.one("/world/objects/cube_a", "Transform3D:translation"))
    np.testing.assert_allclose(trans, cube.position[vis], atol=1e-6)
    quat = np.array(data.one("/world/objects/cube_a", "Transform3D:quaternion"))
    np.testing.assert_allclose(quat, cube.quaternion[vis], atol=1e-6)
    box = data.static["/world/objects/cube_a/box"]
    assert box["Boxes3D:labels"] == ["cube_a (tag 3)"]
    np.testing.assert_allclose(box["Boxes3D:half_sizes"], [[0.025] * 3], atol=1e-7)

    # world frame, marker, camera
    assert "ViewCoordinates:xyz" in data.static["/world"]
    assert "Boxes3D:labels" in data.static["/world/reference_marker/tag"]
    pinhole = data.static["/world/camera/image"]
    assert pinhole["Pinhole:resolution"] == [[64.0, 48.0]]
    assert demo.camera is not None
    np.testing.assert_allclose(  # rerun stores matrices column-major
        np.reshape(pinhole["Pinhole:image_from_camera"][0], (3, 3)).T, demo.camera.K
    )
    np.testing.assert_allclose(
        data.static["/world/camera"]["Transform3D:translation"], [[0.3, -0.6, 0.5]], atol=1e-6
    )
    assert data.static["/world/camera/image/depth"]["DepthImage:meter"] == [1000.0]
    assert demo.color is not None and demo.depth is not None
    rgb = data.one("/world/camera/image/rgb", "Image:buffer")
    assert len(rgb) == len(demo.color)
    np.testing.assert_array_equal(np.asarray(rgb[2], dtype=np.uint8), demo.color.frames[2].ravel())
    depth = data.one("/world/camera/image/depth", "DepthImage:buffer")
    got = np.asarray(depth[1], dtype=np.uint8).view(np.uint16)
    np.testing.assert_array_equal(got, demo.depth.frames[1].ravel())

    # the default blueprint travels with the data
    assert data.blueprints


def test_colour_images_are_jpeg_by_default(session: viz.Session) -> None:
    demo = make_demo()
    viz.log_demonstration(demo, recording=session.recording)
    data = finish(session)
    assert data.static["/world/camera/image/rgb"]["EncodedImage:media_type"] == ["image/jpeg"]
    blobs = data.one("/world/camera/image/rgb", "EncodedImage:blob")
    assert demo.color is not None and len(blobs) == len(demo.color)
    assert bytes(blobs[0][:2]) == b"\xff\xd8"  # JPEG magic


def test_trajectory_gripper_and_trail(session: viz.Session) -> None:
    from lfd import Trajectory

    n = 30
    t = T0 + np.arange(n, dtype=np.int64) * 100_000_000
    tcp = np.linspace([0.1, 0.2, 0.3], [0.3, 0.2, 0.1], n)
    a = np.linspace(0.0, 1.0, n)
    rot = np.zeros((n, 3, 3))
    rot[:, 0, 0] = rot[:, 1, 1] = np.cos(a)
    rot[:, 1, 0], rot[:, 0, 1], rot[:, 2, 2] = np.sin(a), -np.sin(a), 1.0
    traj = Trajectory(
        t_ns=t,
        tcp=tcp,
        rotation=rot,
        euler=np.zeros((n, 3)),
        opening=np.linspace(0.08, 0.01, n),
        keypoints=np.zeros((n, 21, 3)),
        object_names=[],
        object_position=np.zeros((0, n, 3)),
        object_quaternion=np.zeros((0, n, 4)),
        object_size=np.zeros((0, 3)),
        hand_valid=np.ones(n, bool),
        object_valid=np.zeros((0, n), bool),
    )
    viz.log_demonstration(make_demo(images=False), trajectory=traj, recording=session.recording)
    data = finish(session)
    np.testing.assert_allclose(
        data.one("/world/gripper", "Transform3D:translation"), tcp, atol=1e-6
    )
    np.testing.assert_array_equal(data.times("/world/gripper"), t - T0)
    mats = np.array(data.one("/world/gripper", "Transform3D:mat3x3")).reshape(n, 3, 3)
    np.testing.assert_allclose(mats.transpose(0, 2, 1), rot, atol=1e-6)  # column-major
    trail = data.column("/world/gripper_trail", "LineStrips3D:strips")
    assert len(trail) == n
    assert len(trail[-1][0]) == 21  # 2 s at 10 Hz, plus the current sample
    np.testing.assert_allclose(trail[-1][0][-1], tcp[-1], atol=1e-6)
    np.testing.assert_allclose(
        data.column("/trajectory/opening", "Scalars:scalars"), traj.opening[:, None]
    )


# --- features ---------------------------------------------------------------------------------
def test_features_roundtrip_with_thresholds_and_target(session: viz.Session) -> None:
    names, values, thresholds, t = feature_arrays()
    target = np.r_[np.zeros(25, int), np.ones(15, int)]
    viz.log_feature_arrays(
        names, values, thresholds, t, target=target, object_names=["cube_a", "cube_b"],
        recording=session.recording,
    )  # fmt: skip
    data = finish(session)
    for j, name in enumerate(names):
        ok = np.isfinite(values[:, j])
        got = np.array(data.column(f"/features/{name}/value", "Scalars:scalars"))[:, 0]
        np.testing.assert_array_equal(got, values[ok, j])
        np.testing.assert_array_equal(data.times(f"/features/{name}/value"), t[ok] - T0)
        thr = np.array(data.column(f"/features/{name}/threshold", "Scalars:scalars"))[:, 0]
        np.testing.assert_array_equal(thr, thresholds[:, j])
        frames = [r["frame"] for r in data.entity(f"/features/{name}/threshold")]
        assert frames == list(range(len(t)))
        assert (f"/features/{name}/threshold_neg" in data.rows) == name.startswith("tcp_in_object")
    neg = np.array(data.column("/features/tcp_in_object_y/threshold_neg", "Scalars:scalars"))
    np.testing.assert_array_equal(neg[:, 0], -thresholds[:, 6])
    assert data.static["/features/fingertip_distance/threshold"]["SeriesLines:names"] == [
        "threshold"
    ]
    # target: one state per change
    assert data.column("/features/target", "StateChange:state") == [
        ["target: cube_a"],
        ["target: cube_b"],
    ]
    np.testing.assert_array_equal(data.times("/features/target"), [0, t[25] - T0])


def test_log_features_reads_a_result_object_and_shares_the_origin(session: viz.Session) -> None:
    class Features:
        names, values, thresholds, t_ns = feature_arrays()
        target = np.zeros(40, int)

    rec = session.recording
    viz.set_time_origin(T0 - 1_000_000_000, recording=rec)
    viz.log_features(Features(), recording=rec)
    data = finish(session)
    assert data.times("/features/hand_velocity/value")[0] == 1_000_000_000
    assert data.column("/features/target", "StateChange:state") == [["target: object 0"]]


def test_feature_shapes_are_checked(session: viz.Session) -> None:
    names, values, thresholds, t = feature_arrays()
    rec = session.recording
    with pytest.raises(DemonstrationError, match="shape"):
        viz.log_feature_arrays(names[:3], values, thresholds, t, recording=rec)
    with pytest.raises(DemonstrationError, match="thresholds"):
        viz.log_feature_arrays(names, values, thresholds[:, :3], t, recording=rec)
    with pytest.raises(DemonstrationError, match="integer"):
        viz.log_feature_arrays(names, values, thresholds, t.astype(float), recording=rec)


# --- segmentation -----------------------------------------------------------------------------
def test_segmentation_lanes_sections_scores_warnings(session: viz.Session) -> None:
    t = T0 + np.arange(40, dtype=np.int64) * 200_000_000
    result = [
        SkillLabel("pick_up", t[0], t[12], "cube_a"),
        SkillLabel("place", t[12], t[25], "cube_a"),
        SkillLabel("push", t[30], t[39], None),  # a gap before it
    ]
    truth = [SkillLabel("pick_up", t[0], t[15], "cube_a"), SkillLabel("place", t[15], t[39])]
    viz.log_segmentation(
        result,
        ground_truth=truth,
        baselines={"threshold": truth[:1]},
        boundaries=np.array([5, 12, 20, 25, 30]),
        t_ns=t,
        scores=[{"pick_up": -10.0, "place": -50.0}, {"pick_up": -80.0, "place": -float("inf")}],
        spans=[(int(t[0]), int(t[12])), (int(t[12]), int(t[25]))],
        warnings=["grammar: push without a preceding pick_up", (int(t[30]), "gap of 1 s")],
        recording=session.recording,
    )
    data = finish(session)

    lane = "/segmentation/skills/result"
    assert data.column(lane, "StateChange:state") == [
        ["pick_up(cube_a)"], ["place(cube_a)"], [""], ["push"], [""],
    ]  # fmt: skip
    np.testing.assert_array_equal(data.times(lane), t[[0, 12, 25, 30, 39]] - T0)
    config = data.static[lane]
    assert config["StateConfiguration:values"] == ["pick_up(cube_a)", "place(cube_a)", "push"]
    assert config["StateConfiguration:labels"] == ["pick_up cube_a", "place cube_a", "push"]
    colors = config["StateConfiguration:colors"]
    assert colors[0] != colors[1] != colors[2]
    assert data.column("/segmentation/skills/ground_truth", "StateChange:state")[-1] == [""]
    assert "/segmentation/skills/baseline_threshold" in data.rows

    sections = data.column("/segmentation/sections", "StateChange:state")
    assert sections == [[f"section {i}"] for i in range(6)] + [[""]]
    np.testing.assert_array_equal(
        data.times("/segmentation/sections"), t[[0, 5, 12, 20, 25, 30, 39]] - T0
    )
    assert [r["frame"] for r in data.entity("/segmentation/sections")] == [0, 5, 12, 20, 25, 30, 39]

    scores = data.entity("/segmentation/greedy/scores/pick_up", "greedy_iteration")
    assert [r["greedy_iteration"] for r in scores] == [0, 1]
    assert [r["Scalars:scalars"] for r in scores] == [[-10.0], [-80.0]]
    assert [r["demo_time"] for r in scores] == [t[12] - T0, t[25] - T0]
    place = data.entity("/segmentation/greedy/scores/place", "greedy_iteration")
    assert place[0]["Scalars:scalars"] == [-50.0]
    assert np.isnan(place[1]["Scalars:scalars"][0])  # -inf shown as a gap

    warnings = data.entity("/segmentation/warnings")
    assert [r["TextLog:text"][0] for r in warnings] == [
        "grammar: push without a preceding pick_up",
        "gap of 1 s",
    ]
    assert {r["TextLog:level"][0] for r in warnings} == {"WARN"}
    assert warnings[1]["demo_time"] == t[30] - T0


def test_greedy_candidate_series(session: viz.Session) -> None:
    ends = T0 + np.array([1, 2, 3], dtype=np.int64) * 1_000_000_000
    viz.log_greedy_scores(
        [{"pick_up": [-3.0, -2.0, -1.0], "stack": [-9.0, -8.0, -7.0]}],
        candidate_end_ns=[ends],
        recording=session.recording,
        origin_ns=T0,
    )
    data = finish(session)
    assert data.column("/segmentation/greedy/iteration_0/stack", "Scalars:scalars") == [
        [-9.0], [-8.0], [-7.0],
    ]  # fmt: skip
    np.testing.assert_array_equal(data.times("/segmentation/greedy/iteration_0/stack"), ends - T0)


def test_segmentation_inputs_are_checked(session: viz.Session) -> None:
    t = T0 + np.arange(10, dtype=np.int64)
    rec = session.recording
    with pytest.raises(DemonstrationError, match="lie in"):
        viz.log_sections([3, 11], t, recording=rec)
    with pytest.raises(DemonstrationError, match="sample indices"):
        viz.log_sections([1.5], t, recording=rec)
    with pytest.raises(DemonstrationError, match="need the sample times"):
        viz.log_segmentation(boundaries=[1, 2], recording=rec)
    with pytest.raises(DemonstrationError, match="spans"):
        viz.log_greedy_scores([{"place": 1.0}], spans=[], recording=rec)


# --- robot ------------------------------------------------------------------------------------
def test_robot_paths(session: viz.Session) -> None:
    n = 20
    planned = np.linspace([0.3, 0.0, 0.2], [0.5, 0.1, 0.1], n)
    executed = planned + np.array([0.0, 0.0, 0.002])
    t = 5_000_000_000 + np.arange(n, dtype=np.int64) * 10_000_000
    links = np.stack([np.zeros((n, 3)), 0.5 * executed, executed], axis=1)
    viz.log_robot_paths(
        planned, executed, t_ns=t, planned_t_ns=t, mode="dmp", link_positions=links,
        opening=np.full(n, 0.04), base_pose=np.eye(4), recording=session.recording,
    )  # fmt: skip
    data = finish(session)
    np.testing.assert_allclose(
        data.static["/world/robot/dmp/planned"]["LineStrips3D:strips"][0], planned, atol=1e-6
    )
    np.testing.assert_allclose(
        data.static["/world/robot/dmp/executed"]["LineStrips3D:strips"][0], executed, atol=1e-6
    )
    rows = data.entity("/robot/dmp/tcp_error", "robot_time")
    assert rows[0]["robot_time"] == 0 and rows[-1]["robot_time"] == t[-1] - t[0]
    assert "demo_time" not in rows[0]
    np.testing.assert_allclose([r["Scalars:scalars"][0] for r in rows], 0.002, atol=1e-9)
    arm = data.column("/world/robot/dmp/arm", "LineStrips3D:strips", "robot_time")
    assert len(arm) == n and len(arm[0][0]) == 3
    with pytest.raises(DemonstrationError, match=r"\(n, 3\)"):
        viz.log_robot_paths(np.zeros((4, 2)), recording=session.recording)


# --- sessions and the command line ------------------------------------------------------------
def test_no_recording_is_a_clear_error(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(rr, "get_data_recording", lambda *a, **k: None)
    with pytest.raises(LfdError, match=r"lfd\.viz\.init"):
        viz.log_skill_spans([SkillLabel("place", 0, 1)])


def test_telemetry_is_off_unless_the_user_set_it(monkeypatch: pytest.MonkeyPatch) -> None:
    """lfd turns Rerun's telemetry off by default and keeps a value the user chose (conftest
    sets RERUN_TELEMETRY for the whole session, so it is removed here first)."""
    monkeypatch.delenv("RERUN_TELEMETRY", raising=False)
    viz.import_rerun()
    assert os.environ["RERUN_TELEMETRY"] == "0"
    monkeypatch.setenv("RERUN_TELEMETRY", "1")
    viz.import_rerun()
    assert os.environ["RERUN_TELEMETRY"] == "1"


def test_cli_flags_save_and_stream(tmp_path: Path) -> None:
    from lfd.cli import _rerun

    parser = argparse.ArgumentParser()
    _rerun.add_rerun_arguments(parser)
    args = parser.parse_args([])
    assert _rerun.open_from_args(args, "lfd_test") is False
    _rerun.close_from_args(args)  # no-op

    out = tmp_path / "sub" / "cli.rrd"
    args = parser.parse_args(["--rerun-save", str(out)])
    assert _rerun.open_from_args(args, "lfd_test") is True
    viz.log_skill_spans([SkillLabel("stack", T0, T0 + 10)], origin_ns=T0)  # the default recording
    _rerun.close_from_args(args)
    assert rr.get_global_data_recording() is None  # closed: no longer the default
    data = Rrd(out)
    assert data.column("/segmentation/skills/result", "StateChange:state") == [["stack"], [""]]
    assert data.blueprints


def test_rerun_without_display_serves_the_web_viewer(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr("sys.platform", "linux")
    from lfd.cli import _rerun

    parser = argparse.ArgumentParser()
    _rerun.add_rerun_arguments(parser)
    args = parser.parse_args(["--rerun"])
    web = free_port()
    assert _rerun.open_from_args(args, "lfd_test", grpc_port=free_port(), web_port=web)
    err = capsys.readouterr().err
    assert "no display" in err and f"http://127.0.0.1:{web}/?url=rerun" in err
    with urllib.request.urlopen(f"http://127.0.0.1:{web}/", timeout=10) as resp:
        assert resp.status == 200
    _rerun.close_from_args(args, wait_serving=False)


def _listening(port: int) -> list[str]:
    """Local addresses something listens on at TCP ``port`` (from /proc/net/tcp*)."""
    import ipaddress

    found = []
    for name, size in (("/proc/net/tcp", 4), ("/proc/net/tcp6", 16)):
        try:
            lines = Path(name).read_text().splitlines()[1:]
        except OSError:
            continue
        for line in lines:
            local, state = line.split()[1], line.split()[3]
            addr, hexport = local.split(":")
            if state != "0A" or int(hexport, 16) != port:  # 0A: LISTEN
                continue
            raw = bytes.fromhex(addr)
            # the kernel prints each 32-bit word in host (little-endian) order
            raw = b"".join(raw[i : i + 4][::-1] for i in range(0, size, 4))
            found.append(str(ipaddress.ip_address(raw)))
    return found


@pytest.mark.skipif(not Path("/proc/net/tcp").exists(), reason="needs Linux /proc/net/tcp")
def test_served_viewer_listens_on_localhost_unless_asked() -> None:
    """--rerun-serve binds the web viewer and its gRPC server to 127.0.0.1 by default, the
    address --rerun-bind gives otherwise; closing the session stops both."""
    import socket

    from lfd.cli import _rerun

    parser = argparse.ArgumentParser()
    _rerun.add_rerun_arguments(parser)
    for argv, want in (([], "127.0.0.1"), (["--rerun-bind", "0.0.0.0"], "0.0.0.0")):
        args = parser.parse_args(["--rerun-serve", *argv])
        _rerun.check_rerun_args(args)
        grpc, web = free_port(), free_port()
        assert _rerun.open_from_args(args, "lfd_test", grpc_port=grpc, web_port=web)
        session = _rerun.session_from_args(args)
        assert session is not None and session.serve_url is not None
        try:
            assert _listening(web) == [want] and _listening(grpc) == [want]
            if want == "127.0.0.1":  # another address of this machine is refused
                host_ip = socket.gethostbyname(socket.gethostname())
                if not host_ip.startswith("127."):
                    with socket.socket() as s:
                        s.settimeout(2)
                        assert s.connect_ex((host_ip, web)) != 0
        finally:
            _rerun.close_from_args(args, wait_serving=False)
        assert _listening(web) == [] and _listening(grpc) == []


@pytest.mark.slow  # the default run stays under 5 minutes; covered there by faster tests
def test_rerun_serve_for_keeps_serving_then_exits(tmp_path: Path) -> None:
    """Without a terminal, --rerun-serve-for N keeps the viewer served N seconds after the
    work, then the command exits and the server is gone."""
    import subprocess
    import sys
    import time

    grpc, web = free_port(), free_port()
    code = (
        "import argparse, sys; from lfd.cli import _rerun; from lfd import viz;"
        "p = argparse.ArgumentParser(); _rerun.add_rerun_arguments(p);"
        "a = p.parse_args(sys.argv[1:]);"
        f"_rerun.open_from_args(a, 'lfd_test', grpc_port={grpc}, web_port={web});"
        "print('served', flush=True); _rerun.close_from_args(a)"
    )
    t0 = time.monotonic()
    proc = subprocess.Popen(
        [sys.executable, "-c", code, "--rerun-serve-for", "2"],
        stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    assert proc.stdout is not None and proc.stdout.readline().strip() == "served"
    time.sleep(1.0)
    with urllib.request.urlopen(f"http://127.0.0.1:{web}/", timeout=10) as resp:
        assert resp.status == 200  # still serving after the work is done
    # read the rest through the same file object: readline() may already have buffered the
    # next line, which communicate() (reading the raw pipe) would never see
    out = proc.stdout.read()
    assert proc.stderr is not None
    err = proc.stderr.read()
    proc.stdout.close()  # unclosed pipes are a ResourceWarning
    proc.stderr.close()
    proc.wait(timeout=30)
    took = time.monotonic() - t0
    assert proc.returncode == 0, err
    assert "serving until 2 s" in out and 2.0 <= took < 15.0
    assert _listening(web) == []

    # inf: until SIGTERM
    proc = subprocess.Popen(
        [sys.executable, "-c", code, "--rerun-serve-for", "inf"],
        stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    assert proc.stdout is not None and proc.stdout.readline().strip() == "served"
    time.sleep(1.5)
    assert proc.poll() is None
    proc.terminate()
    out, err = proc.communicate(timeout=30)
    assert proc.returncode == 0, err
    assert _listening(web) == []


def test_viewer_url_check_takes_plain_values() -> None:
    """The library checks a URL without argparse; the message names what the caller passes."""
    from lfd.errors import UsageError
    from lfd.viz.session import check_viewer_url

    check_viewer_url("rerun+http://127.0.0.1:9876/proxy")
    check_viewer_url("rerun://example.org:1/proxy/")
    for bad in ("http://127.0.0.1:9876/proxy", "rerun+http://h:1/other", "rerun+http:///proxy"):
        with pytest.raises(UsageError, match=r"^url .* is not a viewer URL"):
            check_viewer_url(bad, what="url")
    with pytest.raises(UsageError, match="Port out of range"):
        check_viewer_url("rerun+http://h:99999/proxy")


def test_library_has_no_argparse() -> None:
    """Command-line parsing lives in lfd.cli only: no other module of lfd imports argparse."""
    root = Path(viz.__file__).parents[1]
    users = sorted(
        str(p.relative_to(root))
        for p in root.rglob("*.py")
        if p.relative_to(root).parts[0] != "cli" and "argparse" in p.read_text()
    )
    assert users == []


# --- the viewer (opt-in) ----------------------------------------------------------------------
def _viewer_opted_in(config: pytest.Config) -> bool:
    expr = str(config.getoption("markexpr") or "")
    return os.environ.get("LFD_TEST_VIEWER") == "1" or ("viewer" in expr and "not" not in expr)


@pytest.mark.viewer
def test_headless_viewer_screenshot_is_not_blank(
    session: viz.Session, tmp_path: Path, request: pytest.FixtureRequest
) -> None:
    if not _viewer_opted_in(request.config):
        pytest.skip("opt-in: run with -m viewer or LFD_TEST_VIEWER=1")
    from lfd.viz.screenshot import screenshot
    from PIL import Image

    demo = make_demo()
    viz.log_demonstration(demo, recording=session.recording)
    viz.log_segmentation(demo.labels, ground_truth=demo.labels, recording=session.recording)
    assert session.save_path is not None
    session.close()
    png = tmp_path / "shot.png"
    try:
        screenshot(session.save_path, png)
    except Exception as err:  # no graphics adapter, viewer crashed, ...
        pytest.skip(f"the headless viewer cannot start here: {err}")
    with Image.open(png) as img:
        pixels = np.asarray(img.convert("RGB"), dtype=np.float64)
    assert pixels.shape[0] > 100 and pixels.shape[1] > 100
    assert pixels.std() > 10.0
    assert len(np.unique(pixels.reshape(-1, 3), axis=0)) > 50


# --- whole runs: preprocess -> features -> sections -> greedy trace -> skills -------------------
def test_greedy_trace_matches_the_score_table() -> None:
    from lfd.viz.pipeline import greedy_trace

    bounds = [0, 10, 30, 40]  # K = 3 sections
    table = np.full((3, 4, 2), -np.inf)
    for i in range(3):
        for j in range(i + 1, 4):
            table[i, j] = [-(bounds[j] - bounds[i]) * (1 + i + j), -2.0 * (bounds[j] - bounds[i])]
    scores, ends = greedy_trace(table, bounds, [0, 30], ["pick_up", "place"])
    assert len(scores) == 2
    np.testing.assert_array_equal(ends[0], [10, 30, 40])
    np.testing.assert_allclose(scores[0]["pick_up"], [-2.0, -3.0, -4.0])  # mean per sample
    np.testing.assert_allclose(scores[0]["place"], [-2.0, -2.0, -2.0])
    np.testing.assert_array_equal(ends[1], [40])
    np.testing.assert_allclose(scores[1]["pick_up"], [-6.0])
    with pytest.raises(ValueError, match="does not match"):
        greedy_trace(table[:, :3], bounds, [0], ["pick_up", "place"])


def test_log_segment_run_on_a_preprocessed_demo(session: viz.Session) -> None:
    from types import SimpleNamespace

    from _synthetic import make_demo as synthetic_demo
    from lfd.features import compute_features
    from lfd.preprocessing import preprocess
    from lfd.segmentation import Run, Segment, Segmentation
    from lfd.viz.pipeline import log_recorded_demo, log_segment_run

    demo = synthetic_demo(duration_s=6.0)
    demo.labels = [SkillLabel("pick_up", demo.start_ns, demo.start_ns + 3_000_000_000, "cube0")]
    traj = preprocess(demo)
    n = len(traj)
    bounds = [0, n // 3, 2 * n // 3, n]
    table = np.zeros((3, 4, 2))
    table[0, :, 0] = [
        0.0,
        -1.0 * bounds[1],
        -5.0 * bounds[2],
        -9.0 * n,
    ]  # pick_up best at 1 section

    method = SimpleNamespace(templates=SimpleNamespace(skills=["pick_up", "place"]))

    def seg(skill: str, a: int, b: int) -> Segment:
        t_end = int(traj.t_ns[min(b, n - 1)])
        return Segment(skill, a, b, 0.0, 0.0, int(traj.t_ns[a]), t_end, "cube0", -1.0, 2.0)

    result = Segmentation(
        [seg("pick_up", 0, bounds[1]), seg("place", bounds[1], n)],
        warnings=["impossible skill transition place -> place"],
        sections=bounds,
        object_names=list(traj.object_names),
        method="greedy",
        run=Run(traj, compute_features(traj), [], table, method),  # type: ignore[arg-type]
    )
    rec = session.recording
    assert log_recorded_demo(demo, trajectory=False, recording=rec) is None
    log_segment_run(demo, result, ground_truth=False, recording=rec)
    data = finish(session)

    assert data.column("/segmentation/skills/ground_truth", "StateChange:state")[0] == [
        "pick_up(cube0)"
    ]
    assert data.column("/segmentation/skills/result", "StateChange:state") == [
        ["pick_up(cube0)"], ["place(cube0)"], [""],
    ]  # fmt: skip
    assert [r["frame"] for r in data.entity("/segmentation/sections")] == [
        0,
        n // 3,
        2 * n // 3,
        n - 1,
    ]
    it0 = data.entity("/segmentation/greedy/iteration_0/pick_up")
    np.testing.assert_allclose([r["Scalars:scalars"][0] for r in it0], [-1.0, -5.0, -9.0])
    assert [r["demo_time"] for r in it0] == [
        int(traj.t_ns[bounds[1]] - demo.start_ns),
        int(traj.t_ns[bounds[2]] - demo.start_ns),
        int(traj.t_ns[-1] - demo.start_ns),
    ]
    chosen = data.entity("/segmentation/greedy/chosen")
    assert [r["Scalars:scalars"][0] for r in chosen] == [-1.0, -1.0]
    assert chosen[0]["demo_time"] == it0[0]["demo_time"]  # the cut sits on its candidate line
    it1 = data.entity("/segmentation/greedy/iteration_1/place")
    assert len(it1) == 2  # candidates: sections 1..2 and 1..3
    assert len(data.entity("/features/hand_velocity/value")) == n
    log = [r["TextLog:text"][0] for r in data.entity("/segmentation/log")]
    assert log[0].startswith("0: pick_up(cube0)")
    warn = [r["TextLog:text"][0] for r in data.entity("/segmentation/warnings")]
    assert "impossible skill transition place -> place" in warn
    assert len(data.entity("/world/gripper")) > 0


def test_the_viewer_shows_the_trajectory_that_was_segmented(tmp_path: Path) -> None:
    """`lfd segment --rerun-save` logs the gripper of the run it segmented: on exp1 the default
    preprocessing differs from the templates' by centimetres (issue 28), the logged one by 0."""
    import lfd
    from lfd.cli import main
    from lfd.preprocessing import preprocess

    rrd = tmp_path / "seg.rrd"
    assert main(["segment", str(EXP1), "--rerun-save", str(rrd)]) == 0
    data = Rrd(rrd)
    logged = np.array(data.column("/world/gripper", "Transform3D:translation"), dtype=np.float64)
    frames = [r["frame"] for r in data.entity("/world/gripper") if r.get("Transform3D:translation")]
    demo = lfd.load(EXP1)
    run = lfd.segment(demo).run
    assert run is not None
    segmented = run.trajectory.tcp[frames]
    assert len(logged) == len(run.trajectory)
    np.testing.assert_allclose(logged.reshape(-1, 3), segmented, atol=1e-6)
    plain = preprocess(demo).tcp  # what the viewer used to show
    m = min(len(plain), len(run.trajectory))
    assert np.nanmax(np.linalg.norm(plain[:m] - run.trajectory.tcp[:m], axis=1)) > 0.01
    features = data.entity("/features/hand_velocity/value")
    np.testing.assert_allclose(
        [r["Scalars:scalars"][0] for r in features],
        run.features.column("hand_velocity")[[r["frame"] for r in features]],
        atol=1e-6,
    )


def test_lfd_simulate_rerun_save(tmp_path: Path) -> None:
    pytest.importorskip("mujoco")
    from lfd.cli import main

    out = tmp_path / "sim.rrd"
    code = main(
        ["simulate", "pick_up", "--seed", "1", "--duration", "3", "-o", str(tmp_path / "d.mcap"),
         "--rerun-save", str(out)]
    )  # fmt: skip
    assert code == 0
    data = Rrd(out)
    assert len(data.entity("/world/hand/keypoints")) >= 10
    assert "/world/gripper" in data.rows and "/features/hand_velocity/value" in data.rows
    assert data.column("/segmentation/skills/ground_truth", "StateChange:state")[0][0].startswith(
        "pick_up"
    )


SHIPPED = _paths.RECORDINGS / "rendered" / "exp1_short.mcap"


@pytest.mark.skipif(not SHIPPED.exists(), reason="shipped recording not present")
def test_shipped_recording_roundtrip(session: viz.Session) -> None:
    from lfd.io import load
    from lfd.viz.pipeline import log_recorded_demo

    demo = load(SHIPPED)
    traj = log_recorded_demo(demo, recording=session.recording, jpeg_quality=None)
    assert traj is not None
    data = finish(session)
    rows = data.entity("/world/hand/keypoints")
    assert len(rows) == len(demo.hand)
    np.testing.assert_array_equal(
        data.times("/world/hand/keypoints"), demo.hand.t_ns - demo.start_ns
    )
    for i in (0, len(rows) // 2, len(rows) - 1):
        ok = np.all(np.isfinite(demo.hand.keypoints[i]), axis=1)
        got = np.array(rows[i]["Points3D:positions"])
        np.testing.assert_allclose(got, demo.hand.keypoints[i][ok], atol=1e-6)
    for name, obj in demo.objects.items():
        vis = np.flatnonzero(obj.visible & np.all(np.isfinite(obj.position), axis=1))
        trans = np.array(data.one(f"/world/objects/{name}", "Transform3D:translation"))
        np.testing.assert_allclose(trans, obj.position[vis], atol=1e-6)
    assert demo.color is not None and demo.depth is not None
    assert len(data.entity("/world/camera/image/rgb")) == len(demo.color)
    assert len(data.entity("/world/camera/image/depth")) == len(demo.depth)
    truth = data.column("/segmentation/skills/ground_truth", "StateChange:state")
    assert [s[0].split("(")[0] for s in truth if s[0]] == demo.skill_sequence
    assert len(data.entity("/features/fingertip_distance/value")) == len(traj)


def test_log_reproduction_reads_a_result(session: viz.Session) -> None:
    from types import SimpleNamespace

    n = 50
    planned = np.linspace([0.3, 0.0, 0.2], [0.5, 0.1, 0.1], n)
    result = SimpleNamespace(
        mode="skills",
        planned_tcp=planned,
        executed_tcp=planned + np.array([0.001, 0.0, 0.0]),
        segment=np.r_[np.full(10, -1), np.zeros(20, int), np.ones(20, int)],
        base=np.array([0.0, -0.4, 0.0]),
        objects=[SimpleNamespace(name="box_1", success=True, position_error=0.004, rotation_error_deg=1.5)],
        execution=SimpleNamespace(
            object_names=["box_1"],
            object_position=np.linspace([0.4, 0.0, 0.025], [0.5, 0.1, 0.025], n)[None],
            object_quaternion=np.tile([0.0, 0.0, 0.0, 1.0], (1, n, 1)),
        ),
    )  # fmt: skip
    viz.log_reproduction(
        result, skills=["pick_up", "place"], object_sizes={"box_1": [0.04, 0.04, 0.05]},
        recording=session.recording,
    )  # fmt: skip
    data = finish(session)
    assert data.column("/robot/skills/segment", "StateChange:state", "robot_time") == [
        [""], ["pick_up"], ["place"],
    ]  # fmt: skip
    assert list(data.times("/robot/skills/segment", "robot_time")) == [0, 100_000_000, 300_000_000]
    err = [r["Scalars:scalars"][0] for r in data.entity("/robot/skills/tcp_error", "robot_time")]
    np.testing.assert_allclose(err, 0.001, atol=1e-9)
    np.testing.assert_allclose(
        data.static["/world/robot/base"]["Transform3D:translation"], [[0.0, -0.4, 0.0]], atol=1e-7
    )
    box = data.one("/world/robot_objects/skills/box_1", "Transform3D:translation", "robot_time")
    np.testing.assert_allclose(box[-1], [0.5, 0.1, 0.025], atol=1e-6)
    half = data.static["/world/robot_objects/skills/box_1/box"]["Boxes3D:half_sizes"]
    np.testing.assert_allclose(half, [[0.02, 0.02, 0.025]], atol=1e-7)
    text = data.entity("/robot/skills/objects", "robot_time")[0]["TextLog:text"][0]
    assert text == "box_1: ok, 4.0 mm, 1.5 deg"
    assert "/robot/skills/failures" not in data.rows  # nothing failed


def test_log_reproduction_marks_failed_skills_on_the_timeline(session: viz.Session) -> None:
    from types import SimpleNamespace

    from lfd.reproduce import SkillResult

    n = 50
    planned = np.linspace([0.3, 0.0, 0.2], [0.5, 0.1, 0.1], n)
    result = SimpleNamespace(
        mode="dmp",
        planned_tcp=planned,
        executed_tcp=planned,
        segment=np.r_[np.full(10, -1), np.zeros(20, int), np.ones(20, int)],
        skills=[
            SkillResult(0, "pick_up", "box_1"),
            SkillResult(1, "place", "box_1", ["place box_1 off target by 12 mm"]),
        ],
    )
    viz.log_reproduction(result, skills=["pick_up", "place"], recording=session.recording)
    data = finish(session)
    rows = data.entity("/robot/dmp/failures", "robot_time")
    assert [r["TextLog:text"][0] for r in rows] == [
        "FAILED 1 place box_1: place box_1 off target by 12 mm"
    ]
    assert list(data.times("/robot/dmp/failures", "robot_time")) == [490_000_000]  # its last tick


@pytest.mark.viewer
def test_live_stream_reaches_a_running_viewer(request: pytest.FixtureRequest) -> None:
    """--rerun-connect: data logged while the run goes arrives in a (headless) native viewer."""
    import time

    if not _viewer_opted_in(request.config):
        pytest.skip("opt-in: run with -m viewer or LFD_TEST_VIEWER=1")
    port = free_port()
    try:
        viewer = rr.experimental.ViewerClient.spawn(headless=True, port=port)
    except Exception as err:
        pytest.skip(f"the headless viewer cannot start here: {err}")
    try:
        session = viz.open_session(
            "lfd_live", connect=f"rerun+http://127.0.0.1:{port}/proxy", make_default=False
        )
        viz.log_demonstration(make_demo(images=False), recording=session.recording)
        session.flush()
        deadline = time.monotonic() + 20
        timelines: set[str] = set()
        while time.monotonic() < deadline and "demo_time" not in timelines:
            time.sleep(0.3)
            state = viewer.get_state()
            timelines = {t.name for r in state.recordings for t in r.timelines}
        assert "demo_time" in timelines
        time.sleep(1.0)  # let the default blueprint lay the views out
        views = viewer.get_state().views
        names = {v.name for v in views}
        assert {"Scene (reference marker frame)", "HMM scores", "Reproduction 3-D"} <= names
        errors = [(v.name, r.summary) for v in views for r in v.reports if r.severity == "error"]
        assert not errors
        session.close()
    finally:
        viewer.quit()


RECORDINGS = _paths.RECORDINGS


@pytest.fixture(scope="module")
def small_templates(tmp_path_factory: pytest.TempPathFactory) -> list[str]:
    """``--templates`` arguments: none with shipped templates, else a quickly trained set."""
    import shutil

    from lfd.cli import main
    from lfd.segmentation import Templates

    try:
        Templates.default()
        return []
    except (FileNotFoundError, LfdError):  # not shipped (yet)
        pass
    src = sorted((RECORDINGS / "templates").glob("*_[012].mcap"))
    if not src:
        pytest.skip("shipped template recordings not present")
    d = tmp_path_factory.mktemp("templates")
    for p in src:
        shutil.copy(p, d)
    out = d / "templates.json"
    assert main(["templates", "train", str(d), "-o", str(out)]) == 0
    return ["--templates", str(out)]


def test_lfd_segment_and_eval_rerun_save(small_templates: list[str], tmp_path: Path) -> None:
    from lfd.cli import main

    rec = RECORDINGS / "exp1.mcap"
    seg = tmp_path / "segment.rrd"
    assert main(["segment", str(rec), *small_templates, "--rerun-save", str(seg)]) == 0
    data = Rrd(seg)
    for path in ("/segmentation/skills/result", "/segmentation/skills/ground_truth",
                 "/segmentation/sections",
                 "/features/object_height/threshold", "/world/hand/keypoints", "/world/gripper"):  # fmt: skip
        assert path in data.rows, path
    assert data.blueprints
    # the paper's greedy loop also shows its iterations
    paper = tmp_path / "paper.rrd"
    args = ["segment", str(rec), *small_templates, "--paper", "--rerun-save", str(paper)]
    assert main(args) == 0
    rows = Rrd(paper).rows
    assert "/segmentation/greedy/chosen" in rows
    assert any(k.startswith("/segmentation/greedy/iteration_") for k in rows)

    ev = tmp_path / "eval.rrd"
    args = ["eval", str(rec), *small_templates, "--rerun-save", str(ev)]
    assert main(args) == 0
    lanes = {k for k in Rrd(ev).rows if k.startswith("/segmentation/skills/")}
    assert lanes == {
        "/segmentation/skills/result",  # dp, the default, in full
        "/segmentation/skills/paper",
        "/segmentation/skills/ground_truth",
        "/segmentation/skills/baseline_changepoint",
        "/segmentation/skills/baseline_proximity",
        "/segmentation/skills/baseline_gripper",
    }


def test_serving_on_a_busy_port_is_a_clear_error() -> None:
    import socket

    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        with pytest.raises(LfdError, match=f"port {port} is in use"):
            viz.open_session("lfd_test", serve=True, grpc_port=port, web_port=free_port())


def test_object_names_are_escaped_in_entity_paths(session: viz.Session) -> None:
    demo = make_demo(images=False)
    cube = demo.objects.pop("cube_a")
    cube.name = "red box/1"
    demo.objects["red box/1"] = cube
    viz.log_demonstration(demo, recording=session.recording)
    data = finish(session)
    boxes = [k for k in data.static if k.endswith("/box") and k.startswith("/world/objects/")]
    assert len(boxes) == 1
    assert data.static[boxes[0]]["Boxes3D:labels"] == ["red box/1 (tag 3)"]
    assert boxes == ["/world/objects/red\\ box\\/1/box"]  # the slash does not make a child
