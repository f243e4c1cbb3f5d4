"""The binding ``lfd._hmmseg`` as a boundary: array layouts, option names, the error contract,
absurd sizes and concurrent calls."""

from __future__ import annotations

import ast
import itertools
import json
import subprocess
import sys
import textwrap
import time
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any, get_args

import _paths
import numpy as np
import pytest
from lfd import _hmmseg, errors
from lfd.engine import GaussianHMM
from lfd.segmentation.grammar import grammar_json
from lfd.skills import SKILLS

ROOT = _paths.ROOT
RNG = np.random.default_rng(7)


# --- inputs ------------------------------------------------------------------------------------
def _sequences(n: int = 3, f: int = 2) -> list[np.ndarray]:
    rng = np.random.default_rng(1)
    return [
        np.concatenate([rng.normal(0, 0.3, (25, f)), rng.normal(2, 0.3, (25, f))]) for _ in range(n)
    ]


SEQS = _sequences()
MODEL = _hmmseg.Hmm.fit(SEQS, n_states=2, covariance="full", seed=3)[0]
MIX = _hmmseg.Hmm.fit(SEQS, n_states=2, n_mix=2, seed=3)[0]
X = np.random.default_rng(2).normal(1, 1, (40, 2))


def _scene() -> dict[str, Any]:
    n, k = 60, 2
    s = np.linspace(0, 1, n)
    tcp = np.stack([0.3 * s, 0.1 + 0.05 * s, 0.05 + 0.1 * np.sin(np.pi * s)], axis=1)
    pos = np.stack([np.tile([0.3, 0.15, 0.025], (n, 1)), np.tile([0.0, 0.1, 0.025], (n, 1))])
    pos[0, 30:] += np.linspace(0, 0.1, 30)[:, None] * [0, 0, 1]
    quat = np.zeros((k, n, 4))
    quat[..., 3] = 1.0
    quat[1, :, 2] = 0.2
    quat /= np.linalg.norm(quat, axis=-1, keepdims=True)
    return {
        "tcp": tcp,
        "opening": 0.06 + 0.02 * np.sin(3 * s),
        "object_position": pos,
        "object_quaternion": quat,
        "object_size": np.array([[0.05, 0.06, 0.05], [0.04, 0.04, 0.08]]),
    }


SCENE = _scene()
SKILL_LIST = list(SKILLS)
GRAMMAR = _hmmseg.Grammar(grammar_json(), SKILL_LIST)
BOUNDS = np.array([0, 10, 25, 40, 60], dtype=np.int64)
SCORES = -RNG.uniform(1, 50, (4, 5, len(SKILL_LIST)))
RISING = RNG.uniform(size=(4, 5)) < 0.3
FEATURES = [("a", 0, 1), ("b", 1, 3)]
TPL_PARAMS = json.dumps({"fit": {"n_states": 2, "max_iter": 3}, "align": False})
EXAMPLES = [(i % 2, np.random.default_rng(10 + i).uniform(size=(20 + i, 3))) for i in range(6)]
TEMPLATES = _hmmseg.TemplateSet.train(["pick_up", "place"], FEATURES, EXAMPLES, TPL_PARAMS)
RAW = np.random.default_rng(4).uniform(size=(60, 3))


# --- layouts -----------------------------------------------------------------------------------
def _c(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a)


def _fortran(a: np.ndarray) -> np.ndarray:
    return np.asfortranarray(a)


def _strided(a: np.ndarray) -> np.ndarray:
    """A view with every stride doubled (every other element of a larger array)."""
    idx = tuple(slice(1, None, 2) for _ in a.shape)
    big = np.zeros(tuple(2 * s + 1 for s in a.shape), dtype=a.dtype)
    big[idx] = a
    view = big[idx]
    assert not view.flags.c_contiguous or a.size <= 1
    return view


def _reversed(a: np.ndarray) -> np.ndarray:
    """A view with negative strides."""
    flip = (slice(None, None, -1),) * a.ndim
    return np.ascontiguousarray(a[flip])[flip]


def _transposed_copy(a: np.ndarray) -> np.ndarray:
    """Fortran order reached by a transpose (the common accidental case)."""
    return np.ascontiguousarray(a.T).T


LAYOUTS: dict[str, Callable[[np.ndarray], np.ndarray]] = {
    "fortran": _fortran,
    "strided": _strided,
    "reversed": _reversed,
    "transposed": _transposed_copy,
}

Layout = Callable[[np.ndarray], np.ndarray]

ENTRY_POINTS: dict[str, Callable[[Layout], Any]] = {
    "dtw": lambda L: _hmmseg.dtw(L(SEQS[0]), L(X)),
    "dtw_distance": lambda L: _hmmseg.dtw_distance(L(SEQS[0]), L(X), 12),
    "align_to_reference": lambda L: _hmmseg.align_to_reference(L(X), [L(s) for s in SEQS]),
    "minmax": lambda L: _hmmseg.minmax(L(X)),
    "minmax_with": lambda L: _hmmseg.minmax_with(
        L(X), L(np.array([-1.0, 0.0])), L(np.array([2.0, 3.0]))
    ),
    "compute_features": lambda L: _hmmseg.compute_features(
        *(L(SCENE[k]) for k in SCENE), 0.05, L(np.arange(60) % 2)
    ),
    "label_targets": lambda L: _hmmseg.label_targets(
        L(SCENE["tcp"]), L(SCENE["object_position"]), L(SCENE["object_size"]), 0.05
    ),
    "Hmm.fit": lambda L: _hmmseg.Hmm.fit([L(s) for s in SEQS], n_states=2, covariance="full"),
    "Hmm.refit": lambda L: MIX.refit([L(s) for s in SEQS], max_iter=2),
    "Hmm.from_params": lambda L: _hmmseg.Hmm.from_params(
        L(MODEL.startprob),
        L(MODEL.transmat),
        L(MODEL.weights),
        L(MODEL.means),
        L(MODEL.covars),
        "full",
    ),
    "Hmm.log_likelihood": lambda L: MODEL.log_likelihood(L(X)),
    "Hmm.log_likelihood_many": lambda L: MODEL.log_likelihood_many([L(s) for s in SEQS]),
    "Hmm.prefix_log_likelihoods": lambda L: MIX.prefix_log_likelihoods(L(X)),
    "Hmm.viterbi": lambda L: MODEL.viterbi(L(X)),
    "Hmm.posteriors": lambda L: MIX.posteriors(L(X)),
    "stage1_boundaries": lambda L: _hmmseg.stage1_boundaries(
        L(np.tile(np.sin(np.arange(100) / 7.0)[:, None], (1, 10))),
        L(np.tile(np.linspace(-0.5, 0.5, 10), (100, 1))),
        [0, 9],
        [0.05, 0.05],
        3,
    ),
    "rising_table": lambda L: _hmmseg.rising_table(L(SCENE["tcp"][:, 2]), L(BOUNDS), 0.02),
    "segment_greedy": lambda L: _hmmseg.segment_greedy(
        L(SCORES), L(BOUNDS), GRAMMAR, L(RISING), "off", True
    ),
    "segment_dp": lambda L: _hmmseg.segment_dp(
        L(SCORES), L(BOUNDS), GRAMMAR, L(RISING), "warn", 1.0
    ),
    "Band": lambda L: _hmmseg.Band(L(BOUNDS), 30).runs(),
    "TemplateSet.train": lambda L: _hmmseg.TemplateSet.train(
        ["pick_up", "place"], FEATURES, [(s, L(x)) for s, x in EXAMPLES], TPL_PARAMS
    ).to_json(),
    "TemplateSet.normalise": lambda L: TEMPLATES.normalise(L(RAW)),
    "TemplateSet.score_table": lambda L: TEMPLATES.score_table(L(RAW), L(BOUNDS), 30, "any"),
}


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, np.ndarray):
        return (
            isinstance(b, np.ndarray)
            and a.dtype == b.dtype
            and np.array_equal(a, b, equal_nan=a.dtype.kind == "f")
        )
    if isinstance(a, tuple | list):
        return type(a) is type(b) and len(a) == len(b) and all(map(_same, a, b))
    return bool(a == b)


@pytest.mark.parametrize("layout", LAYOUTS)
@pytest.mark.parametrize("entry", ENTRY_POINTS)
def test_every_entry_point_reads_any_memory_layout(entry: str, layout: str) -> None:
    call = ENTRY_POINTS[entry]
    reference = call(_c)
    assert _same(call(LAYOUTS[layout]), reference), f"{entry} differs for {layout} input"


def test_fortran_input_is_read_by_logical_index() -> None:
    # the bug this guards against: Fortran-ordered memory read as row-major
    x = np.asfortranarray(X)
    assert MODEL.log_likelihood(x) == MODEL.log_likelihood(X)
    assert _hmmseg.dtw_distance(x, np.asfortranarray(SEQS[0])) == _hmmseg.dtw_distance(X, SEQS[0])
    assert not np.array_equal(X.ravel(order="F"), X.ravel(order="C"))


@pytest.mark.parametrize(
    ("call", "cls", "match"),
    [
        (lambda: MODEL.log_likelihood(X[:, 0]), errors.ShapeMismatchError, "x must be a 2-D"),
        (lambda: MODEL.log_likelihood(X[None]), errors.ShapeMismatchError, r"shape \(1, 40, 2\)"),
        (
            lambda: MODEL.log_likelihood(X.astype(np.float32)),
            errors.InvalidParameterError,
            "float32",
        ),
        (lambda: MODEL.log_likelihood(X.astype(np.int64)), errors.InvalidParameterError, "dtype"),
        (lambda: MODEL.log_likelihood(X.tolist()), errors.InvalidParameterError, "got list"),
        (lambda: MODEL.log_likelihood(X.astype(">f8")), errors.InvalidParameterError, "dtype"),
        (lambda: _hmmseg.dtw(X, SEQS[0][:, :1]), errors.ShapeMismatchError, "columns"),
        (
            lambda: _hmmseg.Hmm.fit([X, X[0]], n_states=2),
            errors.ShapeMismatchError,
            r"sequences\[1\]",
        ),
        (
            lambda: _hmmseg.rising_table(np.zeros(3), np.array([0.0, 3.0])),
            errors.InvalidParameterError,
            "boundaries must have dtype int64",
        ),
        (
            lambda: _hmmseg.segment_dp(SCORES, BOUNDS, GRAMMAR, RISING[:, :4]),
            errors.ShapeMismatchError,
            r"rising must have shape \(4, 5\)",
        ),
        (
            lambda: _hmmseg.compute_features(
                SCENE["tcp"],
                SCENE["opening"],
                SCENE["object_position"][0],
                SCENE["object_quaternion"],
                SCENE["object_size"],
                0.05,
            ),
            errors.ShapeMismatchError,
            "object_position must be a 3-D",
        ),
    ],
)
def test_wrong_arrays_are_refused_by_name(call: Callable[[], Any], cls: type, match: str) -> None:
    with pytest.raises(cls, match=match):
        call()


# --- option names ------------------------------------------------------------------------------
def _stub_literals() -> dict[str, tuple[str, ...]]:
    """The Literal aliases as written in _hmmseg.pyi."""
    tree = ast.parse((ROOT / "python" / "lfd" / "_hmmseg.pyi").read_text())
    out = {}
    for node in tree.body:
        if (
            isinstance(node, ast.Assign)
            and isinstance(node.value, ast.Subscript)
            and isinstance(node.value.value, ast.Name)
            and node.value.value.id == "Literal"
        ):
            elts = node.value.slice
            values = elts.elts if isinstance(elts, ast.Tuple) else [elts]
            out[node.targets[0].id] = tuple(ast.literal_eval(v) for v in values)  # type: ignore[attr-defined]
    return out


def test_option_aliases_are_the_engines_names_and_match_the_stub() -> None:
    stub = _stub_literals()
    assert set(stub) == {"CovarianceType", "Topology", "GrammarMode", "EndState", "SizeMeasure"}
    for name, values in stub.items():
        assert get_args(getattr(_hmmseg, name)) == values, name


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda v: _hmmseg.Hmm.fit(SEQS, n_states=2, covariance=v), "covariance must be one of"),
        (lambda v: _hmmseg.Hmm.fit(SEQS, n_states=2, topology=v), "topology must be one of"),
        (
            lambda v: _hmmseg.segment_dp(SCORES, BOUNDS, GRAMMAR, None, v),
            "grammar mode must be one of",
        ),
        (lambda v: TEMPLATES.score_table(RAW, BOUNDS, 0, v), "end must be one of"),
        (
            lambda v: _hmmseg.check_feature_params(json.dumps({"size_measure": v})),
            "size_measure",
        ),
        (lambda v: GaussianHMM(2, covariance=v), "covariance must be one of"),  # type: ignore[arg-type]
    ],
)
def test_bad_option_values_are_invalid_parameters(call: Callable[[str], Any], match: str) -> None:
    with pytest.raises(errors.InvalidParameterError, match=match):
        call("bogus")


def test_every_option_value_is_accepted() -> None:
    for cov in get_args(_hmmseg.CovarianceType):
        for top in get_args(_hmmseg.Topology):
            assert _hmmseg.Hmm.fit(SEQS, n_states=2, covariance=cov, topology=top, max_iter=1)
    for mode in get_args(_hmmseg.GrammarMode):
        _hmmseg.segment_dp(SCORES, BOUNDS, GRAMMAR, None, mode)
    for end in get_args(_hmmseg.EndState):
        TEMPLATES.score_table(RAW, BOUNDS, 0, end)
    for size in get_args(_hmmseg.SizeMeasure):
        _hmmseg.check_feature_params(json.dumps({"size_measure": size}))


def test_feature_groups_are_defined_once_in_the_engine() -> None:
    from lfd.features import FEATURE_GROUPS, FEATURE_NAMES
    from lfd.segmentation import templates
    from lfd.segmentation.stage1 import FEATURE_COLUMNS

    assert FEATURE_NAMES is _hmmseg.FEATURE_NAMES
    assert templates.FEATURE_GROUPS is _hmmseg.FEATURE_GROUPS
    assert [(n, len(c)) for n, c in FEATURE_GROUPS.items()] == [
        (n, b - a) for n, a, b in _hmmseg.FEATURE_GROUPS
    ]
    assert all(FEATURE_NAMES[c] == n for n, c in FEATURE_COLUMNS.items())
    assert _hmmseg.FEATURE_GROUPS[-1][2] == len(FEATURE_NAMES) == 10


# --- the error contract ------------------------------------------------------------------------
VARIANTS: dict[str, tuple[type[errors.EngineError], Callable[[], Any]]] = {
    "EmptySequence": (errors.EmptySequenceError, lambda: MODEL.log_likelihood(np.zeros((0, 2)))),
    "ShapeMismatch": (errors.ShapeMismatchError, lambda: MODEL.log_likelihood(np.zeros((5, 3)))),
    "NonFinite": (errors.NonFiniteError, lambda: MODEL.log_likelihood(np.full((5, 2), np.nan))),
    "InvalidParameter": (errors.InvalidParameterError, lambda: MODEL.sample(0 - 1)),
    "NotStochastic": (
        errors.NotStochasticError,
        lambda: _hmmseg.Hmm.from_params(
            np.array([0.3, 0.3]), MODEL.transmat, MODEL.weights, MODEL.means, MODEL.covars, "full"
        ),
    ),
    "NotPositiveDefinite": (
        errors.NotPositiveDefiniteError,
        lambda: _hmmseg.Hmm.from_params(
            MODEL.startprob,
            MODEL.transmat,
            MODEL.weights,
            MODEL.means,
            np.tile([[1.0, 2.0], [2.0, 1.0]], (2, 1, 1, 1)),
            "full",
        ),
    ),
    "NotConverged": (
        errors.NotConvergedError,
        lambda: MODEL.refit([np.full((30, 2), 1e155)], max_iter=2),
    ),
    "Format": (errors.ModelFormatError, lambda: _hmmseg.Hmm.from_json("{")),
}


def test_every_engine_error_variant_has_a_real_trigger() -> None:
    source = (ROOT / "crates" / "hmmseg" / "src" / "error.rs").read_text()
    body = source[source.index("pub enum EngineError") :]
    body = body[: body.index("\n}")]
    variants = {
        line.strip().split("(")[0]
        for line in body.splitlines()
        if line.strip().endswith("(String),")
    }
    assert variants == set(VARIANTS)


@pytest.mark.parametrize("variant", VARIANTS)
def test_engine_errors_raise_their_class_from_a_real_call(variant: str) -> None:
    cls, call = VARIANTS[variant]
    try:
        call()
    except errors.EngineError as err:
        if variant == "NotConverged" and not isinstance(err, cls):
            pytest.skip(f"the engine now trains on 1e160 data ({type(err).__name__}); hook below")
        assert type(err) is cls, f"{variant}: {type(err).__name__}: {err}"
        assert str(err) and "\n" not in str(err)
    else:
        if variant == "NotConverged":
            pytest.skip("the engine now trains on 1e160 data; covered by the hook test")
        pytest.fail(f"{variant}: no error raised")


@pytest.mark.parametrize("variant", VARIANTS)
def test_engine_errors_raise_their_class_through_the_hook(variant: str) -> None:
    cls, _ = VARIANTS[variant]
    with pytest.raises(cls, match=f"test hook for {variant}") as info:
        _hmmseg._raise_engine_error(variant)
    assert type(info.value) is cls


def test_a_panic_is_an_internal_error_that_except_exception_catches() -> None:
    try:
        _hmmseg._panic("boom")
    except Exception as err:  # the point: PanicException is not an Exception
        assert type(err) is errors.InternalError
        assert isinstance(err, errors.EngineError)
        assert "boom" in str(err)
    else:
        pytest.fail("no error raised")


def test_a_panic_carrying_a_keyboard_interrupt_is_the_interrupt() -> None:
    """Ctrl+C inside a Python call the binding makes (rust-numpy's lazy import of numpy's C
    API panicked with "Failed to access NumPy array API capsule ... KeyboardInterrupt"): the
    run must stop, not go on as if one input had failed (an InternalError is an LfdError)."""
    with pytest.raises(KeyboardInterrupt, match="KeyboardInterrupt"):
        _hmmseg._panic("Failed to access NumPy array API capsule: KeyboardInterrupt")


@pytest.mark.parametrize("errors_py", [None, "class EngineError(Exception): ...\n"])
def test_the_binding_does_not_import_without_its_error_classes(
    tmp_path: Path, errors_py: str | None
) -> None:
    # a bare package holding only the compiled module (and an incomplete lfd.errors)
    pkg = tmp_path / "lfd"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    if errors_py is not None:
        (pkg / "errors.py").write_text(errors_py)
    so = Path(_hmmseg.__file__)
    (pkg / so.name).symlink_to(so)
    code = "import lfd._hmmseg"
    r = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=tmp_path,
        env={"PYTHONPATH": str(tmp_path), "PATH": "/usr/bin:/bin"},
    )
    assert r.returncode == 1
    assert "ImportError: lfd._hmmseg cannot load its exception classes from lfd.errors" in r.stderr


def test_the_error_classes_are_resolved_at_import() -> None:
    # rebinding a name in lfd.errors later changes nothing: the classes were stored at import
    saved = errors.NonFiniteError
    try:
        errors.NonFiniteError = errors.ShapeMismatchError  # type: ignore[misc]
        with pytest.raises(saved) as info:
            MODEL.log_likelihood(np.full((5, 2), np.nan))
        assert type(info.value) is saved
    finally:
        errors.NonFiniteError = saved  # type: ignore[misc]


def test_silent_fallbacks_are_gone() -> None:
    # what segment.rs used to paper over with zeros / all-false / "" now either works or raises
    assert json.loads(_hmmseg.default_template_params())["fit"]["n_states"] >= 1
    assert json.loads(TEMPLATES.params_json)["fit"]["n_states"] == 2
    with pytest.raises(errors.ShapeMismatchError, match="boundaries"):
        _hmmseg.rising_table(np.zeros(3), np.array([0], dtype=np.int64))
    with pytest.raises(errors.ShapeMismatchError, match="boundaries"):
        TEMPLATES.score_table(RAW, np.array([], dtype=np.int64))


# --- the stage-2 search: a compiled grammar in, named cuts out ------------------------------------
def test_the_grammar_is_checked_once_when_compiled() -> None:
    from lfd.segmentation.grammar import compiled_grammar, implicit_move_grammar_json

    assert GRAMMAR.skills == SKILL_LIST
    assert GRAMMAR == _hmmseg.Grammar(grammar_json(), SKILL_LIST)
    assert GRAMMAR != _hmmseg.Grammar(implicit_move_grammar_json(), SKILL_LIST)
    rules = json.loads(grammar_json())
    bad = [
        ("{", "grammar JSON"),
        (json.dumps({**rules, "format_version": 9}), "format_version 9"),
        (json.dumps({**rules, "start": [*rules["start"], "fly"]}), 'unknown skill "fly"'),
        (json.dumps({k: v for k, v in rules.items() if k != "transitions"}), "transitions"),
    ]
    for text, match in bad:
        with pytest.raises(errors.ModelFormatError, match=match) as info:
            _hmmseg.Grammar(text, SKILL_LIST)
        assert isinstance(info.value, ValueError)
    with pytest.raises(errors.EmptySequenceError, match="at least one skill"):
        _hmmseg.Grammar(grammar_json(), [])
    # the search takes the compiled grammar only, and it must name the table's skills
    with pytest.raises(TypeError):
        _hmmseg.segment_dp(SCORES, BOUNDS, grammar_json())  # type: ignore[arg-type]
    two = _hmmseg.Grammar(grammar_json(), ["pick_up", "place"])
    with pytest.raises(errors.ShapeMismatchError, match="grammar has 2 skills, score table 7"):
        _hmmseg.segment_greedy(SCORES, BOUNDS, two)
    # the pipeline compiles each grammar once per skill order
    key = tuple(SKILL_LIST)
    assert compiled_grammar(key, True) is compiled_grammar(key, True)
    assert compiled_grammar(key, False) == GRAMMAR != compiled_grammar(key, True)


def test_cuts_are_named_read_only_segments() -> None:
    for cuts, _ in (
        _hmmseg.segment_dp(SCORES, BOUNDS, GRAMMAR, RISING, "warn", 1.0),
        _hmmseg.segment_greedy(SCORES, BOUNDS, GRAMMAR, RISING, "off", True),
    ):
        assert cuts and all(type(c) is _hmmseg.Cut for c in cuts)
        assert cuts[0].start_section == 0 and cuts[-1].end_section == len(BOUNDS) - 1
        for a, b in itertools.pairwise(cuts):
            assert a.end_section == b.start_section and a.end == b.start
        for c in cuts:
            assert (c.start, c.end) == (BOUNDS[c.start_section], BOUNDS[c.end_section])
            assert 0 <= c.skill < len(SKILL_LIST) and 0.0 <= c.confidence <= 1.0
            assert isinstance(c.score, float) and isinstance(c.margin, float)
            assert repr(c).startswith(f"Cut(skill={c.skill}, start_section={c.start_section}")
    c = cuts[0]
    with pytest.raises(AttributeError):
        c.skill = 1  # type: ignore[misc]
    with pytest.raises(TypeError):
        _hmmseg.Cut()  # type: ignore[call-arg]
    with pytest.raises(TypeError):
        _skill, _i, *_rest = c  # type: ignore[misc]


# --- absurd sizes: refused before allocating ------------------------------------------------------
ABSURD = {
    "GaussianHMM(3).fit(X).sample(10**12)": "GaussianHMM(3).fit(X).sample(10**12)",
    "Hmm.sample(10**12)": "m.sample(10**12)",
    "Hmm.sample(2**63)": "m.sample(2**63)",
    "Hmm.sample(-1)": "m.sample(-1)",
    "Hmm.fit(n_states=100000)": "_hmmseg.Hmm.fit([np.zeros((200000, 1))], n_states=100000)",
    "GaussianHMM(100000).fit": "GaussianHMM(100000).fit([np.zeros((200000, 1))])",
    "Hmm.fit(n_mix=2**40)": "_hmmseg.Hmm.fit(X, n_states=2, n_mix=2**40)",
    "GaussianHMM(2, n_mix=2**40).fit": "GaussianHMM(2, n_mix=2**40).fit(X)",
    "Hmm.fit(n_mix=2**63)": "_hmmseg.Hmm.fit(X, n_states=2, n_mix=2**63)",
    "GaussianHMM(2, n_mix=2**63).fit": "GaussianHMM(2, n_mix=2**63).fit(X)",
    "Hmm.fit(n_mix=2**64)": "_hmmseg.Hmm.fit(X, n_states=2, n_mix=2**64)",
    "Hmm.fit(n_mix=2**200)": "_hmmseg.Hmm.fit(X, n_states=2, n_mix=2**200)",
    "Hmm.fit(n_states=-1)": "_hmmseg.Hmm.fit(X, n_states=-1)",
    "Hmm.fit(seed=-1)": "_hmmseg.Hmm.fit(X, n_states=2, seed=-1)",
    "TemplateSet.train(n_mix=2**40)": (
        "_hmmseg.TemplateSet.train(['move'], [('f', 0, 1)], [(0, x) for x in X],"
        ' \'{"fit": {"n_mix": 1099511627776}}\')'
    ),
    "dtw(band=-1)": "_hmmseg.dtw(X[0], X[1], band=-1)",
    "score_table(max_len=-1)": "t.score_table(np.zeros((4, 1)), np.array([0, 4]), -1)",
    # iteration counts: bounded by hmmseg::limits::MAX_ITER, a negative tolerance refused
    "Hmm.refit(max_iter=2**40, tol=-1)": "m.refit(X, max_iter=2**40, tol=-1.0)",
    "Hmm.refit(max_iter=2**40)": "m.refit(X, max_iter=2**40)",
    "Hmm.refit(max_iter=10001)": "m.refit(X, max_iter=10_001)",
    "Hmm.refit(tol=-1)": "m.refit(X, max_iter=2, tol=-1.0)",
    "Hmm.refit(tol=nan)": "m.refit(X, max_iter=2, tol=float('nan'))",
    "GaussianHMM.refit(n_iter=2**40)": "GaussianHMM(2).fit(X).refit(X, 2**40)",
    "Hmm.fit(max_iter=2**40, tol=-1)": "_hmmseg.Hmm.fit(X, n_states=2, max_iter=2**40, tol=-1.0)",
    "TemplateSet.train(max_iter=2**40)": (
        "_hmmseg.TemplateSet.train(['move'], [('f', 0, 1)], [(0, x) for x in X],"
        ' \'{"fit": {"max_iter": 1099511627776, "tol": -1}}\')'
    ),
    "template_params(max_iter=2**40)": (
        '_hmmseg.template_params(\'{"fit": {"max_iter": 1099511627776}}\')'
    ),
    # filters: at most hmmseg::limits::MAX_COEFFICIENTS coefficients (lfilter_zi is cubic)
    "lfilter_zi(5001 coefficients)": "_hmmseg.lfilter_zi(np.ones(1), np.r_[1.0, np.zeros(5000)])",
    "filtfilt(5000 coefficients)": "_hmmseg.filtfilt(np.ones(5000), np.ones(1), np.zeros((9, 1)), 2)",
    "filtfilt_runs(5000 coefficients)": (
        "_hmmseg.filtfilt_runs(np.ones(5000), np.ones(1), np.zeros((9, 1)), np.ones((9, 1), bool), 2)"
    ),
    "filtfilt(padlen=2**40)": "_hmmseg.filtfilt(np.ones(1), np.ones(1), np.zeros((9, 1)), 2**40)",
    # outputs sized by the product of two inputs: checked against the budget
    "cubic_spline(len(at) x columns)": (
        "_hmmseg.cubic_spline(np.r_[0.0, 1.0], np.zeros((2, 2_000_000)), np.zeros(1_000_000))"
    ),
    "resample_columns(len(td) x columns)": (
        "_hmmseg.resample_columns(np.r_[0.0, 1.0], np.zeros((2, 2_000_000)), None,"
        " np.zeros(1_000_000), 1.0)"
    ),
    # the band's runs: quadratic in the sections without max_len
    "rising_band(2e6 sections)": "_hmmseg.rising_band(np.zeros(2_000_001), np.arange(2_000_001), 0)",
    "Band.runs(2e6 sections)": "_hmmseg.Band(np.arange(2_000_001), 0).runs()",
}


def test_absurd_sizes_are_invalid_parameters_not_crashes() -> None:
    # one subprocess: an abort (allocation failure) would kill it, not the test session
    code = textwrap.dedent(
        f"""
        import numpy as np
        from lfd import _hmmseg
        from lfd.engine import GaussianHMM
        rng = np.random.default_rng(0)
        X = [rng.normal(size=(40, 1)) for _ in range(3)]
        m = _hmmseg.Hmm.fit(X, n_states=2)[0]
        t = _hmmseg.TemplateSet.train(['move'], [('f', 0, 1)], [(0, x) for x in X],
                                      '{{"fit": {{"n_states": 2, "max_iter": 1}}}}')
        for name, expr in {ABSURD!r}.items():
            try:
                eval(expr)
                print(name, "|", "no error")
            except Exception as e:
                print(name, "|", type(e).__name__, "|", str(e).replace(chr(10), " "))
        """
    )
    t0 = time.perf_counter()
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    lines = dict(line.split(" | ", 1) for line in r.stdout.splitlines())
    assert set(lines) == set(ABSURD)
    for name, outcome in lines.items():
        assert outcome.startswith("InvalidParameterError | "), f"{name}: {outcome}"
    # refused before any work: the whole table (fits included) well under a minute
    assert time.perf_counter() - t0 < 60


def test_minus_infinity_still_means_exactly_max_iter_iterations() -> None:
    # the one negative tolerance accepted: no convergence test (hmmlearn's tol=-inf)
    _, history, n_iter, converged = MODEL.refit(SEQS, max_iter=4)
    assert (len(history), n_iter, converged) == (4, 4, False)
    _, history, n_iter, _ = MODEL.refit(SEQS, max_iter=3, tol=0.0)
    assert n_iter <= 3


# --- threads -----------------------------------------------------------------------------------
def test_concurrent_calls_give_identical_results() -> None:
    jobs: list[Callable[[], Any]] = [
        lambda: TEMPLATES.score_table(RAW, BOUNDS, 30, "final"),
        lambda: _hmmseg.segment_dp(SCORES, BOUNDS, GRAMMAR, RISING, "enforce", 2.0),
        lambda: _hmmseg.segment_greedy(SCORES, BOUNDS, GRAMMAR, RISING, "warn", True),
        lambda: MIX.log_likelihood_many(SEQS),
        lambda: MODEL.posteriors(X),
        lambda: _hmmseg.Hmm.fit(SEQS, n_states=2, n_mix=2, seed=5)[0].to_json(),
        lambda: _hmmseg.dtw(X, SEQS[1]),
    ]
    serial = [job() for job in jobs]
    with ThreadPoolExecutor(max_workers=6) as pool:
        for _ in range(3):
            futures = [pool.submit(job) for job in jobs * 4]
            results = [f.result() for f in futures]
            for k, res in enumerate(results):
                assert _same(res, serial[k % len(jobs)]), f"job {k % len(jobs)} differs"


def _layouts_used() -> Iterator[str]:  # keep LAYOUTS honest: each really is a different layout
    for name, fn in LAYOUTS.items():
        a = fn(X)
        yield f"{name}:{a.flags.c_contiguous}:{a.flags.f_contiguous}:{a.strides}"


def test_layouts_are_distinct() -> None:
    seen = list(_layouts_used())
    assert len(set(seen)) == len(seen)
    assert all(not s.split(":")[1] == "True" for s in seen)


# --- found by the binding fuzzer (tests/fuzz/engine_fuzz.py) -------------------------------------
def test_one_rotation_paired_with_none_gives_none() -> None:
    one, none = np.array([[0.0, 0.0, 0.0, 1.0]]), np.zeros((0, 4))
    assert _hmmseg.quat_multiply(one, none).shape == (0, 4)
    assert _hmmseg.quat_multiply(none, one).shape == (0, 4)
    assert _hmmseg.quat_apply(none, np.ones((1, 3))).shape == (0, 3)
    assert _hmmseg.quat_apply(one, np.zeros((0, 3)), True).shape == (0, 3)
    with pytest.raises(errors.ShapeMismatchError):
        _hmmseg.quat_apply(none, np.ones((2, 3)))


@pytest.mark.parametrize(
    ("features", "examples"),
    [
        ([("f", 2**200, 1)], [(0, np.zeros((5, 1)))]),
        ([("f", 0, -(2**70))], [(0, np.zeros((5, 1)))]),
        ([("f", 0, 1)], [(2**64, np.zeros((5, 1)))]),
    ],
)
def test_template_training_refuses_huge_ints_by_name(features: Any, examples: Any) -> None:
    with pytest.raises(errors.InvalidParameterError):
        _hmmseg.TemplateSet.train(["move"], features, examples)
