"""Templates adapted to a user's labelled recordings, and leave-one-out evaluation."""

from __future__ import annotations

import json
from pathlib import Path

import _paths
import numpy as np
import pytest
from lfd.errors import UsageError
from lfd.segmentation import Templates
from lfd.segmentation.adapt import adapt_templates
from lfd.segmentation.evaluate import leave_one_out
from lfd.segmentation.templates import collect_examples

ROOT = _paths.ROOT
REC = ROOT / "recordings"


@pytest.fixture(scope="module")
def exp1_examples() -> tuple[list[str], list[tuple[str, object]]]:
    return collect_examples([REC / "exp1.mcap"])


def _raw_scores(t: Templates, x: np.ndarray) -> np.ndarray:
    """Per-skill log-likelihood of raw features ``x`` as a density of the raw values (the
    template scores are densities of the normalised values: add the log-Jacobian)."""
    lo, hi = t.ranges.T
    table = t.engine.score_table(np.ascontiguousarray(x), np.array([0, len(x)]), 0, "any")
    return np.asarray(table[0, 1] - len(x) * np.log(hi - lo).sum())


def test_adapted_models_move_and_others_stay(exp1_examples, tmp_path: Path) -> None:
    names, examples = exp1_examples
    base = Templates.default()
    adapted = adapt_templates(base, examples, names=names)  # type: ignore[arg-type]
    b, a = json.loads(base.engine.to_json()), json.loads(adapted.engine.to_json())
    shown = {s for s, _ in examples}  # type: ignore[misc]
    assert shown == {"pick_up", "move_with", "place", "move", "stack"}
    # the ranges only widen, to cover the user's data
    assert np.all(adapted.ranges[:, 0] <= base.ranges[:, 0])
    assert np.all(adapted.ranges[:, 1] >= base.ranges[:, 1])
    # raw samples inside the base's ranges: the skills without user examples (locate, push)
    # keep the base's models, carried exactly into the wider ranges
    x = np.clip(examples[0][1], base.ranges[:, 0] + 1e-9, base.ranges[:, 1] - 1e-9)  # type: ignore[index]
    before, after = _raw_scores(base, x), _raw_scores(adapted, x)
    for si, skill in enumerate(base.skills):
        if skill in shown:
            assert a["n_examples"][si] > b["n_examples"][si]
            assert after[si] != pytest.approx(before[si], abs=1e-6), skill
        else:
            assert after[si] == pytest.approx(before[si], abs=1e-6), skill
            assert a["n_examples"][si] == b["n_examples"][si]
    assert a["params"] == b["params"]
    assert adapted.meta["adapted_from"] == "default"
    assert adapted.meta["adapted_on"] == ["exp1.mcap"]
    assert adapted.meta["adapt_examples"]["pick_up"] == 2
    out = tmp_path / "t.json"
    adapted.save(out)
    assert Templates.load(out).meta["adapt_examples"] == adapted.meta["adapt_examples"]


def test_adapting_to_a_recording_fits_it_better(exp1_examples) -> None:
    """The adapted templates explain the user's segments, each under its own skill, better than
    the base's (in all: on exp1 of simulator 1.3 the Pick ups alone lose 75 nats while the whole
    recording gains 1086; on exp2-4 the Pick ups gain too)."""
    names, examples = exp1_examples
    base = Templates.default()
    adapted = adapt_templates(base, examples, names=names, prior=0)  # type: ignore[arg-type]
    gain = 0.0
    for s, x in examples:  # type: ignore[misc]
        k = base.skills.index(s)
        x = np.clip(x, base.ranges[:, 0] + 1e-9, base.ranges[:, 1] - 1e-9)
        gain += _raw_scores(adapted, x)[k] - _raw_scores(base, x)[k]
    assert gain > 0


def test_leave_one_out_from_scratch_needs_every_skill_elsewhere() -> None:
    with pytest.raises(UsageError, match="no other recording has an example"):
        leave_one_out([REC / "exp1.mcap", REC / "exp3.mcap"])


def test_leave_one_out_adapted_segments_every_recording() -> None:
    seen: list[str] = []
    report = leave_one_out(
        [REC / "exp1.mcap", REC / "exp2.mcap"], base=Templates.default(), progress=seen.append
    )
    assert [r.name for r in report.recordings] == ["exp1.mcap", "exp2.mcap"]
    assert seen == ["read exp1.mcap", "read exp2.mcap", "exp1.mcap", "exp2.mcap"]
    assert report.methods == ("dp",)
    overall = report.summary()["dp"]
    assert overall["n"] == 2
    assert overall["frame_accuracy"] > 0.8
