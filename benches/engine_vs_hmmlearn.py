"""Benchmark lfd's Rust HMM engine against hmmlearn 0.3.3, side by side in one process.

Run: ``python benches/engine_vs_hmmlearn.py`` (build the extension in release first:
``pip install -e .``). Both run single-threaded (``OMP_NUM_THREADS=1``, ``RAYON_NUM_THREADS=1``)
on the same parameters and data. The two are measured side by side: batches of ours and of
hmmlearn's calls alternate (ours, theirs, ours, ...), so both see the same machine load, and the
table shows the minimum time per call over the batches and hmmlearn / ours.
Times are process CPU time (``time.process_time``), which on a shared, loaded machine is far
more stable than wall time; with one thread each they equal wall time on an idle machine.
Pass ``--wall`` to use ``time.perf_counter`` instead. The DTW row lives in
``benches/dtw_vs_dtaidistance.py``.
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("RAYON_NUM_THREADS", "1")

import sys
import time
import warnings
from collections.abc import Callable

import numpy as np
from hmmlearn import hmm
from lfd.engine import GaussianHMM

CLOCK = time.perf_counter if "--wall" in sys.argv else time.process_time


def paired_time(
    ours: Callable[[], object],
    ref: Callable[[], object],
    *,
    budget: float = 2.0,
    repeats: int = 21,
) -> tuple[float, float]:
    """Seconds per call of ``ours`` and ``ref``, timed in alternating batches.

    Each batch lasts about ``budget / repeats / 2`` seconds; the result is the minimum over the
    ``repeats`` batches of each (the least disturbed by other work on the machine).
    """

    def batch_size(fn: Callable[[], object]) -> int:
        fn()
        start, calls = CLOCK(), 0
        while CLOCK() - start < budget / repeats / 8:
            fn()
            calls += 1
        return max(1, calls * 4)

    def timed(fn: Callable[[], object], calls: int) -> float:
        t0 = CLOCK()
        for _ in range(calls):
            fn()
        return (CLOCK() - t0) / calls

    n_ours, n_ref = batch_size(ours), batch_size(ref)
    t_ours, t_ref = [], []
    for _ in range(repeats):
        t_ours.append(timed(ours, n_ours))
        t_ref.append(timed(ref, n_ref))
    return min(t_ours), min(t_ref)


def fmt(seconds: float) -> str:
    if seconds < 1e-3:
        return f"{seconds * 1e6:8.1f} us"
    return f"{seconds * 1e3:8.2f} ms"


def left_right(n: int, m: int, f: int) -> dict[str, np.ndarray]:
    """Left-right parameters in hmmlearn's shapes (GMMHMM shapes when ``m > 1``)."""
    trans = np.zeros((n, n))
    for i in range(n - 1):
        trans[i, i], trans[i, i + 1] = 0.95, 0.05
    trans[-1, -1] = 1.0
    start = np.eye(n)[0]
    rng = np.random.default_rng(0)
    if m == 1:
        means = np.arange(n, dtype=float)[:, None] + 0.1 * rng.normal(size=(n, f))
        covars = 0.2 + 0.05 * rng.random((n, f))
        return {"startprob": start, "transmat": trans, "means": means, "covars": covars}
    means = np.arange(n, dtype=float)[:, None, None] + 0.3 * rng.normal(size=(n, m, f))
    covars = 0.2 + 0.05 * rng.random((n, m, f))
    weights = np.full((n, m), 1.0 / m)
    return {
        "startprob": start,
        "transmat": trans,
        "means": means,
        "covars": covars,
        "weights": weights,
    }


def theirs(p: dict[str, np.ndarray], **kw: object) -> hmm.GaussianHMM | hmm.GMMHMM:
    n = len(p["startprob"])
    if "weights" in p:
        model = hmm.GMMHMM(n, n_mix=p["weights"].shape[1], init_params="", **kw)
        model.weights_ = p["weights"]
    else:
        model = hmm.GaussianHMM(n, init_params="", **kw)
    model.startprob_ = p["startprob"]
    model.transmat_ = p["transmat"]
    model.means_ = p["means"]
    model.covars_ = p["covars"]
    return model


def main() -> None:
    rows: list[tuple[str, str, str, str]] = []

    def add(case: str, ours: float, ref: float) -> None:
        rows.append((case, fmt(ours), fmt(ref), f"{ref / ours:7.1f}x"))

    # 1. score, T=200, 5 states, 1-D diag Gaussian.
    p = left_right(5, 1, 1)
    ours = GaussianHMM.from_params(p["startprob"], p["transmat"], p["means"], p["covars"])
    ref = theirs(p)
    x = ours.sample(200, seed=1)[0]
    assert abs(ours.score(x) - ref.score(x)) <= 1e-9 * abs(ref.score(x))
    add(
        "score T=200, 5 states, 1-D diag", *paired_time(lambda: ours.score(x), lambda: ref.score(x))
    )

    # 2. score with 3-component GMM emissions (2-D diag).
    pg = left_right(5, 3, 2)
    ours_g = GaussianHMM.from_params(
        pg["startprob"], pg["transmat"], pg["means"], pg["covars"], weights=pg["weights"]
    )
    ref_g = theirs(pg)
    xg = ours_g.sample(200, seed=2)[0]
    assert abs(ours_g.score(xg) - ref_g.score(xg)) <= 1e-9 * abs(ref_g.score(xg))
    add(
        "score T=200, 5 states, GMM 3 mix 2-D diag",
        *paired_time(lambda: ours_g.score(xg), lambda: ref_g.score(xg)),
    )

    # 3. Baum-Welch, 9 sequences x 200, the same 10 iterations from the same parameters.
    xs = [ours.sample(200, seed=10 + i)[0] for i in range(9)]
    cat, lengths = np.concatenate(xs), [len(s) for s in xs]
    n_iter = 10
    kw = dict(params="stmc", n_iter=n_iter, tol=-np.inf, covars_prior=0.0, means_weight=0.0)

    def fit_ours() -> GaussianHMM:
        m = GaussianHMM.from_params(
            p["startprob"], p["transmat"], p["means"], p["covars"], covariance_floor=1e-12
        )
        return m.refit(xs, n_iter)

    def fit_ref() -> hmm.GaussianHMM:
        m = theirs(p, **kw)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return m.fit(cat, lengths)

    t_ours, t_ref = paired_time(fit_ours, fit_ref, budget=4.0, repeats=7)
    ll_ours = float(fit_ours().score_many(xs).sum())
    ll_ref = float(fit_ref().score(cat, lengths))
    add(f"fit 9x200, 5 states, 1-D diag, {n_iter} EM iterations", t_ours, t_ref)

    # 4. The same with our own initialisation (left-right uniform segmentation) for reference.
    t_init = paired_time(
        lambda: GaussianHMM(5, max_iter=n_iter, tol=-np.inf).fit(xs), fit_ours, repeats=7
    )[0]
    rows.append((f"  (ours incl. init, {n_iter} iterations)", fmt(t_init), "", ""))
    rows.append(("dtw 200x200 (see benches/dtw_vs_dtaidistance.py)", "", "", ""))

    width = max(len(r[0]) for r in rows)
    print(f"{'case':<{width}}  {'ours':>11}  {'hmmlearn':>11}  {'ratio':>8}")
    for case, a, b, r in rows:
        print(f"{case:<{width}}  {a:>11}  {b:>11}  {r:>8}")
    print(f"final log-likelihood after fit: ours {ll_ours:.9f}, hmmlearn {ll_ref:.9f}")
    print(
        f"threads: OMP_NUM_THREADS={os.environ['OMP_NUM_THREADS']} "
        f"RAYON_NUM_THREADS={os.environ['RAYON_NUM_THREADS']}; clock {CLOCK.__name__}; "
        f"load average {tuple(round(v, 1) for v in os.getloadavg())}"
    )


if __name__ == "__main__":
    main()
