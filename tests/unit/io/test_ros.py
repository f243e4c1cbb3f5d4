"""ROS 1 and ROS 2 bags (lfd.io.ros): bags written with ``rosbags`` itself from
recordings/exp1.mcap (tests/_rosbags.py) read back through a topic mapping, segment to the same
skills as exp1, import to an lfd recording; bad mappings are one clear error."""

from __future__ import annotations

import json
import subprocess
import sys
import warnings
from pathlib import Path

import _paths
import lfd
import numpy as np
import pytest
from lfd.errors import UsageError

pytest.importorskip("rosbags")

from _rosbags import write_ros1, write_ros2
from lfd.io.ros import RosMapping, load_ros, read_mapping

ROOT = _paths.ROOT
EXP1 = ROOT / "recordings" / "exp1.mcap"
KINDS = ("ros1", "ros2-sqlite3", "ros2-mcap")


@pytest.fixture(scope="module")
def exp1() -> lfd.Demonstration:
    return lfd.load(EXP1, images=False)


@pytest.fixture(scope="module")
def bags(
    exp1: lfd.Demonstration, tmp_path_factory: pytest.TempPathFactory
) -> dict[str, tuple[Path, Path]]:
    """kind -> (bag path, mapping file)."""
    d = tmp_path_factory.mktemp("bags")
    out = {}
    for kind in KINDS:
        bag = d / ("exp1.bag" if kind == "ros1" else kind)
        if kind == "ros1":
            text = write_ros1(exp1, bag)
        else:
            text = write_ros2(exp1, bag, kind.split("-")[1])
        (d / f"{kind}.toml").write_text(text, encoding="utf-8")
        out[kind] = (bag, d / f"{kind}.toml")
    return out


def _skills(seg: lfd.Segmentation) -> list[tuple[str, str | None, float, float]]:
    return [(s.skill, s.object, round(s.start_s, 6), round(s.end_s, 6)) for s in seg.segments]


@pytest.mark.parametrize("kind", KINDS)
def test_bag_reads_back_exp1_and_segments_the_same(kind: str, bags, exp1) -> None:
    bag, mapping = bags[kind]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        demo = lfd.load(bag, mapping=mapping)
    # the tf chain (ros1: static world->camera, dynamic camera->box), the units (sqlite3: mm)
    # and the keypoint order (mcap: reversed) come back to exp1's values
    np.testing.assert_array_equal(demo.hand.t_ns, exp1.hand.t_ns)
    np.testing.assert_allclose(demo.hand.keypoints, exp1.hand.keypoints, atol=1e-9)
    assert demo.objects.keys() == exp1.objects.keys()
    for name, o in exp1.objects.items():
        got = demo.objects[name]
        np.testing.assert_array_equal(got.t_ns, o.t_ns)
        np.testing.assert_allclose(got.position, o.position, atol=1e-9)
        same_sign = np.sign(np.sum(got.quaternion * o.quaternion, axis=1))[:, None]
        np.testing.assert_allclose(got.quaternion * same_sign, o.quaternion, atol=1e-9)
        np.testing.assert_array_equal(got.size, o.size)
    assert demo.metadata["source"] == "ros"
    # the target: the same skills as the demonstration in lfd's own layout
    assert _skills(lfd.segment(demo)) == _skills(lfd.segment(exp1))


def test_ros2_files_inside_the_bag_directory(bags, exp1) -> None:
    """The .db3 of a sqlite3 bag, and the lone .mcap of an mcap bag (read without
    metadata.yaml: its channels are cdr)."""
    for kind, suffix in (("ros2-sqlite3", "*.db3"), ("ros2-mcap", "*.mcap")):
        bag, mapping = bags[kind]
        (inner,) = bag.glob(suffix)
        demo = lfd.load(inner, mapping=mapping)
        np.testing.assert_allclose(demo.hand.keypoints, exp1.hand.keypoints, atol=1e-9)
    assert lfd.load(inner, mapping=mapping).metadata["ros"]["format"] == "ROS 2 MCAP file"


def test_import_writes_an_lfd_recording(bags, exp1, tmp_path: Path) -> None:
    bag, mapping = bags["ros1"]
    out = tmp_path / "imported.mcap"
    proc = subprocess.run(
        [sys.executable, "-m", "lfd.cli", "import", "ros", str(bag), "--map", str(mapping),
         "-o", str(out)],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    back = lfd.load(out)  # an lfd recording now: no mapping
    np.testing.assert_allclose(back.hand.keypoints, exp1.hand.keypoints, atol=1e-9)
    assert {n: o.size.tolist() for n, o in back.objects.items()} == {
        n: o.size.tolist() for n, o in exp1.objects.items()
    }
    assert back.metadata["ros"]["format"] == "ROS 1 bag"
    seg = subprocess.run(
        [sys.executable, "-m", "lfd.cli", "segment", str(bag), "--map", str(mapping),
         "--json", "-"],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert seg.returncode == 0, seg.stderr
    doc = json.loads(seg.stdout)
    assert [s["skill"] for s in doc["segments"]] == lfd.segment(exp1).skill_sequence


def test_hand_from_tf_frames_and_sizes(bags, exp1, tmp_path: Path) -> None:
    """The hand as 21 tf frames; an object without a size in the mapping gets the default
    cube (warned), --object-size (object_sizes) wins over the mapping."""
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    T = store.types
    hand = exp1.hand
    keep = np.isfinite(hand.keypoints).all(axis=(1, 2))
    box = exp1.objects["box_2"]

    def tf(t: int, parent: str, child: str, p: np.ndarray, q=(0.0, 0.0, 0.0, 1.0)):
        stamp = T["builtin_interfaces/msg/Time"](sec=t // 10**9, nanosec=t % 10**9)
        return T["geometry_msgs/msg/TransformStamped"](
            header=T["std_msgs/msg/Header"](stamp=stamp, frame_id=parent),
            child_frame_id=child,
            transform=T["geometry_msgs/msg/Transform"](
                translation=T["geometry_msgs/msg/Vector3"](x=p[0], y=p[1], z=p[2]),
                rotation=T["geometry_msgs/msg/Quaternion"](x=q[0], y=q[1], z=q[2], w=q[3]),
            ),
        )

    msgs = []
    for t, kp in zip(hand.t_ns[keep], hand.keypoints[keep], strict=True):
        msgs.append((int(t), [tf(int(t), "world", f"kp{k}", kp[k]) for k in range(21)]))
    for t, p, q in zip(box.t_ns, box.position, box.quaternion, strict=True):
        msgs.append((int(t), [tf(int(t), "world", "/box", p, q)]))  # a ROS 1 style leading /
    path = tmp_path / "tfhand"
    with Writer(path, version=9) as w:
        c = w.add_connection("/tf", "tf2_msgs/msg/TFMessage", typestore=store)
        for t, trs in sorted(msgs, key=lambda m: m[0]):
            w.write(c, t, store.serialize_cdr(T["tf2_msgs/msg/TFMessage"](transforms=trs),
                                              "tf2_msgs/msg/TFMessage"))  # fmt: skip
    mapping = {
        "hand": {"frames": [f"kp{k}" for k in range(21)]},
        "objects": {"box_2": {"frame": "box"}},
    }  # a dict with the TOML file's keys
    with pytest.warns(lfd.errors.DefaultSizeWarning, match="box_2 has no size"):
        demo = load_ros(path, mapping)
    np.testing.assert_allclose(demo.hand.keypoints, hand.keypoints[keep], atol=1e-12)
    np.testing.assert_allclose(demo.objects["box_2"].position, box.position, atol=1e-12)
    assert demo.objects["box_2"].size.tolist() == [0.05, 0.05, 0.05]
    demo = lfd.load(path, mapping=mapping, object_sizes={"box_2": (0.06, 0.04, 0.04)})
    assert demo.objects["box_2"].size.tolist() == [0.06, 0.04, 0.04]


def test_read_mapping(tmp_path: Path, bags) -> None:
    m = read_mapping(bags["ros2-mcap"][1])
    assert isinstance(m, RosMapping)
    assert m.hand.order == tuple(range(20, -1, -1))
    assert [o.name for o in m.objects] == ["box_1", "box_2", "box_3"]
    assert m.objects[1].size == (0.06, 0.04, 0.04)


@pytest.mark.parametrize(
    ("edit", "match"),
    [
        (lambda t: t.replace("/hand/keypoints", "/hand/kp"),
         r"names topics .* does not have: /hand/kp \(hand\); the bag has: /hand/keypoints"),
        (lambda t: t.replace('frame = "box_2"', 'frame = "box_9"'),
         "tf frame 'box_9'.*tf frames in .*: box_1, box_2, box_3, camera, world"),
        (lambda t: t.replace('topic = "/hand/keypoints"', 'topic = "/tf"'),
         "hand topic /tf has message type tf2_msgs/msg/TFMessage, which lfd cannot read as hand "
         "keypoints; supported: geometry_msgs/PoseArray, visualization_msgs/MarkerArray"),
        (lambda t: t.replace("[hand]", "[hands]"), r"\[hands\]: unknown key '.*'; known keys: right, left"),
        (lambda t: t.replace('side = "right"', "side = 3"), "hand.side"),
        (lambda t: t.replace("size = [0.05, 0.05, 0.05]", "size = [0.05, 0.05]"), "objects.box_1.size"),
        (lambda t: t.replace('units = "m"', 'units = "cm"'), "units must be"),
        (lambda t: t.replace('frame = "box_1"', 'frame = "box_1"\ncolour = 1'), "unknown key 'colour'"),
        (lambda t: t + "[", "not a valid TOML"),
        (lambda t: t.replace('reference_frame = "world"', 'reference_frame = "map"'),
         "no tf path from frame 'camera' to the reference frame 'map'; tf frames in the bag: box_1"),
        (lambda t: t.replace("tag_id = 1\n", "tag_id = 12345678901234567890\n"),
         r"objects.box_1.tag_id must be an integer in \[0, 1023\] or -1 \(no tag\), "
         "got 12345678901234567890$"),
        (lambda t: t.replace("tag_id = 1\n", "tag_id = 1.5\n"), r"objects.box_1.tag_id must be"),
        (lambda t: t.replace("tag_id = 2\n", "tag_id = 1\n"),
         "objects 'box_1' and 'box_2' have the same tag_id 1; each tag is on one object"),
    ],
)  # fmt: skip
def test_bad_mapping_is_one_clear_error(edit, match, bags, tmp_path: Path) -> None:
    bag, mapping = bags["ros1"]
    bad = tmp_path / "bad.toml"
    bad.write_text(edit(mapping.read_text(encoding="utf-8")), encoding="utf-8")
    with pytest.raises(UsageError, match=match):
        lfd.load(bag, mapping=bad)


def test_objects_without_tags_may_share_no_tag(tmp_path: Path) -> None:
    """-1 (no tag, the default) is on any number of objects; a tag id is on one."""
    path = tmp_path / "map.toml"
    path.write_text(
        '[hand]\ntopic = "/a"\n[objects.a]\nframe = "a"\ntag_id = -1\n'
        '[objects.b]\nframe = "b"\n[objects.c]\nframe = "c"\ntag_id = 1023\n',
        encoding="utf-8",
    )
    assert [o.tag_id for o in read_mapping(path).objects] == [-1, -1, 1023]


def test_bag_without_map_and_map_without_bag(bags) -> None:
    bag, mapping = bags["ros2-mcap"]
    with pytest.raises(UsageError, match="is a ROS bag: give a topic mapping with --map"):
        lfd.load(bag)
    with pytest.raises(UsageError, match="is a ROS bag: give a topic mapping with --map"):
        lfd.load(next(bag.glob("*.mcap")))  # told by its cdr channels
    with pytest.raises(UsageError, match="not a ROS bag: drop the topic mapping"):
        lfd.load(EXP1, mapping=mapping)


def test_without_rosbags_one_line_says_which_extra(bags, tmp_path: Path) -> None:
    bag, mapping = bags["ros1"]
    code = (
        "import sys\n"
        "class Block:\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name.split('.')[0] == 'rosbags':\n"
        "            raise ModuleNotFoundError(name, name=name)\n"
        "sys.meta_path.insert(0, Block())\n"
        "from lfd.cli import main\n"
        f"sys.exit(main(['segment', {str(bag)!r}, '--map', {str(mapping)!r}]))\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.strip() == (
        "lfd segment: error: reading ROS bags needs the rosbags package: pip install 'lfd[ros]'"
    )


def test_shipped_example_bag_is_exp1(exp1) -> None:
    """recordings/ros/exp1.bag (bz2 chunks) with its commented mapping, docs/ros.md's example."""
    demo = lfd.load(ROOT / "recordings/ros/exp1.bag", mapping=ROOT / "recordings/ros/exp1.toml")
    np.testing.assert_allclose(demo.hand.keypoints, exp1.hand.keypoints, atol=1e-9)
    for name, o in exp1.objects.items():
        np.testing.assert_allclose(demo.objects[name].position, o.position, atol=1e-9)
        np.testing.assert_array_equal(demo.objects[name].size, o.size)
    assert _skills(lfd.segment(demo)) == _skills(lfd.segment(exp1))


def test_foxy_markers_one_per_keypoint_in_a_lone_mcap(exp1, tmp_path: Path) -> None:
    """A ROS 2 Foxy bag (its Marker lacks Humble's texture and mesh_file fields: decoded with the
    definitions the .mcap embeds), the hand as 21 SPHERE markers (ids in MediaPipe order,
    written shuffled), read from the lone .mcap file."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_FOXY)
    T = store.types
    Marker = T["visualization_msgs/msg/Marker"]
    assert "texture" not in Marker.__dataclass_fields__

    def stamp(t: int):
        return T["std_msgs/msg/Header"](
            stamp=T["builtin_interfaces/msg/Time"](sec=t // 10**9, nanosec=t % 10**9),
            frame_id="world",
        )

    def pose(p, q=(0.0, 0.0, 0.0, 1.0)):
        return T["geometry_msgs/msg/Pose"](
            position=T["geometry_msgs/msg/Point"](x=p[0], y=p[1], z=p[2]),
            orientation=T["geometry_msgs/msg/Quaternion"](x=q[0], y=q[1], z=q[2], w=q[3]),
        )

    rng = np.random.default_rng(0)
    msgs = []
    for t, kp in zip(exp1.hand.t_ns, exp1.hand.keypoints, strict=True):
        markers = [
            Marker(
                header=stamp(int(t)), ns="hand", id=int(k), type=Marker.SPHERE,
                action=Marker.ADD, pose=pose(kp[k]),
                scale=T["geometry_msgs/msg/Vector3"](x=0.01, y=0.01, z=0.01),
                color=T["std_msgs/msg/ColorRGBA"](r=1.0, g=0.0, b=0.0, a=1.0),
                lifetime=T["builtin_interfaces/msg/Duration"](sec=0, nanosec=0),
                frame_locked=False, points=[], colors=[], text="", mesh_resource="",
                mesh_use_embedded_materials=False,
            )
            for k in rng.permutation(21)
        ]  # fmt: skip
        msgs.append((int(t), "/hand", T["visualization_msgs/msg/MarkerArray"](markers=markers)))
    for o in exp1.objects.values():
        for t, p, q in zip(o.t_ns, o.position, o.quaternion, strict=True):
            msg = T["geometry_msgs/msg/PoseStamped"](header=stamp(int(t)), pose=pose(p, q))
            msgs.append((int(t), f"/{o.name}", msg))
    types = {"/hand": "visualization_msgs/msg/MarkerArray"}
    types.update({f"/{n}": "geometry_msgs/msg/PoseStamped" for n in exp1.objects})
    path = tmp_path / "foxy"
    with Writer(path, version=8, storage_plugin=StoragePlugin.MCAP) as w:
        conns = {k: w.add_connection(k, v, typestore=store) for k, v in types.items()}
        for t, topic, msg in sorted(msgs, key=lambda m: m[0]):
            w.write(conns[topic], t, store.serialize_cdr(msg, types[topic]))
    mapping = {
        "hand": {"topic": "/hand"},
        "objects": {
            n: {"topic": f"/{n}", "size": o.size.tolist()} for n, o in exp1.objects.items()
        },
    }
    (lone,) = path.glob("*.mcap")
    demo = lfd.load(lone, mapping=mapping)
    np.testing.assert_allclose(demo.hand.keypoints, exp1.hand.keypoints, atol=1e-12)
    assert _skills(lfd.segment(demo)) == _skills(lfd.segment(exp1))


def test_ros1_messages_in_an_mcap_file(exp1, tmp_path: Path) -> None:
    """An .mcap of ROS 1 messages (message encoding ros1, ros1msg schemas), as ROS 1 tools
    write them: read through the same mapping."""
    from mcap.writer import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    T = store.types
    path = tmp_path / "ros1.mcap"
    with open(path, "wb") as f:
        w = Writer(f)
        w.start(profile="ros1", library="test")
        chans = {}
        for topic, typ in [("/hand", "geometry_msgs/msg/PoseArray")] + [
            (f"/{n}", "geometry_msgs/msg/PoseStamped") for n in exp1.objects
        ]:
            text, _ = store.generate_msgdef(typ)
            sid = w.register_schema(typ.replace("/msg/", "/"), "ros1msg", text.encode())
            chans[topic] = (w.register_channel(topic, "ros1", sid), typ)

        def header(t: int):
            stamp = T["builtin_interfaces/msg/Time"](sec=t // 10**9, nanosec=t % 10**9)
            return T["std_msgs/msg/Header"](seq=0, stamp=stamp, frame_id="world")

        def pose(p, q=(0.0, 0.0, 0.0, 1.0)):
            return T["geometry_msgs/msg/Pose"](
                position=T["geometry_msgs/msg/Point"](x=p[0], y=p[1], z=p[2]),
                orientation=T["geometry_msgs/msg/Quaternion"](x=q[0], y=q[1], z=q[2], w=q[3]),
            )

        def write(topic: str, t: int, msg) -> None:
            cid, typ = chans[topic]
            w.add_message(cid, t, bytes(store.serialize_ros1(msg, typ)), t)

        for t, kp in zip(exp1.hand.t_ns, exp1.hand.keypoints, strict=True):
            msg = T["geometry_msgs/msg/PoseArray"](
                header=header(int(t)), poses=[pose(p) for p in kp]
            )
            write("/hand", int(t), msg)
        for o in exp1.objects.values():
            for t, p, q in zip(o.t_ns, o.position, o.quaternion, strict=True):
                msg = T["geometry_msgs/msg/PoseStamped"](header=header(int(t)), pose=pose(p, q))
                write(f"/{o.name}", int(t), msg)
        w.finish()
    mapping = {
        "hand": {"topic": "/hand"},
        "objects": {
            n: {"topic": f"/{n}", "size": o.size.tolist()} for n, o in exp1.objects.items()
        },
    }
    demo = lfd.load(path, mapping=mapping)
    assert demo.metadata["ros"]["format"] == "ROS 1 MCAP file"
    np.testing.assert_allclose(demo.hand.keypoints, exp1.hand.keypoints, atol=1e-12)
    assert _skills(lfd.segment(demo)) == _skills(lfd.segment(exp1))


@pytest.mark.parametrize("kind", ["ros1", "ros2-sqlite3"])
def test_info_of_a_bag(kind: str, bags) -> None:
    bag, mapping = bags[kind]
    ours = {c["topic"]: c for c in lfd.io.summarise(EXP1)["channels"]}
    s = lfd.io.summarise(bag, mapping=mapping)
    assert s["error"] is None and s["warnings"] == []
    assert [o["name"] for o in s["objects"]] == ["box_1", "box_2", "box_3"]
    chans = {c["topic"]: c for c in s["channels"]}
    hand = chans["/hand/keypoints" if kind == "ros1" else "/hand/markers"]
    assert hand["count"] == ours["/hand/right/keypoints"]["count"]
    assert hand["rate_hz"] == pytest.approx(ours["/hand/right/keypoints"]["rate_hz"], abs=1e-3)
    assert s["duration_s"] == pytest.approx(lfd.load(EXP1).duration_s, abs=1e-6)
    without = lfd.io.summarise(bag)  # the channels, and why it cannot be read
    assert without["channels"] == s["channels"]
    assert "give a topic mapping with --map" in without["error"]


def test_reference_frame_below_the_root(bags, exp1, tmp_path: Path) -> None:
    """reference_frame = camera: the chain goes up to world and back down through the inverse."""
    from _rosbags import WORLD_T_CAMERA

    bag, mapping = bags["ros1"]
    text = mapping.read_text(encoding="utf-8").replace(
        'reference_frame = "world"', 'reference_frame = "camera"'
    )
    (tmp_path / "cam.toml").write_text(text, encoding="utf-8")
    demo = lfd.load(bag, mapping=tmp_path / "cam.toml")
    cam_T_world = np.linalg.inv(WORLD_T_CAMERA)
    for name, o in exp1.objects.items():
        want = o.position @ cam_T_world[:3, :3].T + cam_T_world[:3, 3]
        np.testing.assert_allclose(demo.objects[name].position, want, atol=1e-9)
    want = exp1.hand.keypoints @ cam_T_world[:3, :3].T + cam_T_world[:3, 3]
    np.testing.assert_allclose(demo.hand.keypoints, want, atol=1e-9)


def test_tf_chain_interpolates_dynamic_edges() -> None:
    """world -> a moves (x 0 -> 1 m, yaw 0 -> 90 deg over 1 s), a -> b is static (0.1 m along
    a's x): at 0.5 s b is at a's midpoint plus 0.1 m along yaw 45 deg; before the first and after
    the last sample the edge holds."""
    from lfd.io.ros.tf import _TfTree
    from scipy.spatial.transform import Rotation

    tf = _TfTree()
    q0, q1 = Rotation.from_euler("z", [[0], [90]], degrees=True).as_quat()
    tf.add("world", "a", 1_000_000_000, np.zeros(3), q0, False)
    tf.add("/world", "/a", 2_000_000_000, np.array([1.0, 0, 0]), q1, False)
    tf.add("a", "b", 0, np.array([0.1, 0, 0]), np.array([0, 0, 0, 1.0]), True)
    t = np.array([0, 1_500_000_000, 3_000_000_000])
    got = tf.ref_T("world", "b", t, "test")[:, :3, 3]
    c = np.cos(np.pi / 4) * 0.1
    np.testing.assert_allclose(got, [[0.1, 0, 0], [0.5 + c, c, 0], [1.0, 0.1, 0]], atol=1e-12)
    back = tf.ref_T("b", "world", t, "test") @ tf.ref_T("world", "b", t, "test")
    np.testing.assert_allclose(back, np.tile(np.eye(4), (3, 1, 1)), atol=1e-12)


def test_two_hand_topics_map_to_a_two_hand_demonstration(tmp_path: Path) -> None:
    """A ROS 1 bag with one PoseArray topic per hand ([hands.right], [hands.left]): both hands
    come back as written; imported, the lfd recording holds both."""
    from _two_hands import two_hand_demo

    demo = two_hand_demo()
    bag = tmp_path / "two.bag"
    mapping = tmp_path / "two.toml"
    mapping.write_text(write_ros1(demo, bag), encoding="utf-8")
    assert "[hands.left]" in mapping.read_text()
    back = lfd.load(bag, mapping=mapping)
    assert back.sides == ("right", "left")
    for side, hand in demo.hands.items():
        np.testing.assert_array_equal(back.hands[side].t_ns, hand.t_ns)
        np.testing.assert_allclose(back.hands[side].keypoints, hand.keypoints, atol=1e-9)
    assert set(back.metadata["ros"]["mapping"]["hands"]) == {"right", "left"}
    out = tmp_path / "two.mcap"
    lfd.save(back, out)
    assert lfd.load(out).sides == ("right", "left")


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ('[hand]\ntopic = "/a"\n[hands.left]\ntopic = "/b"\n', "not both"),
        ('[hands.right]\ntopic = "/a"\n[hands.left]\ntopic = "/a"\n', "the same topic /a"),
        ('[hands.middle]\ntopic = "/a"\n', "[hands]: unknown key 'middle'"),
        ('[hands.left]\ntopic = "/a"\nside = "right"\n', "[hands.left]: unknown key 'side'"),
    ],
)
def test_bad_two_hand_mapping_is_one_clear_error(tmp_path: Path, text: str, expected: str) -> None:
    path = tmp_path / "map.toml"
    path.write_text(text + '[objects.box_1]\nframe = "box_1"\n', encoding="utf-8")
    with pytest.raises(UsageError) as err:
        read_mapping(path)
    assert expected in str(err.value)
    assert "\n" not in str(err.value)
