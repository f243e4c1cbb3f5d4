"""Two-stage skill segmentation: shipped recordings, engine functions, baselines, bad input."""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
from functools import cache
from pathlib import Path

import _paths
import numpy as np
import pytest
from lfd import _hmmseg
from lfd.demo import Demonstration, HandTrack
from lfd.errors import (
    DemonstrationError,
    InvalidParameterError,
    ModelFormatError,
    ShapeMismatchError,
)
from lfd.segmentation import (
    SegmentParams,
    Templates,
    gripper_segmentation,
    proximity_segmentation,
    segment,
    train_templates,
)
from lfd.segmentation.evaluate import evaluate
from lfd.segmentation.grammar import compiled_grammar, impossible_transitions, needs_move_between
from lfd.segmentation.metrics import all_metrics
from lfd.segmentation.templates import FRAME_SYMMETRY, turn_object_frame
from lfd.skills import SKILLS

ROOT = _paths.ROOT
EXP1 = ROOT / "recordings" / "exp1.mcap"
EXP2 = ROOT / "recordings" / "exp2.mcap"
EXP3 = ROOT / "recordings" / "exp3.mcap"
TEMPLATE_DIR = ROOT / "recordings" / "templates"
PERCEIVED_EXP1 = ROOT / "recordings" / "perceived" / "exp1.mcap"


@cache
def _load(path: Path) -> Demonstration:
    from lfd.io import load

    return load(path, images=False)


def demo(path: Path = EXP1) -> Demonstration:
    return dataclasses.replace(_load(path))


# --- the shipped recordings ------------------------------------------------------------------
@pytest.mark.parametrize(("search", "grammar"), [("dp", "warn"), ("greedy", "enforce")])
def test_exp1_sequence_equals_ground_truth(search: str, grammar: str) -> None:
    d = demo()
    result = segment(d, search=search, grammar=grammar)  # type: ignore[arg-type]
    assert result.skill_sequence == d.skill_sequence
    m = all_metrics(result.segments, d.labels)
    # 0.83: every release ends where the hand lets go (docs/skills.md), the simulator's Place
    # keeps the pause after it (0.86 when only the last release did)
    assert m["frame_accuracy"] > (0.83 if search == "dp" else 0.75)
    assert m["boundary_error_s"] < 0.45
    # segments tile the trajectory and name the objects the labels name
    assert result.segments[0].start == 0
    assert all(a.end == b.start for a, b in zip(result.segments, result.segments[1:], strict=False))
    picks = [s for s in result.segments if s.skill == "pick_up"]
    truth = [lab.object for lab in d.labels if lab.skill == "pick_up"]
    assert [s.object for s in picks] == truth
    assert "grasp_position" in picks[0].params
    assert not impossible_transitions(result.skill_sequence)


@pytest.mark.parametrize("k", [1, 2, 3, 4])
def test_objects_follow_the_ground_truth_convention(k: int) -> None:
    """Every segment names the ground truth's object, Moves included: a Move goes towards the
    object of the skill after it (the one nearest the hand MOVE_OBJECT_S after the Move), and
    the Move that ends the demonstration has none."""
    d = demo(ROOT / "recordings" / f"exp{k}.mcap")
    result = segment(d)
    assert [(s.skill, s.object) for s in result.segments] == [
        (lab.skill, lab.object) for lab in d.labels
    ]
    moves = [i for i, s in enumerate(result.segments) if s.skill == "move"]
    assert result.segments[-1].skill == "move" and result.segments[-1].object is None
    for i in moves[:-1]:
        assert result.segments[i].object == result.segments[i + 1].object


def test_a_locate_followed_by_a_skill_on_another_object_gets_a_move() -> None:
    """On exp3 (Locate box_a, Move, Pick up box_b): with the Move folded into the Pick up, the
    Move is put back between them, towards the Pick up's object; if the Pick up were of the
    located object, the Locate would lead straight into it."""
    from lfd.segmentation.passes import insert_implicit_moves
    from lfd.segmentation.pipeline import as_trajectory
    from lfd.skills import Draft

    d = demo(EXP3)
    traj = as_trajectory(d)
    names = list(traj.object_names)
    segs = [
        Draft(s.skill, s.start, s.end, names.index(s.object) if s.object else None, s.score)
        for s in segment(traj).segments
    ]
    k = next(i for i, s in enumerate(segs) if s.skill == "locate")
    loc, mv, nxt = segs[k : k + 3]
    assert (mv.skill, nxt.skill) == ("move", "pick_up") and loc.obj != nxt.obj
    folded = [*segs[:k], loc, nxt.resized(mv.start, nxt.end)]
    back = insert_implicit_moves(traj, folded, 6)
    assert [s.skill for s in back[k : k + 3]] == ["locate", "move", "pick_up"]
    assert back[k + 1].obj == nxt.obj and np.isnan(back[k + 1].score)
    assert back[k].start == loc.start and back[k + 2].end == nxt.end
    assert (back[k].score, back[k + 2].score) == (loc.score, nxt.score)
    same = [*folded[:-1], dataclasses.replace(folded[-1], obj=loc.obj)]
    assert [s.skill for s in insert_implicit_moves(traj, same, 6)[k:]] == ["locate", "pick_up"]
    assert needs_move_between("locate", "box_1", "push", "box_2")
    assert not needs_move_between("locate", "box_1", "move", "box_2")
    assert needs_move_between("place", "box_1", "pick_up", "box_1")  # a re-grasp


def test_papers_method_finds_the_exp1_sequence() -> None:
    # the greedy loop with grammar warnings, on templates and a pipeline of the paper's recipe
    from lfd.segmentation import PAPER

    d = demo()
    result = segment(d, **PAPER)
    assert result.method == "greedy"
    assert result.skill_sequence == d.skill_sequence
    assert all_metrics(result.segments, d.labels)["frame_accuracy"] > 0.8
    # the paper's greedy loop on lfd's templates is fragile: it is the recipe that makes it work
    assert segment(d, search="greedy", grammar="warn").skill_sequence != d.skill_sequence


@pytest.mark.parametrize(("search", "grammar"), [("dp", "enforce"), ("greedy", "enforce")])
def test_perceived_exp1_segments_like_its_ground_truth(search: str, grammar: str) -> None:
    """The shipped perceived recording (``lfd record --source sim:exp1 --seed 1000``: tags and
    hand network on rendered frames, no labels) is the demonstration of ``exp1.mcap``."""
    seen, truth = demo(PERCEIVED_EXP1), demo(EXP1)
    assert seen.labels == [] and seen.metadata["perception"] == "lfd.perception"
    assert seen.metadata["seed"] == truth.metadata["seed"] == 1000
    result = segment(seen, search=search, grammar=grammar)  # type: ignore[arg-type]
    assert result.skill_sequence == truth.skill_sequence
    assert all_metrics(result.segments, truth.labels)["boundary_error_s"] < 0.3


@pytest.mark.parametrize("search", ["greedy", "dp"])
def test_the_pushes_of_exp2_are_found(search: str) -> None:
    # pushes along the object's y axis: only templates trained with the turned object frames
    # (FRAME_SYMMETRY) explain them; the lookahead keeps the Move after a Push from swallowing it
    d = demo(EXP2)
    r = segment(d, search=search, grammar="enforce")  # type: ignore[arg-type]
    assert r.skill_sequence == d.skill_sequence
    assert r.skill_sequence.count("push") == 2


def test_greedy_lookahead_keeps_a_short_skill_from_being_swallowed() -> None:
    # exp4 on the paper-recipe templates: by its own per-sample score alone, a long Move
    # swallows a short skill (the default templates, with layout copies, no longer need the
    # lookahead on the shipped recordings; exp1 needed it before simulator 1.2)
    d = demo(ROOT / "recordings" / "exp4.mcap")
    t = Templates.paper()
    plain = segment(d, t, search="greedy", params=SegmentParams(lookahead=False))
    look = segment(d, t, search="greedy", params=SegmentParams(lookahead=True))
    assert plain.sections == look.sections
    assert plain.skill_sequence != d.skill_sequence
    assert look.skill_sequence == d.skill_sequence


def test_dp_at_least_as_good_as_greedy_on_exp3() -> None:
    d = demo(EXP3)
    g = all_metrics(segment(d, search="greedy", grammar="enforce").segments, d.labels)
    p = all_metrics(segment(d, search="dp", grammar="enforce").segments, d.labels)
    assert p["sequence_match"] == 1.0
    assert p["frame_accuracy"] >= g["frame_accuracy"] - 0.02


def test_baselines_cover_the_demo_and_are_worse_on_exp2() -> None:
    d = demo(EXP2)
    ours = all_metrics(segment(d, search="dp").segments, d.labels)
    for fn in (proximity_segmentation, gripper_segmentation):
        r = fn(d)
        assert r.segments[0].start == 0
        assert all(s.skill in SKILLS for s in r.segments)
        m = all_metrics(r.segments, d.labels)
        assert m["sequence_match"] == 0.0
        assert m["frame_accuracy"] < ours["frame_accuracy"]


def test_result_json_is_a_task_program() -> None:
    r = segment(demo())
    doc = json.loads(r.to_json())
    assert doc["format_version"] == 2
    assert [s["skill"] for s in doc["segments"]] == r.skill_sequence
    assert {"start_s", "end_s", "object", "score", "confidence", "params"} <= set(
        doc["segments"][0]
    )


# --- engine functions on numpy arrays --------------------------------------------------------
def test_stage1_boundaries_on_a_synthetic_signal() -> None:
    n = 100
    values = np.zeros((n, 10))
    values[30:70, 0] = 1.0  # fingertip distance above its threshold in 30..70
    values[50:, 9] = 1.0  # hand speed above its threshold from 50
    thresholds = np.full((n, 10), 0.5)
    b = _hmmseg.stage1_boundaries(values, thresholds, [0, 9], [0.1, 0.1], 5)
    assert b.tolist() == [0, 30, 50, 70, 100]


def test_greedy_and_dp_on_a_constructed_table() -> None:
    # 4 sections of 10 samples; pick_up on 0..2 and move_with on 2..4 are the only good runs
    skills = list(SKILLS)
    b = np.arange(0, 41, 10, dtype=np.int64)
    scores = np.full((4, 5, len(skills)), -5.0)
    for i in range(4):
        for j in range(5):
            scores[i, j] *= max(j - i, 0) * 10
    scores[0, 2, skills.index("pick_up")] = 0.0
    scores[2, 4, skills.index("move_with")] = 0.0
    rules = compiled_grammar(tuple(skills), False)
    for fn in (_hmmseg.segment_greedy, _hmmseg.segment_dp):
        cuts, warnings = fn(scores, b, rules, None, "enforce")
        assert [
            (skills[c.skill], c.start_section, c.end_section, c.start, c.end) for c in cuts
        ] == [
            ("pick_up", 0, 2, 0, 20),
            ("move_with", 2, 4, 20, 40),
        ]
        assert [c.score for c in cuts] == [0.0, 0.0]
        assert all(c.margin > 0 and 0.5 < c.confidence <= 1 for c in cuts)
        assert warnings == []


def test_rising_table() -> None:
    z = np.concatenate([np.zeros(10), np.linspace(0, 0.1, 10), np.full(10, 0.1)])
    r = _hmmseg.rising_table(z, np.array([0, 10, 20, 30]), 0.02, 0.0)
    assert r.shape == (3, 4)
    assert r[1, 2] and r[0, 3] and not r[0, 1] and not r[2, 3]


def test_band_holds_the_runs_of_at_most_max_len_samples() -> None:
    from lfd.segmentation.band import Band

    # sections of 3, 4, 5, 2 samples, runs of at most 7: 0..2 fits, 0..3 does not; a single
    # section is a run however long
    band = Band.of([0, 3, 7, 12, 14], 7)
    assert band.last.tolist() == [2, 2, 4, 4]
    runs = list(zip(band.start.tolist(), band.end.tolist(), strict=True))
    assert runs == [(0, 1), (0, 2), (1, 2), (2, 3), (2, 4), (3, 4)]
    assert [band.index(i, j) for i, j in runs] == list(range(6))
    assert band.index(0, 3) is None and band.index(2, 2) is None and band.index(3, 5) is None
    assert band.ends(2).tolist() == [3, 4] and band.rows(2) == slice(3, 5)
    values = np.arange(12.0).reshape(6, 2)
    dense = band.dense(values)
    assert dense.shape == (4, 5, 2) and dense[2, 4, 1] == 9.0 and dense[0, 3, 0] == -np.inf
    np.testing.assert_array_equal(band.take(dense), values)
    assert Band.of([0, 3, 7, 12, 14], 0).n_runs == 10  # no bound: every run
    assert Band.of([0, 10, 11], 5).n_runs == 2
    # the view holds the engine's band: its arrays, its row numbers
    engine = _hmmseg.Band(np.array([0, 3, 7, 12, 14]), 7)
    assert (engine.n_sections, engine.n_runs, engine.max_len) == (4, 6, 7)
    np.testing.assert_array_equal(engine.boundaries, band.bounds)
    np.testing.assert_array_equal(engine.last_ends, band.last)
    np.testing.assert_array_equal(engine.offsets, band.offsets)
    assert [engine.index(i, j) for i, j in runs] == list(range(6))
    assert engine.index(0, 3) is None and engine.index(-1, 1) is None
    assert engine == _hmmseg.Band(np.array([0, 3, 7, 12, 14]), 7)
    assert engine != _hmmseg.Band(np.array([0, 3, 7, 12, 14]), 0)
    with pytest.raises(InvalidParameterError, match="strictly increasing"):
        Band.of([0, 3, 3, 5], 7)
    with pytest.raises(ShapeMismatchError, match="at least 2 values"):
        Band.of([0], 7)


def test_banded_engine_functions_agree_with_the_dense_ones() -> None:
    from lfd.segmentation.band import Band

    rng = np.random.default_rng(3)
    skills = list(SKILLS)
    b = np.r_[0, np.cumsum(rng.integers(3, 12, 40))].astype(np.int64)
    n, k = int(b[-1]), len(b) - 1
    max_len = 30
    band = Band.of(b, max_len)
    rules = compiled_grammar(tuple(skills), False)
    assert band.n_runs < k * (k + 1) // 2
    # a dense table holding -inf outside the band, like the score tables
    dense = np.full((k, k + 1, len(skills)), -np.inf)
    dense[band.start, band.end] = (
        -rng.uniform(1, 5, (band.n_runs, len(skills))) * (b[band.end] - b[band.start])[:, None]
    )
    z = np.cumsum(rng.normal(0, 0.01, n))
    rising = _hmmseg.rising_table(z, b, 0.02, 0.0)
    rising_band = _hmmseg.rising_band(z, b, max_len, 0.02, 0.0)
    np.testing.assert_array_equal(rising_band, rising[band.start, band.end])
    for mode in ("off", "warn", "enforce"):
        for lookahead in (False, True):
            assert _hmmseg.segment_greedy(
                band.take(dense), b, rules, rising_band, mode, lookahead, max_len
            ) == _hmmseg.segment_greedy(dense, b, rules, rising, mode, lookahead)
        assert _hmmseg.segment_dp(
            band.take(dense), b, rules, rising_band, mode, 5.0, max_len
        ) == _hmmseg.segment_dp(dense, b, rules, rising, mode, 5.0)
    # the layouts must match: a band of another length, a dense rise table, max_len with a
    # dense table
    with pytest.raises(ShapeMismatchError):
        _hmmseg.segment_dp(band.take(dense), b, rules, None, "warn", 0.0, 20)
    with pytest.raises(ShapeMismatchError):
        _hmmseg.segment_dp(band.take(dense), b, rules, rising, "warn", 0.0, 30)
    with pytest.raises(InvalidParameterError):
        _hmmseg.segment_dp(dense, b, rules, rising, "warn", 0.0, 30)
    # the template scores: the band is the dense table's entries
    t = Templates.default()
    x = np.ascontiguousarray(rng.uniform(0, 1, (n, 10)) * (t.ranges[:, 1] - t.ranges[:, 0]))
    x += t.ranges[:, 0]
    full = t.engine.score_table(x, b, max_len, "final", [0, 2])
    banded = t.engine.score_band(x, b, max_len, "final", [0, 2])
    np.testing.assert_array_equal(banded, band.take(full))
    np.testing.assert_array_equal(band.dense(band.take(full)), full)  # -inf outside the band


def test_banded_co_motion_penalty_is_the_dense_one_on_the_band() -> None:
    from lfd.segmentation.band import Band
    from lfd.segmentation.comotion import co_motion_penalty

    rng = np.random.default_rng(5)
    n, skills = 300, list(SKILLS)
    moving = rng.random((3, n)) < 0.2
    lifted = np.cumsum(rng.random((3, n)) < 0.05, axis=1) % 2 == 1
    b = np.r_[0, np.cumsum(rng.integers(2, 15, 60))]
    b = [*b[b < n].tolist(), n]
    band = Band.of(b, 40)
    for grace in (0, 2):
        dense = co_motion_penalty(moving, np.array(b), skills, 20.0, lifted=lifted, grace=grace)
        banded = co_motion_penalty(
            moving, np.array(b), skills, 20.0, lifted=lifted, grace=grace, band=band
        )
        assert dense is not None and banded is not None
        assert banded.shape == (3, band.n_runs, len(skills))
        np.testing.assert_array_equal(banded, dense[:, band.start, band.end])


def test_scores_in_pieces_are_those_of_the_whole_band() -> None:
    """The stage-2 band built from pieces of a few sections (each over its own samples) holds
    the entries of the whole band, bit for bit, and so do the co-motion rows."""
    from lfd.features import compute_features
    from lfd.preprocessing import preprocess
    from lfd.segmentation.band import Band
    from lfd.segmentation.comotion import co_motion_per_object, moving_objects
    from lfd.segmentation.gaps import fill_gaps
    from lfd.segmentation.stage2 import scores_over_objects, shared_features

    traj, _ = fill_gaps(preprocess(demo()))
    t = Templates.default()
    values = [compute_features(traj, target=o).values for o in range(len(traj.object_names))]
    b = np.r_[0 : len(traj) : 9, len(traj)].astype(np.int64)
    band = Band.of(b, 40)
    moving = moving_objects(traj, 1 / 6, 0.015)
    extra = co_motion_per_object(
        moving, b, t.skills, 20.0, lifted=moving, slide=3.0, hand=moving[0], left=2.0, band=band
    )
    assert extra is not None
    whole = extra(1)
    r1 = band.n_runs - 5
    np.testing.assert_array_equal(extra.rows(1, 17, r1), whole[17:r1])
    table = np.full((r1 - 17, len(t.skills)), 1.5)
    extra.add_rows(1, 17, r1, table)
    np.testing.assert_array_equal(table, 1.5 + whole[17:r1])
    shared = shared_features(values, t)
    assert shared and len(shared) < len(t.features)
    for end in ("final", "any"):
        ref = scores_over_objects(values, t, band, end, extra=extra, chunk=10**9)
        for chunk in (1, 50, 333):
            got = scores_over_objects(values, t, band, end, extra=extra, chunk=chunk)
            assert got.scores.tobytes() == ref.scores.tobytes()
            np.testing.assert_array_equal(got.target, ref.target)
        # an (O, N, S) array of the extra evidence gives the same
        stacked = np.stack([extra(o) for o in range(len(values))])
        got = scores_over_objects(values, t, band, end, extra=stacked, chunk=50)
        assert got.scores.tobytes() == ref.scores.tobytes()


# --- templates -------------------------------------------------------------------------------
def test_default_templates_ship_with_the_package() -> None:
    t = Templates.default()
    assert set(t.skills) == set(SKILLS)
    assert len(t.features) == 8
    assert t.preprocessing == {
        "feature_cutoff_hz": "auto",
        "object_cutoff_hz": 10.0,
        "aperture": "grasp",
        "min_keypoint_confidence": 0.0,  # trained before the hand's confidence was used
    }


def test_train_save_load_round_trip(tmp_path: Path) -> None:
    files = [TEMPLATE_DIR / f"{s}_0.mcap" for s in SKILLS]
    t = train_templates(files, params={"fit": {"max_iter": 5}})
    once = train_templates(
        files, params={"fit": {"max_iter": 5}}, frame_symmetry=1, min_keypoint_confidence=0.3
    )
    assert all(n >= 1 for n in once.engine.n_examples)
    assert list(t.engine.n_examples) == [FRAME_SYMMETRY * n for n in once.engine.n_examples]
    assert t.meta["frame_symmetry"] == FRAME_SYMMETRY
    with pytest.raises(ValueError, match="frame_symmetry"):
        train_templates(files, frame_symmetry=0)
    path = tmp_path / "t.json"
    t.save(path)
    back = Templates.load(path)
    assert back.skills == t.skills
    assert np.allclose(back.ranges, t.ranges)
    r = segment(demo(), back)
    assert len(r.segments) >= 4
    # the confidence threshold is stored with the templates and used again when they segment
    assert back.preprocessing["min_keypoint_confidence"] == 0.0
    once.save(tmp_path / "once.json")
    back_once = Templates.load(tmp_path / "once.json")
    assert back_once.preprocessing["min_keypoint_confidence"] == 0.3
    r = segment(demo(), back_once)
    assert not any("preprocessed differently" in w for w in r.warnings), r.warnings


def test_cli_templates_train_stores_the_confidence_threshold(tmp_path: Path) -> None:
    from lfd.cli import main

    files = [str(TEMPLATE_DIR / f"{s}_0.mcap") for s in SKILLS]
    fast = ["--params", '{"fit": {"max_iter": 2}}']
    assert main(["templates", "train", *files, "-o", str(tmp_path / "a.json"), *fast]) == 0
    args = ["--min-keypoint-confidence", "0.3"]
    assert main(["templates", "train", *files, "-o", str(tmp_path / "b.json"), *fast, *args]) == 0
    a, b = Templates.load(tmp_path / "a.json"), Templates.load(tmp_path / "b.json")
    assert a.preprocessing["min_keypoint_confidence"] == 0.0
    assert b.preprocessing["min_keypoint_confidence"] == 0.3
    assert a.engine.to_json() != b.engine.to_json()  # the examples were preprocessed differently


def test_turn_object_frame_turns_only_the_horizontal_tcp_in_object() -> None:
    x = np.arange(20, dtype=np.float64).reshape(2, 10)
    q = turn_object_frame(x, 1, 4)
    assert np.allclose(q[:, 5], -x[:, 6]) and np.allclose(q[:, 6], x[:, 5])
    keep = [c for c in range(10) if c not in (5, 6)]
    assert np.array_equal(q[:, keep], x[:, keep])
    assert np.allclose(turn_object_frame(x, 4, 4), x)
    assert np.allclose(turn_object_frame(turn_object_frame(x, 1, 4), 3, 4), x)


def test_template_file_errors(tmp_path: Path) -> None:
    doc = json.loads(Templates.default().to_json())
    bad = dict(doc, format_version=99)
    (tmp_path / "v.json").write_text(json.dumps(bad))
    with pytest.raises(ModelFormatError, match="format_version 99"):
        Templates.load(tmp_path / "v.json")
    unknown = dict(doc, skills=["fly", *doc["skills"][1:]])
    (tmp_path / "u.json").write_text(json.dumps(unknown))
    with pytest.raises(ModelFormatError, match="fly"):
        Templates.load(tmp_path / "u.json")
    (tmp_path / "x.json").write_text("{not json")
    with pytest.raises(ModelFormatError):
        Templates.load(tmp_path / "x.json")
    with pytest.raises(ModelFormatError):
        Templates.load(tmp_path / "missing.json")


@pytest.mark.parametrize(
    ("edit", "match"),
    [
        (lambda d: d["ranges"].__setitem__(0, [1.0, 0.0]), "range of column 0 is .* inverted"),
        (lambda d: d["ranges"].__setitem__(3, [0.5, 0.5]), "range of column 3 .* empty"),
        (lambda d: d["ranges"].pop(), "9 ranges for 10 columns"),
        (lambda d: d["n_examples"].pop(), "example counts"),
        (lambda d: d["features"][0].update(end=0), "columns 0..1 of the feature matrix"),
        (lambda d: d["params"]["fit"].update(n_states=0), "n_states must be >= 1"),
        (lambda d: d["params"]["fit"].update(extra=1), "unknown field `extra`"),
        (lambda d: d.update(skills=7), "invalid type: integer `7`"),
        (lambda d: d["models"][0].pop(), "models do not match"),
    ],
    ids=[
        "inverted",
        "empty",
        "count",
        "examples",
        "columns",
        "n_states",
        "field",
        "type",
        "models",
    ],
)
def test_template_file_values_are_checked(tmp_path: Path, edit, match: str) -> None:  # type: ignore[no-untyped-def]
    """A template file that reads but would segment wrongly (exp1 as push/move x4 with
    inverted ranges) is refused when loaded."""
    doc = json.loads(Templates.default().to_json())
    edit(doc)
    path = tmp_path / "t.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(ModelFormatError, match=match):
        Templates.load(path)


def test_binary_template_file_is_a_format_error(tmp_path: Path) -> None:
    path = tmp_path / "t.json"
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(range(256)))
    with pytest.raises(ModelFormatError, match="not a template file"):
        Templates.load(path)


def test_template_params_are_checked_before_training() -> None:
    """Bad --params are refused before any recording is read (here: none exists)."""
    from lfd.errors import InvalidParameterError
    from lfd.segmentation.templates import template_params

    missing = [TEMPLATE_DIR / "no_such_file.mcap"]
    for params, match in [
        ({"fit": {"n_states": 0}}, "n_states must be >= 1"),
        ({"fit": {"covariance_floor": -1.0}}, "covariance_floor"),
        ({"fit": {"n_mix": 1.5}}, "fit.n_mix"),
        ({"fit": {"max_iter": -1}}, "fit.max_iter"),
        ({"fit": {"bogus": 1}}, "unknown template parameter `fit.bogus`"),
        ({"bogus": {"x": 1}}, "unknown template parameter `bogus`"),
        ({"fit": {"tol": float("nan")}}, "not plain JSON"),
        ({"align": "yes"}, "template parameter `align`"),
    ]:
        with pytest.raises(InvalidParameterError, match=match):
            train_templates(missing, params=params)
    full = json.loads(template_params({"fit": {"n_states": 6}}))
    assert full["fit"]["n_states"] == 6
    assert full["fit"]["n_mix"] == json.loads(_hmmseg.default_template_params())["fit"]["n_mix"]
    assert json.loads(template_params(None)) == json.loads(_hmmseg.default_template_params())


def test_template_model_sizes_are_bounded() -> None:
    """n_states at most 64 and n_mix at most 16 (the shipped templates: 4 and 2), refused
    before any recording is read: 3000 states trained for minutes, n_mix 1e6 was refused only
    after loading every recording."""
    from lfd.errors import InvalidParameterError
    from lfd.segmentation.templates import template_params

    for params, match in [
        ({"fit": {"n_states": 3000}}, "fit: n_states must be at most 64, got 3000"),
        ({"fit": {"n_states": 65}}, "n_states must be at most 64"),
        ({"fit": {"n_mix": 1_000_000}}, "fit: n_mix must be at most 16, got 1000000"),
        ({"fit": {"n_mix": 17}}, "n_mix must be at most 16"),
    ]:
        with pytest.raises(InvalidParameterError, match=match):
            template_params(params)
    assert json.loads(template_params({"fit": {"n_states": 64, "n_mix": 16}}))["fit"]["n_mix"] == 16


# --- bad input -------------------------------------------------------------------------------
def test_no_hand_data_is_a_clear_error() -> None:
    d = demo()
    kp = np.full_like(d.hand.keypoints, np.nan)
    d.hand = HandTrack(d.hand.t_ns, kp, np.zeros_like(d.hand.confidence))
    with pytest.raises(DemonstrationError, match="no hand data"):
        segment(d)


def test_trajectory_filtered_differently_from_the_templates_warns() -> None:
    from lfd.preprocessing import preprocess

    r = segment(preprocess(demo(), feature_cutoff_hz=0.625), search="dp")
    assert "preprocessed differently" in r.warnings[0]
    assert "feature_cutoff_hz=0.625 (templates: 'auto')" in r.warnings[0]


def test_too_short_for_any_skill() -> None:
    from lfd.preprocessing import preprocess

    traj = preprocess(demo(), feature_cutoff_hz=2.0)
    short = dataclasses.replace(
        traj,
        t_ns=traj.t_ns[:10],
        tcp=traj.tcp[:10],
        rotation=traj.rotation[:10],
        euler=traj.euler[:10],
        opening=traj.opening[:10],
        keypoints=traj.keypoints[:10],
        object_position=traj.object_position[:, :10],
        object_quaternion=traj.object_quaternion[:, :10],
        hand_valid=traj.hand_valid[:10],
        object_valid=traj.object_valid[:, :10],
    )
    with pytest.raises(DemonstrationError, match="too short"):
        segment(short)


def test_nan_stretch_is_interpolated_with_a_warning() -> None:
    from lfd.preprocessing import preprocess

    traj = preprocess(demo(), feature_cutoff_hz=2.0)
    tcp = traj.tcp.copy()
    opening = traj.opening.copy()
    tcp[100:115] = np.nan
    opening[100:115] = np.nan
    valid = traj.hand_valid.copy()
    valid[100:115] = False
    holed = dataclasses.replace(traj, tcp=tcp, opening=opening, hand_valid=valid)
    r = segment(holed, search="dp")
    assert any("not tracked" in w for w in r.warnings)
    assert r.skill_sequence == demo().skill_sequence


# --- evaluation and CLI ----------------------------------------------------------------------
def test_evaluate_one_recording() -> None:
    rep = evaluate([EXP1], methods=("dp", "gripper"))
    assert len(rep.recordings) == 1
    summary = rep.summary()
    assert summary["dp"]["sequence_match"] == 1.0
    assert summary["dp"]["n"] == 1.0
    assert json.dumps(rep.to_dict())


def test_cli_segment_writes_json(tmp_path: Path) -> None:
    out = tmp_path / "seg.json"
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "lfd.cli",
            "segment",
            str(EXP1),
            "--search",
            "dp",
            "--json",
            str(out),
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(out.read_text())
    assert [s["skill"] for s in doc["segments"]] == [g["skill"] for g in doc["ground_truth"]]
    assert doc["metrics"]["sequence_match"] == 1.0
    assert "pick_up" in proc.stdout and "Pick up" not in proc.stdout  # one spelling everywhere


def test_augment_scales_object_distance_of_layout_free_skills() -> None:
    from lfd.segmentation.templates import LAYOUT_SCALES, OBJECT_DISTANCE, augment

    x = np.random.default_rng(0).uniform(0.1, 0.3, (12, 10))
    skills = ["push", "stack"]
    data = augment([("push", x), ("stack", x), ("locate", x)], skills, 2, (1.5, 2.0))
    # push: itself and 2 scaled copies, stack: itself; each turned twice; locate left out
    assert [k for k, _ in data] == [0, 0, 1, 1, 0, 0, 0, 0]
    dist = [float(y[0, OBJECT_DISTANCE] / x[0, OBJECT_DISTANCE]) for k, y in data if k == 0]
    assert np.allclose(sorted(set(np.round(dist, 6))), [1.0, 1.5, 2.0])
    # nothing but object_distance (and the turned TCP columns) changes
    others = [c for c in range(10) if c not in (OBJECT_DISTANCE, 5, 6)]
    assert all(np.array_equal(y[:, others], x[:, others]) for _, y in data)
    assert len(augment([("push", x)], skills, 1, ())) == 1
    assert LAYOUT_SCALES and min(LAYOUT_SCALES) > 1
    with pytest.raises(InvalidParameterError, match="layout scales"):
        augment([("push", x)], skills, 1, (0.0,))


def test_shipped_templates_read_a_push_far_from_the_other_boxes() -> None:
    """object_distance says how the scene is laid out, not what a Push does: each template
    demo's Push with its box twice as far from the others still scores as a Push, above a Move
    with (templates trained without the layout copies scored 6 of the 9 below)."""
    from lfd.segmentation.templates import OBJECT_DISTANCE, recording_examples

    t = Templates.default()
    push, carry = t.skills.index("push"), t.skills.index("move_with")
    paths = sorted((ROOT / "recordings" / "templates").glob("push_*.mcap"))
    assert len(paths) == 9
    for path in paths:
        _, examples = recording_examples(path, preprocessing=t.preprocessing)
        x = next(x for skill, x in examples if skill == "push").copy()
        x[:, OBJECT_DISTANCE] *= 2.0
        row = t.engine.score_table(np.ascontiguousarray(x), np.array([0, len(x)]))[0, 1]
        assert row[push] > row[carry] + 2.0 * len(x), path.name
