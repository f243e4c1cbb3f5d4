"""Fuzz the engine's Python API (``lfd._hmmseg`` and ``lfd.engine``) with hypothesis: the
HMMs, DTW, normalisation, model JSON and the MCAP reader (cut and overwritten recordings).

Run in a subprocess (an abort or a segfault then shows as the child's exit status, not as a dead
test runner)::

    python tests/fuzz/engine_fuzz.py --examples 2000 --seed 0 [--targets fit,score,...]

Every call must either return a sane result or raise an ``lfd.errors.LfdError`` (or a
``TypeError`` for an argument of the wrong Python type). Anything else — another exception
(``PanicException``, ``OverflowError``, ``MemoryError``, ``RuntimeError``), NaN/inf where a
number is promised, posteriors whose rows do not sum to 1 — is a finding. The script prints one
JSON line: executions per target and the distinct findings (target, kind, message), and exits 1
when there are findings. ``tests/test_fuzz.py`` runs a short smoke of it; long runs are for
the issue notes.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import traceback
from collections import Counter
from typing import Any

import numpy as np
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import seed as hypothesis_seed
from hypothesis import strategies as st
from lfd import _hmmseg
from lfd.errors import LfdError

MAGNITUDES = [0.0, 1e-300, 1e-12, 1e-3, 1.0, 10.0, 1e6, 1e50, 1e150, 1e160, 1e300]
SPECIALS = [np.nan, np.inf, -np.inf, 0.0, -0.0]
SIZES = [0, 1, 2, 3, 5, 2**31, 2**40, 2**63 - 1, 2**63, 2**64]


@st.composite
def arrays(draw: Any, max_rows: int = 40, max_cols: int = 3, min_rows: int = 0) -> np.ndarray:
    rows = draw(st.integers(min_rows, max_rows))
    cols = draw(st.integers(0, max_cols) if draw(st.booleans()) else st.just(1))
    scale = draw(st.sampled_from(MAGNITUDES))
    seed = draw(st.integers(0, 2**32 - 1))
    x = np.random.default_rng(seed).normal(size=(rows, cols)) * scale
    if rows and cols and draw(st.integers(0, 9)) == 0:
        x.flat[draw(st.integers(0, x.size - 1))] = draw(st.sampled_from(SPECIALS))
    layout = draw(st.sampled_from(["C", "F", "strided", "transposed"]))
    if layout == "F":
        x = np.asfortranarray(x)
    elif layout == "strided" and rows:
        big = np.zeros((rows * 2, cols))
        big[::2] = x
        x = big[::2]
    elif layout == "transposed":
        x = np.ascontiguousarray(x.T).T
    return x


ALLOWED = (LfdError, TypeError)
COUNTS: Counter[str] = Counter()
FINDINGS: dict[tuple[str, str, str], int] = {}


def _finding(target: str, kind: str, message: str) -> None:
    key = (target, kind, message[:160])
    FINDINGS[key] = FINDINGS.get(key, 0) + 1


def _call(target: str, fn: Any, check: Any = None) -> Any:
    COUNTS[target] += 1
    try:
        out = fn()
    except ALLOWED:
        return None
    except BaseException as err:  # finding anything else is the point
        if isinstance(err, KeyboardInterrupt):
            raise
        _finding(target, type(err).__name__, str(err))
        return None
    if check is not None:
        problem = check(out)
        if problem:
            _finding(target, "bad result", problem)
    return out


def _finite_number(v: Any) -> str | None:
    return None if np.isfinite(v) or v == -np.inf else f"non-finite result {v}"


def _posteriors_ok(p: Any) -> str | None:
    p = np.asarray(p)
    if p.size == 0:
        return None
    if not np.isfinite(p).all():
        return "posteriors contain NaN/inf"
    if not np.allclose(p.sum(axis=1), 1.0, atol=1e-6):
        return f"posterior rows sum to {p.sum(axis=1).min()}..{p.sum(axis=1).max()}"
    return None


fit_options = st.fixed_dictionaries(
    {
        "n_states": st.sampled_from([1, 2, 3, 5, *SIZES]),
        "n_mix": st.sampled_from([1, 2, 3, 10**6, *SIZES]),
        "covariance": st.sampled_from(["diag", "full", "spherical", "tied", "bogus"]),
        "topology": st.sampled_from(["left-right", "ergodic", "bogus"]),
        "max_iter": st.sampled_from([1, 3, 0, 2**40]),
        "tol": st.sampled_from([1e-4, 0.0, -1.0, float("nan")]),
        "covariance_floor": st.sampled_from([1e-3, 0.0, -1.0, float("inf"), 1e300]),
        "seed": st.integers(0, 2**64 - 1),
    }
)


def _fit(seqs: list[np.ndarray], opts: dict[str, Any]) -> Any:
    return _hmmseg.Hmm.fit(seqs, **opts)


def run(examples: int, seed: int, targets: set[str]) -> None:
    common = settings(
        max_examples=examples,
        deadline=None,
        database=None,
        derandomize=False,
        phases=[Phase.generate],
        suppress_health_check=list(HealthCheck),
    )
    model_holder: dict[str, Any] = {}

    def model() -> Any:
        if "m" not in model_holder:
            x = np.random.default_rng(1).normal(size=(60, 2))
            fitted = _hmmseg.Hmm.fit([x], n_states=3, n_mix=1, covariance="diag", max_iter=5)
            model_holder["m"] = fitted[0]
        return model_holder["m"]

    if "fit" in targets:

        @common
        @given(st.lists(arrays(min_rows=0), min_size=0, max_size=3), fit_options)
        def fit(seqs: list[np.ndarray], opts: dict[str, Any]) -> None:
            _call("fit", lambda: _fit(seqs, opts))

        hypothesis_seed(seed)(fit)()

    if "score" in targets:

        @common
        @given(arrays(max_cols=3))
        def score(x: np.ndarray) -> None:
            m = model()
            _call("log_likelihood", lambda: m.log_likelihood(x), _finite_number)
            _call("prefix", lambda: m.prefix_log_likelihoods(x))
            _call("viterbi", lambda: m.viterbi(x), lambda r: _finite_number(r[0]))
            _call("posteriors", lambda: m.posteriors(x), _posteriors_ok)

        hypothesis_seed(seed)(score)()

    if "sample" in targets:

        @common
        @given(st.sampled_from([0, 1, 7, 10**5, *SIZES, -1]), st.integers(0, 2**64 - 1))
        def sample(n: int, s: int) -> None:
            m = model()
            _call("sample", lambda: m.sample(n, seed=s))

        hypothesis_seed(seed)(sample)()

    if "dtw" in targets:

        @common
        @given(arrays(max_rows=30), arrays(max_rows=30), st.sampled_from([None, 0, 1, 5, 2**40]))
        def dtw(a: np.ndarray, b: np.ndarray, band: int | None) -> None:
            finite = [np.abs(v[np.isfinite(v)]) for v in (a, b)]
            big = max((float(f.max()) for f in finite if f.size), default=0.0)
            # squared distances of values beyond 1e150 overflow f64: inf is the honest answer
            check = _finite_number if big < 1e150 else None
            _call("dtw_distance", lambda: _hmmseg.dtw_distance(a, b, band=band), check)

        hypothesis_seed(seed)(dtw)()

    if "minmax" in targets:

        @common
        @given(arrays())
        def minmax(x: np.ndarray) -> None:
            _call("minmax", lambda: _hmmseg.minmax(x))

        hypothesis_seed(seed)(minmax)()

    if "json" in targets:
        valid = model().to_json()

        @common
        @given(st.integers(0, len(valid) - 1), st.text(max_size=8), st.booleans())
        def from_json(pos: int, insert: str, truncate: bool) -> None:
            text = valid[:pos] if truncate else valid[:pos] + insert + valid[pos + 1 :]
            _call("from_json", lambda: _hmmseg.Hmm.from_json(text))

        hypothesis_seed(seed)(from_json)()

    if "mcap" in targets:
        import tempfile
        from pathlib import Path

        valid_file = (Path(__file__).parents[2] / "recordings" / "exp1.mcap").read_bytes()
        where = Path(tempfile.mkdtemp(prefix="lfd-fuzz-")) / "f.mcap"

        @common
        @given(
            st.integers(0, len(valid_file)),
            st.lists(st.tuples(st.integers(0, len(valid_file) - 1), st.binary(max_size=9))),
            st.booleans(),
        )
        def mcap(cut: int, edits: list[tuple[int, bytes]], images: bool) -> None:
            data = bytearray(valid_file[:cut])
            for pos, chunk in edits:  # overwrite bytes: headers, lengths, CRCs, payloads
                data[pos : pos + len(chunk)] = chunk
            where.write_bytes(bytes(data))
            _call("read_recording", lambda: _hmmseg.read_recording(str(where), images))
            _call("read_summary", lambda: _hmmseg.read_summary(str(where), ["/lfd/ground_truth"]))

        hypothesis_seed(seed)(mcap)()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--examples", type=int, default=300, help="examples per target (300)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--targets", default="fit,score,sample,dtw,minmax,json,mcap")
    args = parser.parse_args()
    t0 = time.perf_counter()
    try:
        run(args.examples, args.seed, set(args.targets.split(",")))
    except Exception:  # a failure of the harness itself
        traceback.print_exc()
        return 3
    doc = {
        "executions": dict(COUNTS),
        "total": sum(COUNTS.values()),
        "seconds": round(time.perf_counter() - t0, 1),
        "findings": [
            {"target": t, "kind": k, "message": m, "count": c} for (t, k, m), c in FINDINGS.items()
        ],
    }
    print(json.dumps(doc))
    return 1 if FINDINGS else 0


if __name__ == "__main__":
    sys.exit(main())
