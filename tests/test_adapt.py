"""Templates adapted to a user's labelled recordings, and leave-one-out evaluation."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from lfd.errors import UsageError
from lfd.segmentation import Templates
from lfd.segmentation.adapt import adapt_templates
from lfd.segmentation.evaluate import leave_one_out
from lfd.segmentation.templates import collect_examples

ROOT = Path(__file__).resolve().parents[1]
REC = ROOT / "recordings"


@pytest.fixture(scope="module")
def exp1_examples() -> tuple[list[str], list[tuple[str, object]]]:
    return collect_examples([REC / "exp1.mcap"])


def test_adapted_models_move_and_others_stay(exp1_examples, tmp_path: Path) -> None:
    names, examples = exp1_examples
    base = Templates.default()
    adapted = adapt_templates(base, examples, names=names)  # type: ignore[arg-type]
    b, a = json.loads(base.engine.to_json()), json.loads(adapted.engine.to_json())
    shown = {s for s, _ in examples}  # type: ignore[misc]
    assert shown == {"pick_up", "move_with", "place", "move", "stack"}
    for si, skill in enumerate(base.skills):
        same = [a["models"][si][fi] == b["models"][si][fi] for fi in range(len(base.features))]
        if skill in shown:
            assert not all(same), skill
            assert a["n_examples"][si] > b["n_examples"][si]
        else:
            assert all(same), skill  # locate, push: the base's models bit for bit
            assert a["n_examples"][si] == b["n_examples"][si]
    assert a["ranges"] == b["ranges"] and a["params"] == b["params"]
    assert adapted.meta["adapted_from"] == "default"
    assert adapted.meta["adapted_on"] == ["exp1.mcap"]
    assert adapted.meta["adapt_examples"]["pick_up"] == 2
    out = tmp_path / "t.json"
    adapted.save(out)
    assert Templates.load(out).meta["adapt_examples"] == adapted.meta["adapt_examples"]


def test_adapting_to_a_recording_fits_it_better(exp1_examples) -> None:
    """The adapted models explain the user's segments at least as well as the base's."""
    from lfd import _hmmseg

    names, examples = exp1_examples
    base = Templates.default()
    adapted = adapt_templates(base, examples, names=names, prior=0)  # type: ignore[arg-type]
    b, a = json.loads(base.engine.to_json()), json.loads(adapted.engine.to_json())
    si = base.skills.index("pick_up")
    xs = [base.engine.normalise(x) for s, x in examples if s == "pick_up"]  # type: ignore[misc]
    gain = 0.0
    for fi, (_, c0, c1) in enumerate(base.features):
        hb = _hmmseg.Hmm.from_json(json.dumps(b["models"][si][fi]))
        ha = _hmmseg.Hmm.from_json(json.dumps(a["models"][si][fi]))
        gain += sum(
            ha.log_likelihood(x[:, c0:c1].copy()) - hb.log_likelihood(x[:, c0:c1].copy())
            for x in xs
        )
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
