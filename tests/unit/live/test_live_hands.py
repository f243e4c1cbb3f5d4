"""Live segmentation of two hands (:mod:`lfd.segmentation.live_hands`): a lane per hand, the
runs over both hands together; at the end each lane is the batch one (``lfd.segment_hands``)."""

from __future__ import annotations

import dataclasses
import warnings
from pathlib import Path

import _paths
import lfd
import numpy as np
import pytest
from _two_hand_tasks import idle_left
from lfd.errors import InvalidParameterError
from lfd.segmentation.live import HandMessage, LiveSegmentation, demo_messages
from lfd.segmentation.live_hands import LiveHands, segment_hands_live


@pytest.fixture(scope="module")
def two() -> lfd.Demonstration:
    return idle_left(lfd.load(_paths.EXP1, images=False))


def test_live_hands_equal_batch_at_the_end(two: lfd.Demonstration) -> None:
    """Every lane: the batch skills of that hand, each settled after its batch end, boundaries
    within a few samples, the same end; the handovers are the batch ones."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        batch = lfd.segment_hands(two)
        live, settled = segment_hands_live(two)
    assert live.sides == batch.sides == ("right", "left")
    for side in two.sides:
        got, want = live.lanes[side].segments, batch.lanes[side].segments
        assert [(s.skill, s.object) for s in got] == [(s.skill, s.object) for s in want], side
        late = (settled[side] - np.array([s.end_ns for s in want])) * 1e-9
        assert np.all(late[:-1] > 0), late
        starts = np.array([s.start for s in got]) - np.array([s.start for s in want])
        assert np.median(np.abs(starts)) <= 2, starts
        assert got[-1].end_ns == want[-1].end_ns
    assert [(h.giver, h.taker, h.object) for h in live.handovers] == [
        (h.giver, h.taker, h.object) for h in batch.handovers
    ]
    # the right hand's skills settle while it is recorded, as with one hand
    assert sum(t < two.end_ns - 2_000_000_000 for t in settled["right"]) >= 4


def test_settled_labels_name_their_hand(two: lfd.Demonstration) -> None:
    """What an update settles, as labels for /lfd/live/segments: each names its hand; the
    labels of all updates are the lanes of the result."""
    live = LiveHands.for_demonstration(two)
    labels = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for msg in demo_messages(two):
            labels += live.push(msg).labels
        labels += live.finish().labels
    assert {lab.hand for lab in labels} == {"right", "left"}
    result = live.result().to_labels()
    key = lambda lab: (lab.hand, lab.start_ns, lab.skill)  # noqa: E731
    assert sorted(labels, key=key) == sorted(result, key=key)


def test_hand_frames_must_name_a_known_side(two: lfd.Demonstration) -> None:
    live = LiveHands.for_demonstration(two)
    frame = np.zeros((21, 3))
    with pytest.raises(InvalidParameterError, match="names no side"):
        live.push(HandMessage(0, frame))
    one = LiveHands.for_demonstration(two.one_hand("right"))
    assert one.sides == ("right",)
    one.push(HandMessage(0, frame))  # the only hand
    with pytest.raises(InvalidParameterError, match="left-hand frame"):
        one.push(HandMessage(1, frame, side="left"))
    with pytest.raises(InvalidParameterError, match="left-hand frame"):
        LiveSegmentation(["box_1"], [[0.05] * 3]).push(HandMessage(0, frame, side="left"))
    with pytest.raises(lfd.errors.DemonstrationError, match="hand side"):
        LiveHands(["box_1"], [[0.05] * 3], sides=("up",))


def test_live_view_of_two_hands(two: lfd.Demonstration, tmp_path: Path) -> None:
    """What ``lfd record --live-segment --rerun-save`` does beside a two-hand file
    (:class:`lfd.live.LiveObserver` with :class:`LiveHands`): every hand sample in its hand's
    keypoints, every settled skill in its hand's lane (and returned as a label naming its
    hand), a settled handover in the handover lane and in 3-D where the object was."""
    pytest.importorskip("rerun")
    from _rrd import Rrd
    from lfd import viz
    from lfd.live import LiveObserver
    from lfd.segmentation.live_hands import HandsUpdate

    session = viz.open_session("lfd_live_hands", save=tmp_path / "live.rrd")
    objects = [(n, o.tag_id, o.size) for n, o in two.objects.items()]
    observer = LiveObserver.open(objects, segmenter=LiveHands.for_demonstration(two), view=True)
    written = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for msg in demo_messages(two):
            if isinstance(msg, HandMessage):
                written += observer.on_hand(msg.t_ns, msg.keypoints, msg.confidence, None, msg.side)
            else:
                poses = {msg.name: (msg.position, msg.quaternion)}
                written += observer.on_frame(msg.t_ns, np.zeros((4, 4, 3), np.uint8), poses)
        written += observer.finish(two.end_ns)
    assert observer.timeline is not None and observer.segmenter is not None
    box = two.objects["box_2"]
    h = lfd.Handover(int(box.t_ns[60]), int(box.t_ns[70]), "right", "left", "box_2")
    observer.timeline.log_update(HandsUpdate(handovers=[h]))
    session.close()
    data = Rrd(session.save_path)
    result = observer.segmenter.result()
    for side in ("right", "left"):
        assert len(data.entity(f"/world/hand/{side}/keypoints")) == len(two.hands[side])
        states = data.column(f"/segmentation/skills/{side}/result", "StateChange:state")
        assert [x[0] for x in states if x[0]] == [
            s.skill + (f"({s.object})" if s.object else "") for s in result.lanes[side].segments
        ]
        assert [lab.skill for lab, _, _ in written if lab.hand == side] == result.lanes[
            side
        ].skill_sequence
    assert data.column("/segmentation/handovers/result", "StateChange:state") == [
        ["box_2 right→left"], [""],
    ]  # fmt: skip
    point = data.static["/world/handovers/result"]["Points3D:positions"][0]
    np.testing.assert_allclose(point, box.position[70], atol=1e-6)


def test_follow_stream_of_two_hands(
    two: lfd.Demonstration, capsys: pytest.CaptureFixture[str]
) -> None:
    """``lfd segment --follow`` of a two-hand recording (cli.segment.segment_stream) on the
    messages a follower yields (each hand's frame and confidence naming its side): a lane per
    hand, equal to the live segmentation of the demonstration, each settled skill printed with
    its hand."""
    from types import SimpleNamespace

    from lfd.cli import build_parser
    from lfd.cli.segment import segment_stream

    args = build_parser().parse_args(["segment", str(_paths.EXP1)])
    args.recording = args.recordings[0]
    follower = SimpleNamespace(
        hand_side="right",
        sides=("right", "left"),
        objects=[(n, o.tag_id, o.size.tolist()) for n, o in two.objects.items()],
        demo_metadata={},
    )

    def messages():
        for msg in demo_messages(two):
            if isinstance(msg, HandMessage):
                yield SimpleNamespace(
                    kind="hand", t_ns=msg.t_ns, value=msg.keypoints, side=msg.side
                )
                both = (msg.confidence, msg.visible)
                yield SimpleNamespace(kind="confidence", t_ns=msg.t_ns, value=both, side=msg.side)
            else:
                yield SimpleNamespace(kind="object", t_ns=msg.t_ns, value=msg, side=None)

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result, _, settled = segment_stream(messages(), follower, lambda: None, args)
        want, _ = segment_hands_live(two)
    assert set(result.lanes) == {"right", "left"}
    for side in two.sides:
        assert [(s.skill, s.object, s.start, s.end) for s in result.lanes[side].segments] == [
            (s.skill, s.object, s.start, s.end) for s in want.lanes[side].segments
        ]
    assert len(settled) == sum(len(lane.segments) for lane in result.lanes.values())
    out = capsys.readouterr().out
    assert out.count("settled: left ") == len(result.lanes["left"].segments)
    assert out.count("settled: right ") == len(result.lanes["right"].segments)


def test_lfd_segment_follow_a_two_hand_file(two: lfd.Demonstration, tmp_path: Path) -> None:
    """``lfd segment --follow`` of a two-hand file written by lfd.save: a lane per hand, the
    batch skills of each hand (lfd.segment_hands of the file), shown live per hand."""
    import json

    from lfd.cli import main

    rec, out, rrd = tmp_path / "two.mcap", tmp_path / "live.json", tmp_path / "live.rrd"
    lfd.save(two, rec)
    args = ["segment", "--follow", str(rec), "--idle-timeout", "2", "--json", str(out)]
    has_rerun = True
    try:
        import rerun  # noqa: F401
    except ImportError:
        has_rerun = False
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main(args + (["--rerun-save", str(rrd)] if has_rerun else [])) == 0
        batch = lfd.segment_hands(lfd.load(rec))
    doc = json.loads(out.read_text())
    assert set(doc["hands"]) == {"right", "left"} and doc["live"]["stopped"] == "end"
    assert set(doc["metrics"]) == {"right", "left", "handovers"}  # as lfd segment --json
    for side in ("right", "left"):
        got = [(s["skill"], s["object"]) for s in doc["hands"][side]["segments"]]
        assert got == [(s.skill, s.object) for s in batch.lanes[side].segments], side
    if has_rerun:
        from _rrd import Rrd

        data = Rrd(rrd)
        for side in ("right", "left"):
            assert len(data.entity(f"/world/hand/{side}/keypoints")) == len(two.hands[side])
            states = data.column(f"/segmentation/skills/{side}/result", "StateChange:state")
            assert len([x for x in states if x[0]]) == len(batch.lanes[side].segments)
            truth = data.column(f"/segmentation/skills/{side}/ground_truth", "StateChange:state")
            assert [x[0] for x in truth if x[0]] == [
                f"{lab.skill}({lab.object})" if lab.object else lab.skill
                for lab in two.labels_of(side)
            ]


def test_a_handover_settles_once_both_lanes_have(
    two: lfd.Demonstration, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A handover every run finds (the segmentation's, here added to each run of
    lfd.segment_hands that reaches it) settles once, when the giver's lane has settled past its
    end and the taker's past its start, before the recording ends; the result has it once."""
    import dataclasses

    import lfd.segmentation as segmentation

    real = segmentation.segment_hands
    h = lfd.Handover(two.start_ns + 3 * 10**9, two.start_ns + 4 * 10**9, "right", "left", "box_2")

    def with_handover(demo, *args, **kwargs):
        out = real(demo, *args, **kwargs)
        return dataclasses.replace(out, handovers=[h] if demo.end_ns > h.end_ns else [])

    monkeypatch.setattr(segmentation, "segment_hands", with_handover)
    # both hands the recorded one: both lanes settle their skills while it is recorded
    twin = dataclasses.replace(
        two, other_hand=dataclasses.replace(two.hand, side="left"), labels=[], handovers=[]
    )
    live = LiveHands.for_demonstration(twin)
    when = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for msg in demo_messages(twin):
            up = live.push(msg)
            if up.handovers:
                when.append((msg.t_ns, up.handovers))
                fronts = {side: lane.settled_until for side, lane in live.lanes.items()}
        end = live.finish()
    assert len(when) == 1 and when[0][1] == [h] and end.handovers == []
    assert when[0][0] < two.end_ns - 10**9  # settled while recording
    assert fronts["right"] >= h.end_ns - live.tolerance_ns
    assert fronts["left"] >= h.start_ns - live.tolerance_ns
    assert live.result().handovers == [h]


@pytest.mark.slow  # records a simulated two-hand handover in real time (~50 s)
def test_record_live_segment_of_two_hands(tmp_path: Path) -> None:
    """``lfd record --source sim:handover --live-segment --rerun-save``: both hands' skills are
    written to /lfd/live/segments, each naming its hand, equal per hand to lfd.segment_hands of
    the file; the live view has each hand's keypoints and lanes."""
    pytest.importorskip("mujoco")
    pytest.importorskip("rerun")
    from _rrd import Rrd
    from lfd.cli import main

    out, rrd = tmp_path / "two.mcap", tmp_path / "two.rrd"
    argv = ["record", "--source", "sim:handover", "--seed", "3", "-o", str(out)]
    assert main([*argv, "--live-segment", "--rerun-save", str(rrd)]) == 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        demo = lfd.load(out)
        batch = lfd.segment_hands(demo)
    data = Rrd(rrd)
    for side in ("right", "left"):
        live = [(s.skill, s.object) for s in demo.live_segments if s.hand == side]
        assert live == [(s.skill, s.object) for s in batch.lanes[side].segments], side
        assert f"/world/hand/{side}/keypoints" in data.rows
        assert f"/segmentation/skills/{side}/result" in data.rows


def test_a_run_while_a_hand_has_one_frame(two: lfd.Demonstration) -> None:
    """The left hand enters the view late and is estimated twice a second: the run due 0.2 s
    after its first frame sees one frame of it and does not fail (an IndexError in the
    attribution of objects to the nearer hand did, live and in batch of such a recording);
    the end is the batch result."""
    left = two.other_hand
    assert left is not None
    t = np.asarray(left.t_ns)
    keep = np.flatnonzero(t >= two.start_ns + 2 * 1_000_000_000)
    keep = keep[np.r_[True, np.diff(t[keep] // 500_000_000) > 0]]  # 2 Hz
    sparse = dataclasses.replace(
        left,
        t_ns=t[keep],
        keypoints=left.keypoints[keep],
        confidence=left.confidence[keep],
        visible=None if left.visible is None else left.visible[keep],
    )
    demo = dataclasses.replace(two, other_hand=sparse)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        live, _ = segment_hands_live(demo, every_s=0.2)
        batch = lfd.segment_hands(demo)
    for side in demo.sides:
        assert [(s.skill, s.object) for s in live.lanes[side].segments] == [
            (s.skill, s.object) for s in batch.lanes[side].segments
        ], side
    assert live.lanes["right"].segments
