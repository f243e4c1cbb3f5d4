"""Live views: lfd.viz.live.LiveTimeline and ``lfd segment --follow`` on a growing recording."""

from __future__ import annotations

import threading
import time
from pathlib import Path

import _paths
import numpy as np
import pytest

rr = pytest.importorskip("rerun", reason="rerun-sdk not installed (optional viz extra)")

from _rrd import Rrd, row_times  # noqa: E402
from lfd import viz  # noqa: E402
from lfd.demo import SkillLabel  # noqa: E402
from lfd.io import McapRecorder, load  # noqa: E402

ROOT = _paths.ROOT
EXP1 = ROOT / "recordings" / "exp1.mcap"


def _replay(out: Path, speed: float, done: threading.Event | None = None) -> None:
    """Write exp1's tracks and labels to ``out`` with McapRecorder at ``speed`` x real time."""
    demo = load(EXP1, images=False)
    events = [(int(t), "hand", i) for i, t in enumerate(demo.hand.t_ns)]
    for name, obj in demo.objects.items():
        events += [(int(t), name, i) for i, t in enumerate(obj.t_ns)]
    events.sort(key=lambda e: e[0])
    objects = [(o.name, o.tag_id, o.size) for o in demo.objects.values()]
    with McapRecorder(out, objects=objects) as rec:
        t_prev = events[0][0]
        for t, stream, i in events:
            time.sleep(max(0.0, (t - t_prev) * 1e-9 / speed))
            t_prev = t
            if stream == "hand":
                h = demo.hand
                rec.add_hand(t, h.keypoints[i], h.confidence[i], h.visible[i])
            else:
                o = demo.objects[stream]
                rec.add_object_pose(stream, t, o.position[i], o.quaternion[i])
        for label in demo.labels:
            rec.add_label(label)
    if done is not None:
        done.set()


def test_live_timeline_matches_the_offline_paths(tmp_path: Path) -> None:
    """Samples, sections, settled and provisional skills logged one by one land on the entity
    paths of the offline views, at their demo_time."""
    from lfd.viz.live import LiveTimeline

    demo = load(EXP1, images=False)
    t0 = int(demo.start_ns)
    session = viz.open_session("lfd_live_test", save=tmp_path / "live.rrd", make_default=False)
    objects = [(n, o.tag_id, o.size) for n, o in demo.objects.items()]
    live = LiveTimeline(session.recording, origin_ns=t0, objects=objects)
    for i, t in enumerate(demo.hand.t_ns):
        live.log_hand(int(t), demo.hand.keypoints[i])
    name, obj = next(iter(demo.objects.items()))
    for i in range(0, len(obj), 10):
        live.log_object(name, int(obj.t_ns[i]), obj.position[i], obj.quaternion[i])
    rng = np.random.default_rng(0)
    ft = demo.hand.t_ns[:20]
    for i, t in enumerate(ft):
        live.log_sample(int(t), rng.standard_normal(10), np.full(10, 0.5), target=i // 10)
    live.log_section(int(ft[0]))
    live.log_section(int(ft[8]))
    first, second = demo.labels[0], demo.labels[1]
    live.log_provisional(SkillLabel(first.skill, first.start_ns, first.start_ns + 1, first.object))
    live.log_skill(first)
    live.log_provisional(None, first.end_ns)
    live.log_skill(second)
    live.log_score(first.skill, int(first.end_ns), -12.5)
    session.close()

    data = Rrd(tmp_path / "live.rrd")
    np.testing.assert_array_equal(data.times("/world/hand/keypoints"), demo.hand.t_ns - t0)
    assert f"/world/objects/{name}/box" in data.static
    assert len(data.times(f"/world/objects/{name}")) == len(range(0, len(obj), 10))
    np.testing.assert_array_equal(data.times("/features/object_height/value"), ft - t0)
    assert data.column("/features/target", "StateChange:state")[:2] == [["target: object 0"]] * 2
    assert data.column("/segmentation/sections", "StateChange:state") == [
        ["section 0"],
        ["section 1"],
    ]
    lane = data.entity("/segmentation/skills/result")
    states = [r["StateChange:state"][0] for r in lane]
    want = f"{first.skill}({first.object})" if first.object else first.skill
    assert states[0] == want and lane[0]["demo_time"] == first.start_ns - t0
    assert "/segmentation/skills/provisional" in data.rows
    assert data.one("/segmentation/greedy/scores/" + first.skill, "Scalars:scalars") == [-12.5]
    assert data.blueprints


@pytest.mark.slow  # the default run stays under 5 minutes; covered there by faster tests
def test_segment_follow_streams_a_growing_recording_to_rerun(tmp_path: Path) -> None:
    """``lfd segment --follow`` on a recording written at 4x real time: every hand sample of
    the final file reaches the .rrd, logged while the recorder was still writing."""
    from lfd.cli import main

    rec = tmp_path / "rec.mcap"
    rrd = tmp_path / "live.rrd"
    done = threading.Event()
    writer = threading.Thread(target=_replay, args=(rec, 4.0, done))
    writer.start()
    try:
        code = main(
            ["segment", "--follow", str(rec), "--rerun-save", str(rrd), "--idle-timeout", "5"]
        )
    finally:
        writer.join()
    assert code == 0 and done.is_set()
    final = load(rec, images=False)
    data = Rrd(rrd)
    t = data.times("/world/hand/keypoints")
    np.testing.assert_array_equal(t, final.hand.t_ns - final.start_ns)
    # logged as the samples came: the first rows were written seconds before the last ones
    logged = row_times(rrd, "/world/hand/keypoints")
    assert len(logged) == len(t) and (logged.max() - logged.min()) * 1e-9 > 1.5
    lanes = {k for k in data.rows if k.startswith("/segmentation/skills/")}
    assert {"/segmentation/skills/ground_truth", "/segmentation/skills/result"} <= lanes
    # the online segmenter's skills were logged as they settled, not at the end
    spans = row_times(rrd, "/segmentation/skills/result")
    assert len(spans) >= 2 * 6 and (logged.max() - spans.min()) * 1e-9 > 1.0
    assert data.blueprints


def test_segment_follow_of_a_file_that_never_gets_data_is_an_error(tmp_path: Path) -> None:
    """A followed file that stops growing before any hand or object sample arrived: exit 2 with
    one error line (after the follower's warning that the file stopped growing) and no
    --rerun-save file, as ``lfd segment`` of an empty file."""
    import subprocess
    import sys

    rec = tmp_path / "empty.mcap"
    rec.write_bytes(b"")
    rrd = tmp_path / "x.rrd"
    cmd = ["segment", "--follow", str(rec), "--idle-timeout", "0.5", "--rerun-save", str(rrd)]
    proc = subprocess.run(
        [sys.executable, "-m", "lfd.cli", *cmd], capture_output=True, text=True, timeout=120
    )
    lines = [line for line in proc.stderr.splitlines() if line.strip()]
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    errors = [line for line in lines if ": error: " in line]
    assert errors == lines[-1:] and lines[-1].startswith("lfd segment: error: "), proc.stderr
    assert "nothing to segment" in lines[-1] and "stopped growing" in lines[0]
    assert "0 messages over 0.0 s" in " ".join(proc.stdout.split())
    assert not rrd.exists() and sorted(p.name for p in tmp_path.iterdir()) == ["empty.mcap"]
