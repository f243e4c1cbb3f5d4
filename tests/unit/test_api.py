"""The public API: every call the README shows works repeatedly, in any import order, in a
fresh interpreter, and type checkers see what it returns."""

from __future__ import annotations

import inspect
import json
import subprocess
import sys
import textwrap
from pathlib import Path

import _paths
import pytest

ROOT = _paths.ROOT
EXP3 = ROOT / "recordings" / "exp3.mcap"

# Imports a user might do before calling the functions; each used to replace lfd.segment or
# lfd.preprocess by a package, or to leave lfd.io missing.
IMPORT_ORDERS = [
    "import lfd",
    "import lfd.segmentation, lfd",
    "import lfd.preprocessing.pipeline, lfd",
    "import lfd; import lfd.segmentation.metrics; import lfd.preprocessing.filters",
    "from lfd.segmentation import segment as _s; import lfd.preprocessing; import lfd",
    "import lfd.viz, lfd",
]


def fresh(code: str) -> subprocess.CompletedProcess[str]:
    """Run ``code`` in a new interpreter (nothing imported before it)."""
    return subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)],
        capture_output=True,
        text=True,
        cwd=ROOT,
        check=False,
        timeout=300,
    )


@pytest.mark.parametrize("imports", IMPORT_ORDERS)
def test_functions_work_repeatedly_in_any_import_order(imports: str) -> None:
    proc = fresh(
        f"""
        {imports}
        import lfd
        demo = lfd.load({str(EXP3)!r})
        for _ in range(2):
            traj = lfd.preprocess(demo)
            result = lfd.segment(demo)
            assert isinstance(traj, lfd.Trajectory), type(traj)
            assert isinstance(result, lfd.Segmentation), type(result)
            assert result.skill_sequence == demo.skill_sequence, result.skill_sequence
            import lfd.segmentation, lfd.preprocessing  # packages never replace the functions
        assert callable(lfd.segment) and callable(lfd.preprocess)
        assert lfd.io.load is lfd.load and lfd.segmentation.segment is lfd.segment
        print("ok")
        """
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "ok"


def test_every_public_name_is_there_after_import_lfd() -> None:
    proc = fresh(
        """
        import lfd
        missing = [n for n in lfd.__all__ if not hasattr(lfd, n)]
        assert not missing, missing
        for mod in ("io", "preprocessing", "segmentation", "errors"):
            assert type(getattr(lfd, mod)).__name__ == "module", mod
        print("ok")
        """
    )
    assert proc.returncode == 0, proc.stderr


def test_segment_signature_and_help_show_the_real_function() -> None:
    import pydoc

    import lfd

    sig = inspect.signature(lfd.segment)
    assert sig.parameters["method"].default is None  # lfd.Method.default()
    assert lfd.Method.default().search == "dp" and lfd.Method.default().grammar == "enforce"
    assert sig.parameters["search"].kind is inspect.Parameter.KEYWORD_ONLY
    text = pydoc.render_doc(lfd.segment, renderer=pydoc.plaintext)
    assert "method" in text and "search" in text and "grammar" in text
    assert len(text.splitlines()) < 80  # the function's documentation, not a whole package
    assert inspect.signature(lfd.preprocess).parameters


def test_paper_options_select_the_papers_algorithm() -> None:
    import lfd
    from lfd.segmentation import PAPER

    demo = lfd.load(EXP3)
    paper = lfd.segment(demo, **PAPER)
    assert paper.method == "greedy"
    assert lfd.segment(demo).method == "dp"
    by_name = lfd.segment(demo, method="paper")  # the same method as a value
    assert by_name.method == "greedy" and by_name.skill_sequence == paper.skill_sequence


def test_confidence_is_a_probability_and_margin_the_raw_score_gap() -> None:
    import math

    import lfd

    result = lfd.segment(lfd.load(ROOT / "recordings" / "exp1.mcap"))
    for s in result.segments:
        assert 0.0 <= s.confidence <= 1.0, s
        # a rival at least as likely caps the posterior at one half
        if s.margin <= 0:
            assert s.confidence <= 0.5
        if math.isinf(s.margin):
            assert s.confidence == 1.0
    doc = result.to_dict()
    assert doc["format_version"] == 2
    assert all(0.0 <= seg["confidence"] <= 1.0 for seg in doc["segments"])
    assert all("margin" in seg for seg in doc["segments"])


@pytest.mark.slow  # runs mypy on a script (mypy python/lfd runs in CI's lint step)
def test_type_checker_sees_real_return_types(tmp_path: Path) -> None:
    from mypy import api

    snippet = tmp_path / "snippet.py"
    snippet.write_text(
        textwrap.dedent(
            """
            import lfd
            demo = lfd.load("x.mcap")
            reveal_type(lfd.preprocess(demo))
            reveal_type(lfd.segment(demo))
            reveal_type(lfd.segment(demo, search="greedy", grammar="warn").segments[0].confidence)
            """
        )
    )
    out, err, status = api.run([str(snippet), "--no-incremental", "--cache-dir", str(tmp_path)])
    assert "lfd.trajectory.Trajectory" in out, out + err
    assert "lfd.segmentation.result.Segmentation" in out, out + err
    assert 'Revealed type is "float"' in out or 'Revealed type is "builtins.float"' in out, out
    assert status == 0 and "Success" in out, out + err


def test_a_method_is_a_value_saved_with_its_templates(tmp_path: Path) -> None:
    """lfd.Method: loadable by name or file, saved with the templates, shown in --json."""
    import dataclasses

    import lfd
    from lfd.errors import InvalidParameterError, ModelFormatError

    paper = lfd.Method.load("paper")
    assert (paper.search, paper.grammar, paper.params.contacts) == ("greedy", "warn", None)
    custom = dataclasses.replace(lfd.Method.default(), name="mine", grammar="warn")
    path = tmp_path / "mine.json"
    custom.save(path)
    back = lfd.Method.load(path)
    assert (back.name, back.grammar, back.params) == ("mine", "warn", custom.params)
    assert back.preprocessing == lfd.Method.default().preprocessing
    result = lfd.segment(lfd.load(EXP3), method=back)
    doc = result.report()
    assert doc["method_detail"]["name"] == "mine" and doc["method_detail"]["grammar"] == "warn"
    assert result.run is not None and result.run.method is back
    with pytest.raises(InvalidParameterError, match="neither"):
        lfd.Method.load(tmp_path / "missing.json")
    with pytest.raises(InvalidParameterError, match="not both"):
        lfd.segment(lfd.load(EXP3), "paper", method="paper")
    bad = json.loads(path.read_text())
    bad["lfd"]["method"]["params"]["no_such_option"] = 1
    path.write_text(json.dumps(bad))
    with pytest.raises(ModelFormatError, match=r"lfd\.method"):
        lfd.Method.load(path)


def test_lfd_info_shows_a_method(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """`lfd info paper|default|FILE.json --json -` prints the method as `lfd.Method.describe`."""
    import lfd
    from lfd.cli import main

    assert main(["info", "paper", "--json", "-"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc == json.loads(json.dumps(lfd.Method.paper().describe()))
    assert main(["info", str(tmp_path / "none.json")]) == 2
    assert "neither" in capsys.readouterr().err
