"""Fuzz every public entry point of the engine binding ``lfd._hmmseg``.

Each target is one entry point (a function, a constructor, a method or a property of a class);
:data:`TARGETS` lists them and ``--check-coverage`` (run by ``tests/unit/engine/test_fuzz.py``) fails when a
public name of ``lfd._hmmseg`` has no target. A case is drawn from its own seeded generator
(``seed``, target, case number), so any finding is replayed with ``--replay TARGET:CASE``.
Inputs mix sane values with absurd ones: sizes from 0 to 2**200 and negative, NaN/inf, huge and
tiny magnitudes, every memory layout, wrong dtypes and dimensions, and, for the MCAP reader,
recordings cut short and overwritten with random bytes (written to a temporary file).

Every call must return or raise an ``lfd.errors.LfdError`` (or a ``TypeError`` for an argument
of the wrong Python type). The kinds of finding:

- ``abort``: the process died (an allocation failure, a segfault) - the cases run in a worker
  process, so the supervisor counts it, names the case and restarts the worker after it;
- ``hang``: one call ran longer than ``--timeout`` seconds (the worker is killed);
- ``panic``: ``lfd.errors.InternalError`` (a Rust panic caught at the boundary) or a
  ``PanicException``;
- ``exception``: any other exception (``OverflowError``, ``MemoryError``, ``ValueError``...);
- ``bad result``: NaN where a number is promised, posteriors whose rows do not sum to 1.

Usage::

    python tests/fuzz/engine_fuzz.py --cases 2000 --seed 0 [--targets dtw,Hmm.fit] \
        [--seconds 60] [--timeout 30]

``--cases`` is the number of cases per target, ``--seconds`` (optional) a time budget per target.
The last line of output is one JSON document: calls per target, the total, the time, and the
findings (target, kind, message, first case, count); the exit status is 1 with findings.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import mmap
import os
import signal
import struct
import subprocess
import sys
import tempfile
import threading
import time
import traceback
import zlib
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[2]

# ----------------------------------------------------------------------------------------------
# value generators (each takes the case's numpy Generator)
# ----------------------------------------------------------------------------------------------
MAGNITUDES = [0.0, 1e-300, 1e-12, 1e-3, 1.0, 1.0, 1.0, 10.0, 1e6, 1e50, 1e150, 1e160, 1e300]
SPECIALS = [np.nan, np.inf, -np.inf, 0.0, -0.0, 5e-324, 1.7976931348623157e308]
HUGE = [2**31, 2**40, 2**62, 2**63 - 1, 2**63, 2**64 - 1, 2**64, 2**200, -1, -(2**63)]

MASK = (1 << 64) - 1
_BITS = np.random.PCG64(0)
_NUMPY = np.random.Generator(_BITS)


class Rng:
    """The generator of one case: splitmix64 in Python for the scalar draws (no seeding cost,
    which dominates the fast targets), numpy for arrays (its shared generator set from this one
    the first time a case asks for an array)."""

    __slots__ = ("_np", "_s")

    def __init__(self, key: int) -> None:
        self._s = key & MASK
        self._np: np.random.Generator | None = None

    def next64(self) -> int:
        self._s = s = (self._s + 0x9E3779B97F4A7C15) & MASK
        z = ((s ^ (s >> 30)) * 0xBF58476D1CE4E5B9) & MASK
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & MASK
        return z ^ (z >> 31)

    def numpy(self) -> np.random.Generator:
        if self._np is None:
            _BITS.state = {
                "bit_generator": "PCG64",
                "state": {"state": self.next64() << 64 | self.next64(), "inc": self.next64() | 1},
                "has_uint32": 0,
                "uinteger": 0,
            }
            self._np = _NUMPY
        return self._np

    def random(self, size: Any = None) -> Any:
        if size is None:
            return (self.next64() >> 11) * 2.0**-53
        return self.numpy().random(size)

    def integers(self, lo: int, hi: int | None = None) -> int:
        lo, hi = (0, lo) if hi is None else (lo, hi)
        return lo + self.next64() % (hi - lo)

    def gauss(self) -> float:
        u = 1.0 - self.random()
        return math.sqrt(-2.0 * math.log(u)) * math.cos(2.0 * math.pi * self.random())

    def bytes(self, n: int) -> bytes:
        return b"".join(self.next64().to_bytes(8, "little") for _ in range((n + 7) // 8))[:n]

    def normal(self, *args: Any, **kw: Any) -> Any:
        return self.numpy().normal(*args, **kw)

    def uniform(self, *args: Any, **kw: Any) -> Any:
        return self.numpy().uniform(*args, **kw)

    def choice(self, *args: Any, **kw: Any) -> Any:
        return self.numpy().choice(*args, **kw)


def pick(rng: Rng, values: list[Any]) -> Any:
    """One of `values` (exactly: Python ints of any size stay ints)."""
    return values[int(rng.integers(len(values)))]


def size(rng: Rng, small: int = 6) -> int:
    """Mostly a small count, sometimes an absurd or negative one."""
    r = rng.random()
    if r < 0.85:
        return int(rng.integers(0, small + 1))
    if r < 0.93:
        return pick(rng, [100, 1000, 10**5, 10**6])
    return int(HUGE[rng.integers(len(HUGE))])


def real(rng: Rng) -> float:
    r = rng.random()
    if r < 0.7:
        return rng.gauss() * MAGNITUDES[rng.integers(len(MAGNITUDES))]
    return float(SPECIALS[rng.integers(len(SPECIALS))])


def layout(rng: Rng, x: np.ndarray) -> np.ndarray:
    r = rng.random()
    if r < 0.6 or x.ndim == 0:
        return x
    if r < 0.75:
        return np.asfortranarray(x)
    if r < 0.88:
        flip = (slice(None, None, -1),) * x.ndim
        return np.ascontiguousarray(x[flip])[flip]
    idx = tuple(slice(None, None, 2) for _ in x.shape)
    big = np.zeros(tuple(2 * s for s in x.shape), dtype=x.dtype)
    big[idx] = x
    return big[idx]


def floats(rng: Rng, shape: tuple[int, ...]) -> np.ndarray:
    """A float64 array of `shape`: normal values at one magnitude, now and then specials."""
    scale = MAGNITUDES[rng.integers(len(MAGNITUDES))]
    x = rng.normal(size=shape) * scale
    if x.size and rng.random() < 0.15:
        for _ in range(int(rng.integers(1, 4))):
            x.flat[rng.integers(x.size)] = SPECIALS[rng.integers(len(SPECIALS))]
    return x


def oddity(rng: Rng, x: np.ndarray) -> Any:
    """`x` itself (mostly), or a wrong dtype / dimension / type."""
    r = rng.random()
    if r < 0.9:
        return layout(rng, x)
    if r < 0.93:
        return x.astype(np.float32)
    if r < 0.95:
        return x.reshape((*x.shape, 1)) if x.size < 64 else x[..., None]
    if r < 0.97:
        return x.ravel()
    if r < 0.98:
        return x.tolist()
    if r < 0.99:
        return x.astype(np.int64) if np.isfinite(x).all() else None
    return "not an array"


def arr(rng: Rng, *trailing: int | None, rows: int | None = None, max_rows: int = 40) -> Any:
    """A float64 array `(rows, *trailing)`; a None trailing dimension is drawn (0..4)."""
    n = int(rng.integers(0, max_rows + 1)) if rows is None else rows
    dims = tuple(int(rng.integers(0, 5)) if t is None else t for t in trailing)
    if rng.random() < 0.03:  # a wrong trailing shape
        dims = tuple(d + int(rng.integers(1, 3)) for d in dims)
    return oddity(rng, floats(rng, (n, *dims)))


def bounds(rng: Rng, n: int | None = None) -> Any:
    """Section boundaries: mostly `[0, ..., n]` strictly increasing, sometimes broken."""
    n = int(rng.integers(1, 60)) if n is None else n
    k = int(rng.integers(0, min(12, max(n, 1)) + 1))
    inner = np.sort(rng.choice(np.arange(1, max(n, 2)), size=min(k, max(n - 1, 0)), replace=False))
    b = np.concatenate([[0], inner, [n]]).astype(np.int64)
    r = rng.random()
    if r < 0.08:
        b = b[::-1].copy()
    elif r < 0.14:
        b[rng.integers(len(b))] = pick(rng, [-1, 2**62, 2**63 - 1])
    elif r < 0.18:
        b = b[:1]
    elif r < 0.2:
        b = np.zeros(0, dtype=np.int64)
    elif r < 0.22:
        b = b.astype(np.float64)  # wrong dtype
    return layout(rng, b) if isinstance(b, np.ndarray) and rng.random() < 0.2 else b


def text_mutation(rng: Rng, valid: str) -> str:
    """`valid` cut, spliced or with a number replaced by an absurd one."""
    r = rng.random()
    pos = int(rng.integers(0, len(valid) + 1))
    if r < 0.3:
        return valid[:pos]
    if r < 0.6:
        junk = rng.choice(
            ['"', "{", "}", "[", "]", ",", ":", "1e400", "-", "null", "\\u0000", "9" * 30]
        )
        return valid[:pos] + str(junk) + valid[pos + 1 :]
    # replace the number at a random position
    digits = [i for i, ch in enumerate(valid) if ch.isdigit()]
    if not digits:
        return valid
    i = digits[int(rng.integers(len(digits)))]
    j = i
    while j < len(valid) and (valid[j].isdigit() or valid[j] in ".e-"):
        j += 1
    new = str(
        rng.choice(["0", "-1", "1e308", "1e999", "NaN", "18446744073709551616", "1099511627776"])
    )
    return valid[:i] + new + valid[j:]


# ----------------------------------------------------------------------------------------------
# fixtures shared by the cases (built once per worker)
# ----------------------------------------------------------------------------------------------
class Fixtures:
    def __init__(self, tmp: Path) -> None:
        from lfd import _hmmseg

        self.h = _hmmseg
        rng = np.random.default_rng(1)
        seqs = [
            np.concatenate([rng.normal(0, 0.3, (25, 2)), rng.normal(2, 0.3, (25, 2))])
            for _ in range(3)
        ]
        self.seqs = seqs
        self.models = [
            _hmmseg.Hmm.fit(seqs, n_states=3, max_iter=5)[0],
            _hmmseg.Hmm.fit(seqs, n_states=2, n_mix=2, covariance="full", max_iter=5)[0],
            _hmmseg.Hmm.fit([s[:, :1] for s in seqs], n_states=1, max_iter=2)[0],
        ]
        self.model_json = [m.to_json() for m in self.models]
        self.skills = ["pick_up", "move_with", "place", "stack", "move", "push", "locate"]
        self.grammar_text = (ROOT / "python" / "lfd" / "data" / "grammar.json").read_text()
        self.grammar = _hmmseg.Grammar(self.grammar_text, self.skills)
        self.tpl_params = json.dumps({"fit": {"n_states": 2, "max_iter": 3}, "align": False})
        examples = [(i % 2, rng.uniform(size=(20 + i, 3))) for i in range(6)]
        self.features = [("a", 0, 1), ("b", 1, 3)]
        self.templates = _hmmseg.TemplateSet.train(
            ["pick_up", "place"], self.features, examples, self.tpl_params
        )
        self.templates_json = self.templates.to_json()
        self.feature_params = _hmmseg.default_feature_params()
        self.template_params = _hmmseg.default_template_params()
        self.recording = (ROOT / "recordings" / "exp1.mcap").read_bytes()
        self.mcap_path = tmp / "f.mcap"

    def model(self, rng: Rng) -> Any:
        return self.models[int(rng.integers(len(self.models)))]

    def mcap_bytes(self, rng: Rng) -> bytes:
        data = bytearray(self.recording[: int(rng.integers(0, len(self.recording) + 1))])
        if rng.random() < 0.2:
            data = bytearray(self.recording)
        for _ in range(int(rng.integers(0, 6))):
            if not data:
                break
            pos = int(rng.integers(len(data)))
            r = rng.random()
            if r < 0.5:
                chunk = rng.bytes(int(rng.integers(1, 9)))
            elif r < 0.8:  # a length or count field set to something absurd
                chunk = struct.pack("<Q", pick(rng, [0, 2**31, 2**32 - 1, 2**40, 2**63, 2**64 - 1]))
            else:
                chunk = bytes([0xFF] * int(rng.integers(1, 9)))
            data[pos : pos + len(chunk)] = chunk
        return bytes(data)


# ----------------------------------------------------------------------------------------------
# targets: name -> (entry points it covers, case function)
# ----------------------------------------------------------------------------------------------
Case = Callable[[Fixtures, Rng], Callable[[], Any]]
TARGETS: dict[str, Case] = {}
COVERS: dict[str, str] = {}  # entry point ("Hmm.fit", "dtw") -> target


def target(name: str, *covers: str) -> Callable[[Case], Case]:
    def register(fn: Case) -> Case:
        TARGETS[name] = fn
        for c in covers or (name,):
            COVERS[c] = name
        return fn

    return register


def _finite(v: Any) -> str | None:
    return None if np.isfinite(v) or v == -np.inf else f"non-finite result {v}"


def _posteriors_ok(p: Any) -> str | None:
    p = np.asarray(p)
    if p.size == 0:
        return None
    if not np.isfinite(p).all():
        return "posteriors contain NaN/inf"
    if not np.allclose(p.sum(axis=1), 1.0, atol=1e-6):
        return "posterior rows do not sum to 1"
    return None


CHECKS: dict[str, Callable[[Any], str | None]] = {
    "Hmm.log_likelihood": _finite,
    "Hmm.viterbi": lambda r: _finite(r[0]),
    "Hmm.posteriors": _posteriors_ok,
}


# --- DTW and normalisation ----------------------------------------------------------------------
def _band(rng: Rng) -> int | None:
    return None if rng.random() < 0.4 else size(rng, 10)


@target("dtw")
def _dtw(f: Fixtures, rng: Rng) -> Callable[[], Any]:
    d = int(rng.integers(0, 4))
    a, b, band = arr(rng, d, max_rows=30), arr(rng, d, max_rows=30), _band(rng)
    return lambda: f.h.dtw(a, b, band)


@target("dtw_distance")
def _dtw_distance(f: Fixtures, rng: Rng) -> Callable[[], Any]:
    d = int(rng.integers(0, 4))
    a, b, band = arr(rng, d, max_rows=30), arr(rng, d, max_rows=30), _band(rng)
    return lambda: f.h.dtw_distance(a, b, band=band)


@target("align_to_reference")
def _align(f: Fixtures, rng: Rng) -> Callable[[], Any]:
    d = int(rng.integers(0, 4))
    ref = arr(rng, d, max_rows=20)
    seqs = [arr(rng, d, max_rows=20) for _ in range(int(rng.integers(0, 4)))]
    band = _band(rng)
    return lambda: f.h.align_to_reference(ref, seqs, band)


@target("minmax")
def _minmax(f: Fixtures, rng: Rng) -> Callable[[], Any]:
    x = arr(rng, None)
    return lambda: f.h.minmax(x)


@target("minmax_with")
def _minmax_with(f: Fixtures, rng: Rng) -> Callable[[], Any]:
    d = int(rng.integers(0, 4))
    x = arr(rng, d)
    lo = oddity(rng, floats(rng, (d + int(rng.random() < 0.05),)))
    hi = oddity(rng, floats(rng, (d,)))
    return lambda: f.h.minmax_with(x, lo, hi)


# --- features ------------------------------------------------------------------------------------
def _params_json(f: Fixtures, rng: Rng) -> str | None:
    r = rng.random()
    if r < 0.6:
        return None
    if r < 0.8:
        return f.feature_params
    return text_mutation(rng, f.feature_params)


@target("compute_features")
def _compute_features(f: Fixtures, rng: Rng) -> Callable[[], Any]:
    n, k = int(rng.integers(0, 40)), int(rng.integers(0, 4))
    tcp = arr(rng, 3, rows=n)
    opening = oddity(rng, floats(rng, (n,)))
    pos = oddity(rng, floats(rng, (k, n, 3)))
    quat = oddity(rng, floats(rng, (k, n, 4)))
    sz = oddity(rng, np.abs(floats(rng, (k, 3))))
    dt = real(rng) if rng.random() < 0.2 else 0.05
    tgt = None if rng.random() < 0.7 else bounds(rng, n)
    p = _params_json(f, rng)
    return lambda: f.h.compute_features(tcp, opening, pos, quat, sz, dt, tgt, p)


@target("label_targets")
def _label_targets(f: Fixtures, rng: Rng) -> Callable[[], Any]:
    n, k = int(rng.integers(0, 40)), int(rng.integers(0, 4))
    tcp = arr(rng, 3, rows=n)
    pos = oddity(rng, floats(rng, (k, n, 3)))
    sz = oddity(rng, np.abs(floats(rng, (k, 3))))
    dt = real(rng) if rng.random() < 0.2 else 0.05
    p = _params_json(f, rng)
    return lambda: f.h.label_targets(tcp, pos, sz, dt, p)


@target("default_feature_params")
def _default_feature_params(f: Fixtures, rng: Rng) -> Callable[[], Any]:
    return f.h.default_feature_params


@target("check_feature_params")
def _check_feature_params(f: Fixtures, rng: Rng) -> Callable[[], Any]:
    text = text_mutation(rng, f.feature_params)
    return lambda: f.h.check_feature_params(text)


# --- HMM ---------------------------------------------------------------------------------------
ITERS = [0, 1, 2, 3, 5, 10, 100, 10_000, 10_001, 2**40, -1, 2**64]


def _iters(rng: Rng) -> int:
    # a legitimate 10 000 iterations is slow: rare
    v = ITERS[int(rng.integers(len(ITERS)))]
    return 3 if v == 10_000 and rng.random() < 0.95 else v


def _tol(rng: Rng) -> float:
    return pick(rng, [1e-4, 0.0, -1.0, -1e-9, -np.inf, np.inf, np.nan, 1e300])


def _seqs(rng: Rng, d: int | None = None, max_rows: int = 40) -> list[Any]:
    d = int(rng.integers(0, 4)) if d is None else d
    return [arr(rng, d, max_rows=max_rows) for _ in range(int(rng.integers(0, 4)))]


@target("Hmm.fit", "Hmm.fit", "Hmm")
def _fit(f: Fixtures, rng: Rng) -> Callable[[], Any]:
    seqs = _seqs(rng)
    opts = {
        "n_states": size(rng, 5),
        "n_mix": size(rng, 3),
        "covariance": pick(rng, ["diag", "full", "full", "diag", "spherical"]),
        "topology": pick(rng, ["left-right", "ergodic", "ring"]),
        "seed": pick(rng, [0, 1, 2**64 - 1, 2**64, -1]),
        "max_iter": _iters(rng),
        "tol": _tol(rng),
        "covariance_floor": pick(rng, [1e-3, 1e-3, 0.0, -1.0, np.inf, np.nan, 1e300]),
    }
    return lambda: f.h.Hmm.fit(seqs, **opts)


@target("Hmm.refit")
def _refit(f: Fixtures, rng: Rng) -> Callable[[], Any]:
    m = f.model(rng)
    seqs = _seqs(rng, m.n_features if rng.random() < 0.9 else None)
    it, tol = _iters(rng), _tol(rng)
    floor = pick(rng, [1e-3, 1e-3, 0.0, -1.0, np.inf, np.nan])
    return lambda: m.refit(seqs, max_iter=it, tol=tol, covariance_floor=floor)


@target("Hmm.from_params")
def _from_params(f: Fixtures, rng: Rng) -> Callable[[], Any]:
    m = f.model(rng)
    cov = "full" if rng.random() < 0.5 else "diag"
    parts = [m.startprob, m.transmat, m.weights, m.means, m.covars]
    if cov == "diag":
        parts[4] = np.diagonal(m.covars, axis1=2, axis2=3).copy()
    out = []
    for p in parts:
        p = np.array(p, dtype=np.float64)
        if p.size and rng.random() < 0.15:
            p.flat[rng.integers(p.size)] = real(rng)
        if rng.random() < 0.05:
            p = floats(rng, tuple(int(rng.integers(0, 4)) for _ in range(p.ndim)))
        out.append(oddity(rng, p))
    return lambda: f.h.Hmm.from_params(*out, cov)


@target("Hmm.from_json")
def _from_json(f: Fixtures, rng: Rng) -> Callable[[], Any]:
    text = text_mutation(rng, f.model_json[int(rng.integers(len(f.model_json)))])
    return lambda: f.h.Hmm.from_json(text)


@target(
    "Hmm.to_json",
    "Hmm.to_json",
    "Hmm.n_states",
    "Hmm.n_features",
    "Hmm.n_mix",
    "Hmm.covariance",
    "Hmm.startprob",
    "Hmm.transmat",
    "Hmm.weights",
    "Hmm.means",
    "Hmm.covars",
    "Hmm.__eq__",
    "Hmm.__repr__",
)
def _hmm_props(f: Fixtures, rng: Rng) -> Callable[[], Any]:
    m, o = f.model(rng), f.model(rng)

    def call() -> Any:
        return (
            m.to_json(),
            m.n_states,
            m.n_features,
            m.n_mix,
            m.covariance,
            m.startprob,
            m.transmat,
            m.weights,
            m.means,
            m.covars,
            m == o,
            m == 3,
            repr(m),
        )

    return call


def _scored(name: str) -> Case:
    def case(f: Fixtures, rng: Rng) -> Callable[[], Any]:
        m = f.model(rng)
        x = arr(rng, m.n_features if rng.random() < 0.9 else None, max_rows=60)
        meth = getattr(m, name)
        return lambda: meth(x)

    return case


for _name in ("log_likelihood", "prefix_log_likelihoods", "viterbi", "posteriors"):
    target(f"Hmm.{_name}")(_scored(_name))


@target("Hmm.log_likelihood_many")
def _ll_many(f: Fixtures, rng: Rng) -> Callable[[], Any]:
    m = f.model(rng)
    seqs = _seqs(rng, m.n_features if rng.random() < 0.9 else None, max_rows=30)
    return lambda: m.log_likelihood_many(seqs)


@target("Hmm.sample")
def _sample(f: Fixtures, rng: Rng) -> Callable[[], Any]:
    m, n = f.model(rng), size(rng, 50)
    s = pick(rng, [0, 7, 2**64 - 1, 2**64, -1])
    return lambda: m.sample(n, seed=s)


# --- segmentation ---------------------------------------------------------------------------------
@target("stage1_boundaries")
def _stage1(f: Fixtures, rng: Rng) -> Callable[[], Any]:
    n, c = int(rng.integers(0, 80)), int(rng.integers(0, 5))
    v, t = arr(rng, c, rows=n), arr(rng, c, rows=n)
    k = int(rng.integers(0, 4))
    cols = [size(rng, c) for _ in range(k)]
    hyst = [real(rng) for _ in range(k + int(rng.random() < 0.05))]
    ms = size(rng, 5)
    return lambda: f.h.stage1_boundaries(v, t, cols, hyst, ms)


@target("rising_table")
def _rising_table(f: Fixtures, rng: Rng) -> Callable[[], Any]:
    n = int(rng.integers(1, 60))
    z, b = oddity(rng, floats(rng, (n + int(rng.random() < 0.1),))), bounds(rng, n)
    mr, dom = real(rng), real(rng)
    return lambda: f.h.rising_table(z, b, mr, dom)


@target("rising_band")
def _rising_band(f: Fixtures, rng: Rng) -> Callable[[], Any]:
    n = int(rng.integers(1, 60))
    z, b = oddity(rng, floats(rng, (n + int(rng.random() < 0.1),))), bounds(rng, n)
    ml, mr, dom = size(rng, 30), real(rng), real(rng)
    return lambda: f.h.rising_band(z, b, ml, mr, dom)


@target(
    "Band",
    "Band",
    "Band.boundaries",
    "Band.max_len",
    "Band.n_sections",
    "Band.n_runs",
    "Band.offsets",
    "Band.last_ends",
    "Band.runs",
    "Band.index",
    "Band.__eq__",
    "Band.__repr__",
)
def _band_all(f: Fixtures, rng: Rng) -> Callable[[], Any]:
    b, ml = bounds(rng), size(rng, 30)
    i, j = size(rng, 10), size(rng, 12)

    def call() -> Any:
        band = f.h.Band(b, ml)
        out = (
            band.boundaries,
            band.max_len,
            band.n_sections,
            band.n_runs,
            band.offsets,
            band.last_ends,
            band.runs(),
            band.index(i, j),
            band == band,
            repr(band),
        )
        if band.n_runs and band.index(0, 1) != 0:
            return "first run is not row 0"
        return out

    return call


@target("Grammar", "Grammar", "Grammar.skills", "Grammar.__eq__", "Grammar.__repr__")
def _grammar(f: Fixtures, rng: Rng) -> Callable[[], Any]:
    text = f.grammar_text if rng.random() < 0.2 else text_mutation(rng, f.grammar_text)
    skills = list(f.skills)
    r = rng.random()
    if r < 0.1:
        skills = skills[: int(rng.integers(0, len(skills)))]
    elif r < 0.15:
        skills = [*skills, skills[0]]

    def call() -> Any:
        g = f.h.Grammar(text, skills)
        return (g.skills, g == f.grammar, repr(g))

    return call


def _search(name: str) -> Case:
    def case(f: Fixtures, rng: Rng) -> Callable[[], Any]:
        n = int(rng.integers(1, 80))
        b = bounds(rng, n)
        k = max(len(b) - 1, 1) if isinstance(b, np.ndarray) else 1
        s = len(f.skills) if rng.random() < 0.9 else int(rng.integers(0, 9))
        dense = rng.random() < 0.5
        ml = 0 if dense and rng.random() < 0.9 else size(rng, 40)
        if dense:
            scores = -np.abs(floats(rng, (k, k + 1, s)))
            rising = rng.random((k, k + 1)) < 0.3 if rng.random() < 0.5 else None
        else:
            try:
                runs = f.h.Band(b, ml).n_runs
            except Exception:
                runs = int(rng.integers(0, 10))
            runs = min(runs, 5000) + (int(rng.random() < 0.05))
            scores = -np.abs(floats(rng, (runs, s)))
            rising = rng.random(runs) < 0.3 if rng.random() < 0.5 else None
        if scores.size and rng.random() < 0.2:
            scores.flat[rng.integers(scores.size)] = pick(rng, [-np.inf, np.nan, np.inf])
        scores = oddity(rng, scores)
        mode = pick(rng, ["off", "warn", "enforce", "bogus"])
        extra = bool(rng.random() < 0.5) if name == "segment_greedy" else real(rng)
        fn = getattr(f.h, name)

        def call() -> Any:
            cuts, warnings = fn(scores, b, f.grammar, rising, mode, extra, ml)
            return [
                (
                    c.skill,
                    c.start_section,
                    c.end_section,
                    c.start,
                    c.end,
                    c.score,
                    c.margin,
                    c.confidence,
                    repr(c),
                    c == c,
                )
                for c in cuts
            ], warnings

        return call

    return case


target("segment_greedy", "segment_greedy", "Cut")(_search("segment_greedy"))
target(
    "segment_dp",
    "segment_dp",
    "Cut.skill",
    "Cut.start_section",
    "Cut.end_section",
    "Cut.start",
    "Cut.end",
    "Cut.score",
    "Cut.margin",
    "Cut.confidence",
    "Cut.__eq__",
    "Cut.__repr__",
)(_search("segment_dp"))


# --- templates ---------------------------------------------------------------------------------
@target("default_template_params")
def _default_template_params(f: Fixtures, rng: Rng) -> Callable[[], Any]:
    return f.h.default_template_params


@target("template_params")
def _template_params(f: Fixtures, rng: Rng) -> Callable[[], Any]:
    text = text_mutation(rng, f.template_params)
    return lambda: f.h.template_params(text)


@target("TemplateSet.train", "TemplateSet.train", "TemplateSet")
def _train(f: Fixtures, rng: Rng) -> Callable[[], Any]:
    c = int(rng.integers(0, 5))
    n_skills = int(rng.integers(0, 4))
    skills = [f.skills[i] for i in range(n_skills)]
    feats = []
    for i in range(int(rng.integers(0, 3))):
        s = int(rng.integers(0, c + 1)) if rng.random() < 0.9 else size(rng)
        e = s + int(rng.integers(0, 3)) if rng.random() < 0.9 else size(rng)
        feats.append((f"f{i}", s, e))
    examples = [
        (
            int(rng.integers(0, max(n_skills, 1))) if rng.random() < 0.95 else size(rng),
            arr(rng, c, max_rows=30),
        )
        for _ in range(int(rng.integers(0, 6)))
    ]
    r = rng.random()
    if r < 0.5:
        params: str | None = f.tpl_params
    elif r < 0.6:
        params = None
    else:
        params = text_mutation(rng, f.tpl_params)
    return lambda: f.h.TemplateSet.train(skills, feats, examples, params)


@target("TemplateSet.from_json")
def _tpl_from_json(f: Fixtures, rng: Rng) -> Callable[[], Any]:
    text = text_mutation(rng, f.templates_json)
    return lambda: f.h.TemplateSet.from_json(text)


@target(
    "TemplateSet.to_json",
    "TemplateSet.to_json",
    "TemplateSet.skills",
    "TemplateSet.features",
    "TemplateSet.ranges",
    "TemplateSet.n_examples",
    "TemplateSet.params_json",
)
def _tpl_props(f: Fixtures, rng: Rng) -> Callable[[], Any]:
    t = f.templates

    def call() -> Any:
        return (t.to_json(), t.skills, t.features, t.ranges, t.n_examples, t.params_json)

    return call


@target("TemplateSet.normalise")
def _normalise(f: Fixtures, rng: Rng) -> Callable[[], Any]:
    x = arr(rng, 3 if rng.random() < 0.9 else None)
    return lambda: f.templates.normalise(x)


def _score(name: str) -> Case:
    def case(f: Fixtures, rng: Rng) -> Callable[[], Any]:
        n = int(rng.integers(1, 60))
        raw = arr(rng, 3 if rng.random() < 0.9 else None, rows=n)
        b = bounds(rng, n)
        ml = size(rng, 40)
        end = pick(rng, ["final", "any", "bogus"])
        feats = (
            None if rng.random() < 0.7 else [size(rng, 2) for _ in range(int(rng.integers(0, 3)))]
        )
        meth = getattr(f.templates, name)
        return lambda: meth(raw, b, ml, end, feats)

    return case


target("TemplateSet.score_table")(_score("score_table"))
target("TemplateSet.score_band")(_score("score_band"))


# --- MCAP reader ---------------------------------------------------------------------------------
@target("read_recording")
def _read_recording(f: Fixtures, rng: Rng) -> Callable[[], Any]:
    data = f.mcap_bytes(rng)
    images = bool(rng.random() < 0.5)
    raw = None if rng.random() < 0.7 else ["/lfd/ground_truth", "/nope"][: int(rng.integers(0, 3))]

    def call() -> Any:
        f.mcap_path.write_bytes(data)
        return f.h.read_recording(str(f.mcap_path), images, raw)

    return call


@target("read_summary")
def _read_summary(f: Fixtures, rng: Rng) -> Callable[[], Any]:
    data = f.mcap_bytes(rng)
    topics = ["/lfd/ground_truth", "/tf", "/nope"][: int(rng.integers(0, 4))]

    def call() -> Any:
        f.mcap_path.write_bytes(data)
        return f.h.read_summary(f.mcap_path, topics)

    return call


# --- signal processing ---------------------------------------------------------------------------
def _coefficients(rng: Rng) -> tuple[Any, Any]:
    r = rng.random()
    if r < 0.5:
        n = int(rng.integers(1, 6))
        return (oddity(rng, floats(rng, (n,))), oddity(rng, floats(rng, (n,))))
    if r < 0.8:
        b, a = np.array([0.2, 0.4, 0.2]), np.array([1.0, -0.5, 0.1])
        return oddity(rng, b), oddity(rng, a)
    # the longest filter allowed is legitimately slow (lfilter_zi is cubic in it): rare
    n = pick(rng, [0, 21, 1025, 5000]) if rng.random() < 0.99 else 1024
    return floats(rng, (n,)), floats(rng, (int(rng.integers(1, 4)),))


@target("butter_lowpass")
def _butter(f: Fixtures, rng: Rng) -> Callable[[], Any]:
    order = size(rng, 25)
    cutoff = real(rng) if rng.random() < 0.5 else float(rng.uniform(0, 20))
    fs = real(rng) if rng.random() < 0.5 else 30.0
    return lambda: f.h.butter_lowpass(order, cutoff, fs)


@target("lfilter_zi")
def _lfilter_zi(f: Fixtures, rng: Rng) -> Callable[[], Any]:
    b, a = _coefficients(rng)
    if rng.random() < 0.5:
        a, b = b, a
    return lambda: f.h.lfilter_zi(b, a)


@target("filtfilt")
def _filtfilt(f: Fixtures, rng: Rng) -> Callable[[], Any]:
    b, a = _coefficients(rng)
    shape = tuple(int(rng.integers(0, 4)) for _ in range(int(rng.integers(0, 3))))
    x = oddity(rng, floats(rng, (int(rng.integers(0, 60)), *shape)))
    pad = size(rng, 20)
    return lambda: f.h.filtfilt(b, a, x, pad)


@target("filtfilt_runs")
def _filtfilt_runs(f: Fixtures, rng: Rng) -> Callable[[], Any]:
    b, a = _coefficients(rng)
    n, c = int(rng.integers(0, 60)), int(rng.integers(0, 4))
    x = arr(rng, c, rows=n)
    ok = rng.random((n + int(rng.random() < 0.05), c)) < 0.8
    pad = size(rng, 20)
    return lambda: f.h.filtfilt_runs(b, a, x, ok, pad)


@target("solve_tridiagonal")
def _tridiagonal(f: Fixtures, rng: Rng) -> Callable[[], Any]:
    m = int(rng.integers(0, 30))
    d = oddity(rng, floats(rng, (m,)))
    dl = oddity(rng, floats(rng, (max(m - 1 + int(rng.random() < 0.05), 0),)))
    du = oddity(rng, floats(rng, (max(m - 1, 0),)))
    shape = tuple(int(rng.integers(0, 4)) for _ in range(int(rng.integers(0, 3))))
    rhs = oddity(rng, floats(rng, (m + int(rng.random() < 0.05), *shape)))
    return lambda: f.h.solve_tridiagonal(dl, d, du, rhs)


def _times(rng: Rng, m: int) -> Any:
    t = np.cumsum(np.abs(rng.normal(size=m)) + (0 if rng.random() < 0.1 else 0.01))
    if m and rng.random() < 0.1:
        t.flat[rng.integers(m)] = real(rng)
    return oddity(rng, t)


@target("cubic_spline")
def _cubic(f: Fixtures, rng: Rng) -> Callable[[], Any]:
    m = int(rng.integers(0, 30))
    t = _times(rng, m)
    shape = tuple(int(rng.integers(0, 4)) for _ in range(int(rng.integers(0, 3))))
    y = oddity(rng, floats(rng, (m + int(rng.random() < 0.05), *shape)))
    at = oddity(rng, rng.uniform(-1, m + 1, int(rng.integers(0, 40))))
    return lambda: f.h.cubic_spline(t, y, at)


@target("resample_columns")
def _resample(f: Fixtures, rng: Rng) -> Callable[[], Any]:
    m, c = int(rng.integers(0, 30)), int(rng.integers(0, 7))
    ts = _times(rng, m)
    x = floats(rng, (m + int(rng.random() < 0.05), c))
    if x.size:
        x[rng.random(x.shape) < 0.2] = np.nan
    x = x if rng.random() < 0.9 else oddity(rng, x)
    cw = pick(rng, [1, 1, 2, 3, 0, c]) if c else 1
    w = (
        None
        if rng.random() < 0.4
        else (np.abs(floats(rng, (m, cw))) if rng.random() < 0.95 else arr(rng, None))
    )
    td = oddity(rng, rng.uniform(-1, m + 1, int(rng.integers(0, 40))))
    gap = real(rng) if rng.random() < 0.3 else 1.0
    return lambda: f.h.resample_columns(ts, x, w, td, gap)


# --- rotations ---------------------------------------------------------------------------------
def _rot(name: str, *inner: int) -> Case:
    def case(f: Fixtures, rng: Rng) -> Callable[[], Any]:
        shape = inner if rng.random() < 0.95 else tuple(int(rng.integers(0, 5)) for _ in inner)
        x = arr(rng, *shape, max_rows=20)
        fn = getattr(f.h, name)
        return lambda: fn(x)

    return case


for _name, _inner in {
    "quat_normalize": (4,),
    "quat_to_matrix": (4,),
    "quat_from_matrix": (3, 3),
    "euler_xyz_from_matrix": (3, 3),
    "matrix_from_euler_xyz": (3,),
    "euler_xyz_from_quat": (4,),
    "quat_from_euler_xyz": (3,),
    "quat_make_continuous": (4,),
}.items():
    target(_name)(_rot(_name, *_inner))


def _rows(rng: Rng, d: int) -> tuple[Any, Any]:
    n = int(rng.integers(0, 20))
    m = n if rng.random() < 0.7 else pick(rng, [1, 0, n + 1])
    return arr(rng, d, rows=n), arr(rng, d if rng.random() < 0.95 else 4 - d % 4 + 1, rows=m)


@target("quat_multiply")
def _quat_multiply(f: Fixtures, rng: Rng) -> Callable[[], Any]:
    p, q = _rows(rng, 4)
    return lambda: f.h.quat_multiply(p, q)


@target("quat_apply")
def _quat_apply(f: Fixtures, rng: Rng) -> Callable[[], Any]:
    n = int(rng.integers(0, 20))
    m = n if rng.random() < 0.7 else pick(rng, [1, 0, n + 1])
    q, v = arr(rng, 4, rows=n), arr(rng, 3, rows=m)
    inv = bool(rng.random() < 0.5)
    return lambda: f.h.quat_apply(q, v, inv)


@target("quat_slerp")
def _quat_slerp(f: Fixtures, rng: Rng) -> Callable[[], Any]:
    m = int(rng.integers(0, 20))
    times = _times(rng, m)
    q = arr(rng, 4, rows=m + int(rng.random() < 0.05))
    at = oddity(rng, rng.uniform(-1, m + 1, int(rng.integers(0, 30))))
    return lambda: f.h.quat_slerp(times, q, at)


# --- the harness's own check: a target that aborts the process and one that hangs -------------
if os.environ.get("LFD_FUZZ_SELFTEST") == "1":

    @target("selftest.abort", "selftest.abort")
    def _selftest_abort(f: Fixtures, rng: Rng) -> Callable[[], Any]:
        return lambda: os.abort() if rng.random() < 0.1 else None

    @target("selftest.hang", "selftest.hang")
    def _selftest_hang(f: Fixtures, rng: Rng) -> Callable[[], Any]:
        return lambda: time.sleep(3600) if rng.random() < 0.05 else None


# ----------------------------------------------------------------------------------------------
# coverage: every public name of lfd._hmmseg has a target
# ----------------------------------------------------------------------------------------------
NOT_ENTRY_POINTS = {
    "__version__", "FEATURE_NAMES", "FEATURE_GROUPS",
    "CovarianceType", "Topology", "GrammarMode", "EndState", "SizeMeasure",
}  # fmt: skip


def entry_points() -> set[str]:
    """Public functions, classes and their public methods / properties of `lfd._hmmseg`."""
    from lfd import _hmmseg

    out: set[str] = set()
    for name in dir(_hmmseg):
        if name.startswith("_") or name in NOT_ENTRY_POINTS:
            continue
        obj = getattr(_hmmseg, name)
        out.add(name)
        if isinstance(obj, type):
            for attr, value in vars(obj).items():
                if not attr.startswith("_") or attr in ("__eq__", "__repr__"):
                    if callable(value) or hasattr(value, "__get__"):
                        out.add(f"{name}.{attr}")
    return out


def missing_targets() -> list[str]:
    return sorted(entry_points() - set(COVERS))


# ----------------------------------------------------------------------------------------------
# worker: runs the cases of the targets in turn, reporting progress through a shared status page
# ----------------------------------------------------------------------------------------------
# target index, case, calls made in this target, call start (monotonic), target deadline (wall
# clock), in a call
STATUS = struct.Struct("<qqqddb")


def _rng(seed: int, name: str, case: int) -> Rng:
    return Rng((seed * 0x100000001B3 ^ zlib.crc32(name.encode())) << 32 ^ case)


def classify(err: BaseException) -> str | None:
    """The kind of finding an exception is (None: the contract allows it)."""
    from lfd.errors import InternalError, LfdError

    if isinstance(err, InternalError):
        return "panic"
    if type(err).__name__ == "PanicException":
        return "panic"
    if isinstance(err, LfdError | TypeError):
        return None
    return "exception"


def build(f: Fixtures, name: str, seed: int, case: int) -> Callable[[], Any]:
    """The call of one case (its inputs drawn)."""
    return TARGETS[name](f, _rng(seed, name, case))


def run(name: str, call: Callable[[], Any]) -> tuple[str, str] | None:
    """Run one case's call; the finding `(kind, message)` or None."""
    try:
        out = call()
    except KeyboardInterrupt:
        raise
    except BaseException as err:  # finding anything else is the point
        kind = classify(err)
        return None if kind is None else (kind, f"{type(err).__name__}: {err}")
    if isinstance(out, str) and name.startswith("Band"):
        return ("bad result", out)
    check = CHECKS.get(name)
    problem = check(out) if check is not None else None
    return ("bad result", problem) if problem else None


def worker(args: argparse.Namespace) -> int:
    """Run targets `args.first`.. of `args.targets`, the first from case `args.start`; append
    one JSON line per finished target to `args.results`."""
    f = Fixtures(Path(args.status).parent)
    names = args.targets.split(",")
    fd = os.open(args.status, os.O_RDWR)
    page = mmap.mmap(fd, STATUS.size)
    clock, pack = time.monotonic, STATUS.pack_into
    for ti in range(args.first, len(names)):
        name = names[ti]
        first = ti == args.first
        start = args.start if first else 0
        until = args.until if first else (time.time() + args.seconds if args.seconds else 1e300)
        findings: dict[tuple[str, str], list[int]] = {}
        calls, case = 0, start
        for case in range(start, args.cases):
            if case % 16 == 0 and time.time() > until:
                break
            call = build(f, name, args.seed, case)
            pack(page, 0, ti, case, calls, clock(), until, 1)
            calls += 1
            found = run(name, call)
            pack(page, 0, ti, case, calls, clock(), until, 0)
            if found is not None:
                key = (found[0], found[1][:200])
                if key in findings:
                    findings[key][1] += 1
                else:
                    findings[key] = [case, 1]
        else:
            case = args.cases
        pack(page, 0, ti, case, calls, clock(), until, 0)
        doc = {
            "target": name,
            "calls": calls,
            "findings": [[k, m, c, n] for (k, m), (c, n) in findings.items()],
        }
        with open(args.results, "a") as out:
            out.write(json.dumps(doc) + "\n")
        pack(page, 0, ti + 1, 0, 0, clock(), 0.0, 0)
    return 0


# ----------------------------------------------------------------------------------------------
# supervisor: a worker process runs the targets; an abort or a hang is counted, the worker killed
# and a new one started at the next case
# ----------------------------------------------------------------------------------------------
def supervise(
    names: list[str], args: argparse.Namespace, tmp: Path
) -> tuple[dict[str, int], list[dict[str, Any]]]:
    status, results = tmp / "status", tmp / "results"
    calls = dict.fromkeys(names, 0)
    log: list[dict[str, Any]] = []
    env = {**os.environ, "RUST_BACKTRACE": "0"}
    first, start = 0, 0
    until = time.time() + args.seconds if args.seconds else 1e300
    while first < len(names):
        status.write_bytes(b"\0" * STATUS.size)
        results.write_text("")
        cmd = [sys.executable, __file__, "--worker", "--targets", ",".join(names),
               "--seed", str(args.seed), "--cases", str(args.cases),
               "--seconds", str(args.seconds), "--first", str(first), "--start", str(start),
               "--until", repr(until), "--status", str(status), "--results", str(results)]  # fmt: skip
        proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env)
        err_lines: list[bytes] = []
        reader = _drain(proc, err_lines)
        hung, last = False, None
        with open(status, "rb") as fh:
            page = mmap.mmap(fh.fileno(), STATUS.size, access=mmap.ACCESS_READ)
            while proc.poll() is None:
                time.sleep(0.2)
                now = STATUS.unpack_from(page, 0)
                # a hang: the same call seen twice (never one torn read), in it for too long
                if now == last and now[5] and time.monotonic() - now[3] > args.timeout:
                    hung = True
                    proc.kill()
                    break
                last = now
            proc.wait()
            reader.join()
            ti, case, made, _, t_until, in_call = STATUS.unpack_from(page, 0)
        for line in results.read_text().splitlines():
            doc = json.loads(line)
            calls[doc["target"]] += doc["calls"]
            for kind, msg, c, n in doc["findings"]:
                log.append({"target": doc["target"], "kind": kind, "message": msg, "case": c,
                            "count": n})  # fmt: skip
        if not hung and proc.returncode == 0:
            break
        name = names[ti]
        calls[name] += made + (1 if in_call else 0)
        if hung:
            msg = f"a call ran longer than {args.timeout} s"
            log.append({"target": name, "kind": "hang", "case": case, "count": 1, "message": msg})
        else:
            rc = proc.returncode
            how = f"signal {signal.Signals(-rc).name}" if rc < 0 else f"exit status {rc}"
            tail = b"".join(err_lines).decode(errors="replace").strip().splitlines()[-3:]
            log.append({"target": name, "kind": "abort", "case": case, "count": 1,
                        "message": f"{how}: {' | '.join(tail)}"[:300]})  # fmt: skip
            if not in_call:  # died outside a call: the harness itself is broken
                raise RuntimeError(f"the worker died outside a call: {how}: {tail}")
        first, start, until = ti, case + 1, t_until
    return calls, log


def _drain(proc: subprocess.Popen[bytes], into: list[bytes]) -> threading.Thread:
    """Read the worker's stderr in a thread (the last 64 KiB kept) so it never blocks."""

    def read() -> None:
        assert proc.stderr is not None
        for line in proc.stderr:
            into.append(line)
            if len(into) > 200:
                del into[:100]

    th = threading.Thread(target=read, daemon=True)
    th.start()
    return th


def replay(spec: str, seed: int) -> int:
    name, case = spec.rsplit(":", 1)
    with tempfile.TemporaryDirectory(prefix="lfd-fuzz-") as tmp:
        f = Fixtures(Path(tmp))
        t0 = time.perf_counter()
        found = run(name, build(f, name, seed, int(case)))
    print(json.dumps({"target": name, "case": int(case), "finding": found,
                      "seconds": round(time.perf_counter() - t0, 3)}))  # fmt: skip
    return 1 if found else 0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=300, help="cases per target (300)")
    parser.add_argument("--seconds", type=float, default=0.0, help="time budget per target")
    parser.add_argument("--timeout", type=float, default=30.0, help="a hang: one call > this")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--targets", default="", help="comma-separated (default: all)")
    parser.add_argument("--replay", help="TARGET:CASE: run one case in this process")
    parser.add_argument("--check-coverage", action="store_true")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--first", type=int, default=0, help=argparse.SUPPRESS)
    parser.add_argument("--start", type=int, default=0, help=argparse.SUPPRESS)
    parser.add_argument("--status", help=argparse.SUPPRESS)
    parser.add_argument("--results", help=argparse.SUPPRESS)
    parser.add_argument("--until", type=float, default=1e300, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        return worker(args)
    if args.replay:
        return replay(args.replay, args.seed)
    if args.check_coverage:
        missing = missing_targets()
        print(json.dumps({"missing": missing, "targets": len(TARGETS)}))
        return 1 if missing else 0
    names = [n for n in args.targets.split(",") if n] or list(TARGETS)
    unknown = [n for n in names if n not in TARGETS]
    if unknown:
        parser.error(f"unknown targets {unknown}; known: {', '.join(TARGETS)}")
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="lfd-fuzz-") as tmp:
        try:
            calls, log = supervise(names, args, Path(tmp))
        except Exception:  # a failure of the harness itself
            traceback.print_exc()
            return 3
    seconds = time.perf_counter() - t0
    kinds = {k: sum(e["count"] for e in log if e["kind"] == k)
             for k in ("abort", "hang", "panic", "exception", "bad result")}  # fmt: skip
    doc = {
        "calls": calls,
        "total": sum(calls.values()),
        "seconds": round(seconds, 1),
        "rate": round(sum(calls.values()) / max(seconds, 1e-9)),
        "seed": args.seed,
        "counts": kinds,
        "findings": log,
    }
    print(json.dumps(doc))
    return 1 if log else 0


if __name__ == "__main__":
    with contextlib.suppress(BrokenPipeError):
        sys.exit(main())
