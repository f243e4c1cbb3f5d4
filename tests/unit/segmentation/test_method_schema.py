"""Method files have one validated schema (docs/method-files.md): every hostile file is one
line and exit status 2 wherever a method enters (``Method.load``, ``lfd info FILE.json``,
``lfd segment --templates``, ``lfd templates show``), the parameter dataclasses refuse the same
values with the same rule, and the shipped files still load and segment as before."""

from __future__ import annotations

import copy
import dataclasses
import json
import math
import pickle
from collections.abc import Callable
from pathlib import Path
from typing import Any

import lfd
import pytest
from lfd.contact import CONTACT_RULES, ContactParams
from lfd.errors import InvalidParameterError, LfdError, ModelFormatError
from lfd.segmentation import Method, SegmentParams, Stage1Params
from lfd.segmentation.schema import FORMAT_VERSION, SEGMENT_RULES
from lfd.segmentation.stage1 import STAGE1_RULES

ROOT = Path(__file__).resolve().parents[3]
SHIPPED = ROOT / "python" / "lfd" / "data" / "templates.json"
PAPER = ROOT / "python" / "lfd" / "data" / "templates_paper.json"
EXP1 = ROOT / "recordings" / "exp1.mcap"
BASE: dict[str, Any] = json.loads(SHIPPED.read_text())


def _method(**params: Any) -> Callable[[dict[str, Any]], None]:
    """A file with a saved method whose params hold ``params``."""

    def edit(doc: dict[str, Any]) -> None:
        doc["lfd"]["method"] = {"name": "mine", "search": "dp", "grammar": "enforce"}
        doc["lfd"]["method"]["params"] = params

    return edit


def _lfd(**keys: Any) -> Callable[[dict[str, Any]], None]:
    return lambda doc: doc["lfd"].update(keys)


def _entry(entry: Any) -> Callable[[dict[str, Any]], None]:
    return lambda doc: doc["lfd"].__setitem__("method", entry)


def _deep(depth: int) -> Any:
    x: Any = "recording.mcap"
    for _ in range(depth):
        x = [x]
    return x


NAN, INF = float("nan"), float("inf")

# (case, edit of the shipped file, what the message names)
HOSTILE: list[tuple[str, Callable[[dict[str, Any]], None], str]] = [
    ("penalty NaN", _method(penalty=NAN), "params.penalty"),
    ("penalty inf", _method(penalty=INF), "params.penalty"),
    ("penalty -inf", _method(penalty=-INF), "params.penalty"),
    ("penalty 1e308", _method(penalty=1e308), "params.penalty"),
    ("negative penalty", _method(penalty=-1e6), "params.penalty"),
    ("penalty a string", _method(penalty="abc"), "params.penalty"),
    ("penalty null", _method(penalty=None), "params.penalty"),
    ("lookahead 'no'", _method(lookahead="no"), "params.lookahead"),
    ("lookahead 0", _method(lookahead=0), "params.lookahead"),
    ("max_segment_s 1e308", _method(max_segment_s=1e308), "params.max_segment_s"),
    ("max_segment_s 0", _method(max_segment_s=0), "params.max_segment_s"),
    ("end unknown", _method(end="middle"), "params.end"),
    ("stage1 string field", _method(stage1={"min_section_s": "x"}), "stage1.min_section_s"),
    ("stage1 NaN field", _method(stage1={"min_section_s": NAN}), "stage1.min_section_s"),
    ("stage1 a number", _method(stage1=3), "params.stage1"),
    ("contacts rest_samples 3.0", _method(contacts={"rest_samples": 3.0}), "rest_samples"),
    ("contacts rest_samples 1e308", _method(contacts={"rest_samples": 1e308}), "rest_samples"),
    ("contacts a list", _method(contacts=[1, 2]), "params.contacts"),
    ("params a string", _entry({"params": "abc"}), "lfd.method.params"),
    ("params a list", _entry({"params": [1]}), "lfd.method.params"),
    ("method a string", _entry("dp"), "lfd.method"),
    ("method search unknown", _entry({"search": "beam"}), "lfd.method.search"),
    ("method grammar a bool", _entry({"grammar": True}), "lfd.method.grammar"),
    ("method name a number", _entry({"name": 3}), "lfd.method.name"),
    ("unknown params key", _method(penalti=3.0), "penalti"),
    ("unknown stage1 key", _method(stage1={"hysteresis": 0.1}), "hysteresis"),
    ("unknown method key", _entry({"serach": "dp"}), "serach"),
    ("unknown lfd key", _lfd(cutoff_hz=2.0), "cutoff_hz"),
    ("feature cut-off NaN", _lfd(feature_cutoff_hz=NAN), "feature_cutoff_hz"),
    ("feature cut-off 1e308", _lfd(feature_cutoff_hz=1e308), "feature_cutoff_hz"),
    ("feature cut-off a string", _lfd(feature_cutoff_hz="fast"), "feature_cutoff_hz"),
    ("object cut-off inf", _lfd(object_cutoff_hz=INF), "object_cutoff_hz"),
    ("object cut-off negative", _lfd(object_cutoff_hz=-2.0), "object_cutoff_hz"),
    ("object cut-off 1e-300", _lfd(object_cutoff_hz=1e-300), "lfd.object_cutoff_hz must be"),
    ("feature cut-off 1e-300", _lfd(feature_cutoff_hz=1e-300), "lfd.feature_cutoff_hz must be"),
    (
        "feature unknown",
        lambda doc: doc["features"][0].update(name="fingertip_distanse"),
        "features[0].name 'fingertip_distanse' is not a feature; known: fingertip_distance, ",
    ),
    (
        "feature on another's columns",
        lambda doc: doc["features"][2].update(start=0),
        "features[2] 'object_proximity' is columns 2..3 of the feature matrix, got 0..3",
    ),
    ("skills empty", lambda doc: doc.update(skills=[]), "template file: skills is empty"),
    (
        "skills and models empty",
        lambda doc: doc.update(skills=[], models=[], n_examples=[]),
        "template file: skills is empty",
    ),
    ("aperture unknown", _lfd(aperture="fist"), "aperture"),
    ("confidence 2", _lfd(min_keypoint_confidence=2), "min_keypoint_confidence"),
    ("confidence 'high'", _lfd(min_keypoint_confidence="high"), "min_keypoint_confidence"),
    ("frame symmetry 2.5", _lfd(frame_symmetry=2.5), "frame_symmetry"),
    ("trained_from nested deep", _lfd(trained_from=_deep(500)), "trained_from"),
    ("lfd a string", lambda doc: doc.__setitem__("lfd", "abc"), "lfd"),
    ("newer version", _lfd(format_version=FORMAT_VERSION + 1), "newer"),
    ("version a string", _lfd(format_version="1"), "format_version"),
]


@pytest.fixture(scope="module")
def hostile_files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("hostile")
    out = {}
    for i, (case, edit, _) in enumerate(HOSTILE):
        doc = copy.deepcopy(BASE)
        edit(doc)
        out[case] = root / f"case{i}.json"
        out[case].write_text(json.dumps(doc))  # NaN and Infinity as Python's json writes them
    deep = root / "deep.json"  # nested beyond what the JSON parser takes
    deep.write_text('{"lfd": ' + "[" * 100_000 + "]" * 100_000 + "}")
    out["nested 100000 deep"] = deep
    return out


CASES = [*(c for c, _, _ in HOSTILE), "nested 100000 deep"]
NAMES = {c: n for c, _, n in HOSTILE} | {"nested 100000 deep": "nested too deeply"}


@pytest.mark.parametrize("case", CASES)
def test_method_load_refuses_hostile_files_with_an_lfd_error(
    case: str, hostile_files: dict[str, Path]
) -> None:
    path = hostile_files[case]
    with pytest.raises(ModelFormatError) as info:
        Method.load(path)
    message = str(info.value)
    assert "\n" not in message and message.startswith(str(path))
    assert NAMES[case] in message


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize(
    "argv",
    [
        ["info", "{file}"],
        ["segment", str(EXP1), "--templates", "{file}"],
        ["segment", str(EXP1), "--paper", "--templates", "{file}"],
        ["templates", "show", "{file}"],
    ],
    ids=["info", "segment", "segment-paper", "templates-show"],
)
def test_cli_refuses_hostile_files_in_one_line(
    case: str, argv: list[str], hostile_files: dict[str, Path], lfd_main: Callable[..., Any]
) -> None:
    path = hostile_files[case]
    proc = lfd_main([a.replace("{file}", str(path)) for a in argv])
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith(f"lfd {argv[0]}: error: {path}: ")
    assert NAMES[case] in lines[0]


@pytest.mark.parametrize(
    ("params", "names"),
    [
        ("[" * 65_000 + "]" * 65_000, "nested too deeply"),
        ('{"fit": {"n_states": NaN}}', "not plain JSON"),
        ('{"fit": {"n_states": 1e308}}', "n_states"),
        ('"abc"', "must be a dict"),
        ("[1, 2]", "must be a dict"),
        ('{"fit": {"n_state": 3}}', "n_state"),
        ("{not json", "not valid JSON"),
    ],
    ids=["deep", "nan", "1e308", "string", "list", "unknown key", "not json"],
)
def test_templates_train_refuses_hostile_params_in_one_line(
    params: str, names: str, tmp_path: Path, lfd_main: Callable[..., Any]
) -> None:
    out = tmp_path / "t.json"
    argv = ["templates", "train", str(ROOT / "recordings" / "templates"), "-o", str(out)]
    proc = lfd_main([*argv, "--params", params])
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("lfd templates: error: "), proc.stderr
    assert names in lines[0]
    assert not out.exists()


@pytest.mark.parametrize(
    ("make", "name"),
    [
        (lambda: ContactParams(rest_samples=3.0), "contacts.rest_samples"),  # type: ignore[arg-type]
        (lambda: ContactParams(min_move=True), "contacts.min_move"),
        (lambda: ContactParams(approach_m=NAN), "contacts.approach_m"),
        (lambda: Stage1Params(min_section_s=math.inf), "stage1.min_section_s"),
        (lambda: Stage1Params(object_criteria="no"), "stage1.object_criteria"),  # type: ignore[arg-type]
        (lambda: SegmentParams(penalty=-1e6), "params.penalty"),
        (lambda: SegmentParams(lookahead="no"), "params.lookahead"),  # type: ignore[arg-type]
        (lambda: SegmentParams(max_segment_s=1e308), "params.max_segment_s"),
        (lambda: SegmentParams(stage1={"min_section_s": 0.1}), "params.stage1"),  # type: ignore[arg-type]
        (lambda: SegmentParams(end="middle"), "params.end"),  # type: ignore[arg-type]
        (lambda: Method(search="beam"), "method.search"),  # type: ignore[arg-type]
        (lambda: Method(params="abc"), "method.params"),  # type: ignore[arg-type]
        (lambda: Method(templates="default"), "method.templates"),  # type: ignore[arg-type]
    ],
)
def test_constructors_refuse_what_files_refuse(make: Callable[[], Any], name: str) -> None:
    with pytest.raises(InvalidParameterError) as info:
        make()
    assert str(info.value).startswith(f"{name} must be ")


def test_constructors_keep_numbers_as_floats() -> None:
    """An int for a float field is kept as a float: what a file read back gives."""
    p = SegmentParams(penalty=10, stage1=Stage1Params(min_section_s=1))
    assert type(p.penalty) is float and type(p.stage1.min_section_s) is float
    assert p == SegmentParams(penalty=10.0, stage1=Stage1Params(min_section_s=1.0))


def test_every_field_has_one_rule() -> None:
    """The rule tables are the dataclasses' fields, no more, no fewer."""
    for cls, rules in (
        (SegmentParams, SEGMENT_RULES),
        (Stage1Params, STAGE1_RULES),
        (ContactParams, CONTACT_RULES),
    ):
        assert set(rules) == {f.name for f in dataclasses.fields(cls)}, cls.__name__


def test_the_defaults_and_the_papers_parameters_follow_the_rules() -> None:
    for m in (Method.default(), Method.paper()):
        doc = json.loads(json.dumps(m.entry()))
        assert lfd.segmentation.method.params_from_dict(doc["params"]) == m.params


def test_shipped_files_load_and_segment_as_before(tmp_path: Path) -> None:
    """The shipped files (no lfd.format_version: read as version 1) load as the shipped
    methods; a method saved and read back, and one sent to a worker, segment identically."""
    demo = lfd.load(EXP1)
    default = lfd.segment(demo)
    by_file = Method.load(SHIPPED)
    assert by_file.preprocessing == Method.default().preprocessing
    assert by_file.params == Method.default().params
    assert Method.load(PAPER).preprocessing == Method.paper().preprocessing
    custom = dataclasses.replace(
        Method.default(), name="mine", params=SegmentParams(penalty=12.5, lookahead=False)
    )
    custom.save(tmp_path / "mine.json")
    saved = json.loads((tmp_path / "mine.json").read_text())
    assert saved["lfd"]["format_version"] == FORMAT_VERSION
    back = Method.load(tmp_path / "mine.json")
    assert (back.name, back.params, back.search, back.grammar) == (
        "mine",
        custom.params,
        custom.search,
        custom.grammar,
    )
    sent = pickle.loads(pickle.dumps(Method.default()))
    assert sent.templates is Method.default().templates  # the shipped set, by name
    for m in (by_file, sent):
        again = lfd.segment(demo, method=m)
        assert [(s.skill, s.start, s.end, s.object) for s in again.segments] == [
            (s.skill, s.start, s.end, s.object) for s in default.segments
        ]
        assert all(math.isfinite(s.confidence) for s in again.segments)
    # a method with its own templates travels as the whole file, checked again on arrival
    mine = pickle.loads(pickle.dumps(back))
    assert mine.params == back.params and mine.templates.skills == back.templates.skills


def test_method_load_refuses_anything_else_with_an_lfd_error(tmp_path: Path) -> None:
    for spec in (tmp_path / "missing.json", "x\0y", tmp_path, 3):
        with pytest.raises(LfdError):
            Method.load(spec)  # type: ignore[arg-type]


def test_the_doc_shows_every_rule() -> None:
    """docs/method-files.md lists every field with what its rule says it holds."""
    from lfd.segmentation.method import METHOD_KEYS, METHOD_RULES
    from lfd.segmentation.schema import ABOUT_RULES, PREPROCESSING_RULES

    doc = (ROOT / "docs" / "method-files.md").read_text()
    tables = [SEGMENT_RULES, STAGE1_RULES, CONTACT_RULES, PREPROCESSING_RULES, ABOUT_RULES]
    for rules in tables:
        for key, rule in rules.items():
            assert f"| `{key}` | {rule.want()} |" in doc, key
    for key in METHOD_KEYS - {"params"}:
        assert f"| `{key}` | {METHOD_RULES[key].want()} |" in doc, key
    assert f'"format_version": {FORMAT_VERSION},' in doc
