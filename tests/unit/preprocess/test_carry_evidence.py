"""An object never seen again after the hand reached it (lfd.preprocessing.carry): it rests where
it was last seen unless the camera saw that place empty, nothing near the line of sight; then
the hand carried it and set it down where it came down and stopped. The same rule makes the
live segmentation's check runs (docs/live.md)."""

from __future__ import annotations

import dataclasses
import warnings

import _paths  # noqa: F401
import lfd
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from lfd.preprocessing.carry import covered, in_clear_view, occluders, seen_empty, set_down
from lfd.sim import Variability, simulate


def _hidden_from(demo: lfd.Demonstration, name: str, a_ns: int) -> lfd.Demonstration:
    """``demo`` with no pose of ``name`` from ``a_ns`` on (its tag never seen again)."""
    ob = demo.objects[name]
    keep = np.asarray(ob.t_ns) < a_ns
    track = dataclasses.replace(
        ob,
        t_ns=ob.t_ns[keep],
        position=ob.position[keep],
        quaternion=ob.quaternion[keep],
        visible=np.asarray(ob.visible)[keep],
    )
    return dataclasses.replace(demo, objects={**demo.objects, name: track})


def _until(demo: lfd.Demonstration, cut_ns: int) -> lfd.Demonstration:
    """``demo`` recorded up to ``cut_ns`` (a recording still being made)."""

    def cut(track):  # type: ignore[no-untyped-def]
        keep = np.asarray(track.t_ns) <= cut_ns
        n = keep.size
        fields = {
            f.name: np.asarray(getattr(track, f.name))[keep]
            for f in dataclasses.fields(track)
            if isinstance(getattr(track, f.name), np.ndarray)
            and getattr(track, f.name).shape[:1] == (n,)
        }
        return dataclasses.replace(track, **fields)

    objects = {k: cut(o) for k, o in demo.objects.items()}
    return dataclasses.replace(demo, hand=cut(demo.hand), objects=objects, labels=[])


@pytest.fixture(scope="module")
def exp3() -> lfd.Demonstration:
    return simulate("exp3", 0, Variability(style="careful")).demo


def _end(demo: lfd.Demonstration, name: str) -> tuple[np.ndarray, dict]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        traj = lfd.preprocess(demo)
    return traj.object_position[traj.object_names.index(name), -1], traj.meta["gaps"]


def test_a_carried_box_never_seen_again_is_set_down_where_the_hand_left_it(exp3) -> None:
    """exp3: box_3 picked up and stacked on box_2; its tag hidden from the grasp to the end.
    Its place was seen empty once it was lifted away: it ends within 2 cm of where the
    simulator put it (on box_2), not where it was last seen (20 cm away)."""
    grasp = next(lab for lab in exp3.labels if lab.object == "box_3" and lab.skill != "move")
    hidden = _hidden_from(exp3, "box_3", grasp.start_ns)
    end, gaps = _end(hidden, "box_3")
    truth = exp3.objects["box_3"].position[-1]
    last_seen = hidden.objects["box_3"].position[-1]
    assert np.linalg.norm(end - truth) < 0.02
    assert np.linalg.norm(last_seen - truth) > 0.15
    assert gaps["carried"]["box_3"][-1][1] >= exp3.labels[-1].start_ns  # to the end
    # without the camera's pose nothing says its place was empty: it rests where last seen
    end, gaps = _end(dataclasses.replace(hidden, camera=None), "box_3")
    assert np.linalg.norm(end - last_seen) < 0.01 and "box_3" not in gaps["carried"]


def test_a_covered_base_rests(exp3) -> None:
    """box_2, the base of the stack, unseen from the stack on (box_3 covers its tag): box_3
    over it is near the line of sight, so its place is never seen empty and it stays put."""
    stack = next(lab for lab in exp3.labels if lab.skill == "stack")
    hidden = _hidden_from(exp3, "box_2", stack.start_ns)
    end, gaps = _end(hidden, "box_2")
    assert np.linalg.norm(end - exp3.objects["box_2"].position[-1]) < 0.01
    assert "box_2" not in gaps["carried"] and "box_2" in gaps["held"]


def test_a_covered_base_rests_in_a_recording_still_being_made(exp3) -> None:
    """The same in the live segmentation's runs (``complete=False``), where an object hidden
    since the hand reached it is taken to follow the hand: box_3 rests on box_2's place, so box_2
    is not carried off with the hand that let go of box_3 (perceived careful exp3, seeds 9408,
    9411-9413: the runs had a Pick up of the base and held the Stack for 5 s)."""
    stack = next(lab for lab in exp3.labels if lab.skill == "stack")
    hidden = _hidden_from(exp3, "box_2", stack.start_ns)
    # declared wider (9 cm), so that the hand stacking on it comes within its grasp radius as a
    # perceived hand, estimated a few cm low, does
    wide = dataclasses.replace(hidden.objects["box_2"], size=np.array([0.09, 0.09, 0.05]))
    hidden = dataclasses.replace(hidden, objects={**hidden.objects, "box_2": wide})
    base = exp3.objects["box_2"].position[-1]
    for cut in (stack.end_ns + 1_000_000_000, exp3.labels[-1].end_ns):
        so_far = _until(hidden, cut)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            traj = lfd.preprocess(so_far, complete=False)
        k = traj.object_names.index("box_2")
        assert np.nanmax(np.linalg.norm(traj.object_position[k] - base, axis=1)) < 0.01
    # without box_3 on it, the hidden base would go with the hand
    bare = _hidden_from(hidden, "box_3", stack.start_ns)
    so_far = _until(bare, stack.end_ns + 1_000_000_000)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        traj = lfd.preprocess(so_far, complete=False)
    k = traj.object_names.index("box_2")
    assert np.nanmax(np.linalg.norm(traj.object_position[k] - base, axis=1)) > 0.02


def test_covered_needs_an_object_at_rest_above_the_spot() -> None:
    spot, still = np.zeros(3), np.tile([0.01, 0.0, 0.05], (20, 1))
    assert covered(spot, 0.025, [still], 9)
    assert not covered(spot, 0.025, [still - np.array([0, 0, 0.05])], 9)  # beside it, not above
    assert not covered(spot, 0.025, [still + np.array([0.05, 0, 0])], 9)  # off its footprint
    moving = still.copy()
    moving[:, 2] += np.linspace(0.0, 0.1, 20)  # carried over it by the hand
    assert not covered(spot, 0.025, [moving], 9) and not covered(spot, 0.025, [], 9)


def test_the_line_of_sight_is_clear_only_without_a_hand_or_arm_on_it() -> None:
    spot, camera = np.zeros(3), np.array([0.0, 0.5, 0.5])
    hand = np.zeros((3, 21, 3))
    hand[:, :, 0] = np.linspace(0.0, 0.08, 21)  # fingers along x, the wrist (0) at the origin
    hand[0] += [0.0, 0.25, 0.25]  # on the line of sight, half way up
    hand[1] += [0.4, 0.0, 0.2]  # far from it, the forearm pointing away (-x from the wrist)
    hand[2] += [0.3, 0.25, 0.25]  # the hand beside it, its forearm reaching across it
    points, radii = occluders(hand)
    assert points.shape[1] == radii.size > 21
    assert in_clear_view(spot, camera, points, radii + 0.03).tolist() == [False, True, False]
    unknown = points.copy()
    unknown[1, 0] = np.nan  # an unknown hand hides what it may
    assert not in_clear_view(spot, camera, unknown, radii + 0.03)[1]


def test_set_down_is_where_the_lifted_hand_comes_down_and_stops() -> None:
    rate = 30.0
    t = np.arange(0, 3.0, 1 / rate)
    z = 0.05 + 0.15 * np.sin(np.pi * np.clip(t - 0.5, 0, 1.5) / 1.5) ** 2  # up, then down
    z[t > 2.0] = 0.05 + 0.1 * (t[t > 2.0] - 2.0) ** 2  # after the set-down it rises again
    x = 0.1 * np.clip(t, 0.0, 1.9) + 0.1 * np.clip(t - 2.1, 0.0, None)  # it stops to let go
    tcp = np.stack([x, np.zeros_like(t), z], axis=1)
    valid = np.ones(t.size, dtype=bool)
    put = set_down(tcp, valid, 0, rate)
    assert put is not None and abs(t[put] - 2.0) <= 0.1
    assert set_down(tcp[: int(1.2 * rate)], valid[: int(1.2 * rate)], 0, rate) is None


@given(st.lists(st.booleans(), max_size=40), st.integers(0, 8))
def test_seen_empty_is_a_run_of_clear_samples(clear: list[bool], samples: int) -> None:
    """``seen_empty``: some ``samples`` consecutive samples are all clear (the longest run
    counted one sample at a time)."""
    longest = run = 0
    for c in clear:
        run = run + 1 if c else 0
        longest = max(longest, run)
    assert seen_empty(np.array(clear, dtype=bool), samples) == (longest >= samples)
