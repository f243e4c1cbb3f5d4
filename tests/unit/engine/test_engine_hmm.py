"""lfd.engine.GaussianHMM against hmmlearn 0.3.3 and a numpy EM, plus every error path."""

from __future__ import annotations

import json
import pickle
import warnings
from typing import Any

import numpy as np
import pytest
from lfd import errors
from lfd.engine import GaussianHMM
from scipy.special import logsumexp

hmm = pytest.importorskip("hmmlearn.hmm")


# --- random models ------------------------------------------------------------------------
def _stochastic(rng: np.random.Generator, *shape: int) -> np.ndarray:
    p = 0.05 + rng.random(shape)
    return p / p.sum(axis=-1, keepdims=True)


def _spd(rng: np.random.Generator, f: int) -> np.ndarray:
    a = rng.normal(size=(f, f))
    return a @ a.T / f + 0.3 * np.eye(f)


def _params(seed: int, n: int, f: int, *, m: int = 0, full: bool = False) -> dict:
    """hmmlearn-shaped parameters; ``m > 0`` gives a GMMHMM."""
    rng = np.random.default_rng(seed)
    lead = (n, m) if m else (n,)
    means = rng.normal(scale=2.0, size=(*lead, f))
    if full:
        covars = np.array([_spd(rng, f) for _ in range(int(np.prod(lead)))]).reshape(*lead, f, f)
    else:
        covars = 0.2 + rng.random((*lead, f))
    out = {
        "startprob": _stochastic(rng, n),
        "transmat": _stochastic(rng, n, n),
        "means": means,
        "covars": covars,
    }
    if m:
        out["weights"] = _stochastic(rng, n, m)
    return out


def _theirs(p: dict, full: bool, **kw: Any) -> Any:
    cov = "full" if full else "diag"
    n = len(p["startprob"])
    if "weights" in p:
        model = hmm.GMMHMM(
            n, n_mix=p["weights"].shape[1], covariance_type=cov, init_params="", **kw
        )
        model.weights_ = p["weights"]
    else:
        model = hmm.GaussianHMM(n, covariance_type=cov, init_params="", **kw)
    model.startprob_ = p["startprob"]
    model.transmat_ = p["transmat"]
    model.means_ = p["means"]
    model.covars_ = p["covars"]
    return model


def _ours(p: dict, full: bool, **options) -> GaussianHMM:
    return GaussianHMM.from_params(
        p["startprob"],
        p["transmat"],
        p["means"],
        p["covars"],
        weights=p.get("weights"),
        covariance="full" if full else "diag",
        **options,
    )


def _data(seed: int, f: int, lengths: tuple[int, ...]) -> list[np.ndarray]:
    rng = np.random.default_rng(seed + 1000)
    return [rng.normal(scale=2.0, size=(t, f)) for t in lengths]


CASES = [
    pytest.param(dict(n=5, f=1), False, id="diag-1d"),
    pytest.param(dict(n=4, f=3), False, id="diag-3d"),
    pytest.param(dict(n=3, f=2), True, id="full-2d"),
    pytest.param(dict(n=3, f=2, m=3), False, id="gmm-diag"),
    pytest.param(dict(n=2, f=3, m=2), True, id="gmm-full"),
]


# --- scoring parity -----------------------------------------------------------------------
@pytest.mark.parametrize(("shape", "full"), CASES)
def test_score_matches_hmmlearn(shape: dict, full: bool) -> None:
    for seed in range(3):
        p = _params(seed, **shape, full=full)
        ours, theirs = _ours(p, full), _theirs(p, full)
        for x in _data(seed, shape["f"], (1, 7, 120)):
            assert ours.score(x) == pytest.approx(theirs.score(x), rel=1e-9)
        xs = _data(seed + 1, shape["f"], (3, 40, 90))
        many = ours.score_many(xs)
        assert many.shape == (3,)
        np.testing.assert_allclose(many, [theirs.score(x) for x in xs], rtol=1e-9)


@pytest.mark.parametrize(("shape", "full"), CASES)
def test_viterbi_and_posteriors_match_hmmlearn(shape: dict, full: bool) -> None:
    p = _params(11, **shape, full=full)
    ours, theirs = _ours(p, full), _theirs(p, full)
    x = _data(11, shape["f"], (60,))[0]
    score, path = ours.viterbi(x)
    their_score, their_path = theirs.decode(x, algorithm="viterbi")
    assert score == pytest.approx(their_score, rel=1e-9)
    np.testing.assert_array_equal(path, their_path)
    assert path.dtype == np.int64
    post = ours.predict_proba(x)
    np.testing.assert_allclose(post, theirs.predict_proba(x), atol=1e-9)
    np.testing.assert_allclose(post.sum(axis=1), 1.0, atol=1e-12)


def test_left_right_score_matches_hmmlearn() -> None:
    rng = np.random.default_rng(4)
    n, f = 5, 2
    trans = np.zeros((n, n))
    for i in range(n - 1):
        trans[i, i] = 0.5 + 0.45 * rng.random()
        trans[i, i + 1] = 1.0 - trans[i, i]
    trans[-1, -1] = 1.0
    p = {"startprob": np.eye(n)[0], "transmat": trans}
    p["means"] = rng.normal(size=(n, f))
    p["covars"] = 0.3 + rng.random((n, f))
    ours, theirs = _ours(p, False), _theirs(p, False)
    for x in _data(4, f, (1, 30, 200)):
        assert ours.score(x) == pytest.approx(theirs.score(x), rel=1e-9)
        assert ours.prefix_scores(x)[-1] == pytest.approx(theirs.score(x), rel=1e-9)


def test_prefix_scores_equal_scoring_each_prefix() -> None:
    p = _params(3, n=4, f=2, m=2)
    ours = _ours(p, False)
    x = _data(3, 2, (50,))[0]
    prefix = ours.prefix_scores(x)
    assert prefix.shape == (50,)
    want = [ours.score(x[: t + 1]) for t in range(50)]
    np.testing.assert_allclose(prefix, want, rtol=1e-12)
    assert prefix[-1] == pytest.approx(ours.score(x), rel=1e-12)
    theirs = _theirs(p, False)
    assert prefix[9] == pytest.approx(theirs.score(x[:10]), rel=1e-9)


def test_one_dimensional_input_is_one_feature() -> None:
    p = _params(0, n=3, f=1)
    ours = _ours(p, False)
    x = np.linspace(-1, 1, 25)
    assert ours.score(x) == ours.score(x[:, None])
    assert ours.score(x.astype(np.float32)) == ours.score(x.astype(np.float32).astype(float))
    assert ours.score(np.arange(5)) == ours.score(np.arange(5.0))


# --- Baum-Welch parity --------------------------------------------------------------------
@pytest.mark.parametrize(("n", "f", "full"), [(4, 2, False), (3, 1, False), (3, 2, True)])
def test_baum_welch_matches_hmmlearn_with_neutral_priors(n: int, f: int, full: bool) -> None:
    p = _params(5, n=n, f=f, full=full)
    xs = _data(5, f, (40, 75, 60, 33))
    k = 6
    theirs = _theirs(
        p, full, params="stmc", n_iter=k, tol=-np.inf, covars_prior=0.0, means_weight=0.0
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        theirs.fit(np.concatenate(xs), [len(x) for x in xs])
    ours = _ours(p, full, covariance_floor=1e-12).refit(xs, k)
    assert ours.monitor_ is not None and ours.monitor_.n_iter == k
    np.testing.assert_allclose(ours.history_, theirs.monitor_.history, rtol=1e-9)
    np.testing.assert_allclose(ours.startprob_, theirs.startprob_, atol=1e-6)
    np.testing.assert_allclose(ours.transmat_, theirs.transmat_, atol=1e-6)
    np.testing.assert_allclose(ours.means_, theirs.means_, atol=1e-6)
    np.testing.assert_allclose(ours.covars_, theirs._covars_, atol=1e-6)


def _numpy_em_gmm_diag(p: dict, xs: list[np.ndarray], n_iter: int) -> dict:
    """Plain maximum-likelihood Baum-Welch for diag GMM emissions, in log space."""
    start, trans, w = p["startprob"].copy(), p["transmat"].copy(), p["weights"].copy()
    mu, var = p["means"].copy(), p["covars"].copy()
    history = []
    for _ in range(n_iter):
        n, m, f = mu.shape
        acc_start, acc_trans = np.zeros(n), np.zeros((n, n))
        post, s1, s2 = np.zeros((n, m)), np.zeros((n, m, f)), np.zeros((n, m, f))
        total = 0.0
        for x in xs:
            d = x[:, None, None, :] - mu[None]
            lc = np.log(w)[None] - 0.5 * (np.log(2 * np.pi * var)[None] + d**2 / var[None]).sum(-1)
            lb = logsumexp(lc, axis=2)
            t_len = len(x)
            la, lbe = np.zeros((t_len, n)), np.zeros((t_len, n))
            la[0] = np.log(start) + lb[0]
            for t in range(1, t_len):
                la[t] = logsumexp(la[t - 1][:, None] + np.log(trans), axis=0) + lb[t]
            for t in range(t_len - 2, -1, -1):
                lbe[t] = logsumexp(np.log(trans) + lb[t + 1] + lbe[t + 1], axis=1)
            ll = logsumexp(la[-1])
            total += ll
            gamma = np.exp(la + lbe - ll)
            acc_start += gamma[0]
            for t in range(t_len - 1):
                acc_trans += np.exp(la[t][:, None] + np.log(trans) + lb[t + 1] + lbe[t + 1] - ll)
            resp = gamma[:, :, None] * np.exp(lc - lb[:, :, None])
            post += resp.sum(0)
            s1 += np.einsum("tnm,tf->nmf", resp, x)
            s2 += np.einsum("tnm,tf->nmf", resp, x**2)
        history.append(total)
        start = acc_start / acc_start.sum()
        trans = acc_trans / acc_trans.sum(1, keepdims=True)
        w = post / post.sum(1, keepdims=True)
        mu = s1 / post[:, :, None]
        var = s2 / post[:, :, None] - mu**2
    return {"startprob": start, "transmat": trans, "weights": w, "means": mu, "covars": var,
            "history": history}  # fmt: skip


def test_gmm_baum_welch_matches_numpy_em() -> None:
    # hmmlearn's GMMHMM centres its covariance statistics on the previous means, which is
    # not the maximum-likelihood update, so the GMM reference is a direct numpy EM.
    p = _params(8, n=3, f=2, m=2)
    xs = _data(8, 2, (50, 35, 64))
    want = _numpy_em_gmm_diag(p, xs, 5)
    ours = _ours(p, False, covariance_floor=1e-12).refit(xs, 5)
    np.testing.assert_allclose(ours.history_, want["history"], rtol=1e-9)
    for name in ("startprob", "transmat", "weights", "means", "covars"):
        np.testing.assert_allclose(getattr(ours, f"{name}_"), want[name], atol=1e-6, err_msg=name)


# --- training behaviour -------------------------------------------------------------------
def _demos(seed: int, count: int = 6) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    levels = [(0.0, 0.1), (1.0, 0.15), (0.3, 0.1)]
    return [
        np.concatenate([rng.normal(mu, sd, rng.integers(25, 40)) for mu, sd in levels])
        for _ in range(count)
    ]


def test_fit_left_right_recovers_levels_and_keeps_zeros() -> None:
    demos = _demos(0)
    model = GaussianHMM(3, seed=4).fit(demos)
    assert model.n_features == 1
    np.testing.assert_allclose(model.means_[:, 0], [0.0, 1.0, 0.3], atol=0.05)
    assert model.covars_.shape == (3, 1)
    tri = np.triu(np.ones((3, 3)), 2) + np.tril(np.ones((3, 3)), -1)
    assert np.all(model.transmat_[tri == 1] == 0.0)
    np.testing.assert_array_equal(model.startprob_, [1.0, 0.0, 0.0])
    history = model.history_
    assert model.monitor_ is not None
    assert len(history) == model.monitor_.n_iter and model.converged_
    assert np.all(np.diff(history) >= -1e-8 * np.abs(history[1:]))
    path = model.predict(demos[0])
    assert path[0] == 0 and np.all(np.diff(path) >= 0)


def test_fit_is_deterministic_for_a_seed() -> None:
    demos = [np.c_[d, d**2] for d in _demos(1)]
    a = GaussianHMM(3, n_mix=2, covariance="full", topology="ergodic", seed=7).fit(demos)
    b = GaussianHMM(3, n_mix=2, covariance="full", topology="ergodic", seed=7).fit(demos)
    assert a.to_json() == b.to_json()
    assert a.means_.shape == (3, 2, 2) and a.covars_.shape == (3, 2, 2, 2)
    assert a.weights_.shape == (3, 2)


def test_json_and_pickle_round_trip_exactly() -> None:
    model = GaussianHMM(3, n_mix=2).fit([np.c_[d, -d] for d in _demos(2)])
    text = model.to_json()
    assert '"format_version":1' in text
    back = GaussianHMM.from_json(text)
    assert back.to_json() == text
    for name in ("startprob_", "transmat_", "weights_", "means_", "covars_"):
        np.testing.assert_array_equal(getattr(back, name), getattr(model, name))
    clone = pickle.loads(pickle.dumps(model))
    assert clone.to_json() == text
    assert clone.history_.tolist() == model.history_.tolist()
    x = np.c_[_demos(3)[0], -_demos(3)[0]]
    assert clone.score(x) == model.score(x)


# --- errors -------------------------------------------------------------------------------
@pytest.fixture
def model() -> GaussianHMM:
    return _ours(_params(0, n=3, f=2), False)


def test_bad_observations_raise_documented_errors(model: GaussianHMM) -> None:
    with pytest.raises(errors.EmptySequenceError):
        model.score(np.zeros((0, 2)))
    with pytest.raises(errors.ShapeMismatchError):
        model.score(np.zeros((5, 3)))
    with pytest.raises(errors.ShapeMismatchError):
        model.score(np.zeros((5, 2, 1)))
    with pytest.raises(errors.NonFiniteError, match="sample 1, feature 0"):
        model.score(np.array([[0.0, 0.0], [np.nan, 0.0]]))
    with pytest.raises(errors.NonFiniteError):
        model.prefix_scores(np.array([[np.inf, 0.0]]))
    with pytest.raises(errors.InvalidParameterError, match="numeric"):
        model.score(np.array([["a", "b"]]))
    with pytest.raises(errors.InvalidParameterError, match="list of arrays"):
        model.score_many(np.zeros((3, 2)))  # type: ignore[arg-type]
    with pytest.raises(errors.ShapeMismatchError):
        model.score_many([np.zeros((4, 2)), np.zeros((4, 1))])
    with pytest.raises(errors.EngineError):
        model.viterbi(np.zeros((0, 2)))
    with pytest.raises(errors.EngineError):
        model.predict_proba(np.full((3, 2), np.nan))
    # Every engine error is also a ValueError and an LfdError.
    with pytest.raises(ValueError):
        model.score(np.zeros((5, 3)))
    with pytest.raises(errors.LfdError):
        model.score(np.zeros((5, 3)))


def test_fit_errors() -> None:
    with pytest.raises(errors.InvalidParameterError, match="more states"):
        GaussianHMM(5).fit([np.zeros(3)])
    with pytest.raises(errors.EmptySequenceError):
        GaussianHMM(2).fit([])
    with pytest.raises(errors.EmptySequenceError):
        GaussianHMM(2).fit([np.zeros(5), np.zeros(0)])
    with pytest.raises(errors.ShapeMismatchError):
        GaussianHMM(2).fit([np.zeros((5, 2)), np.zeros((5, 3))])
    with pytest.raises(errors.NonFiniteError):
        GaussianHMM(2).fit([np.array([0.0, 1.0, np.inf, 2.0])])
    with pytest.raises(errors.InvalidParameterError, match="no parameters yet"):
        GaussianHMM(2).score(np.zeros(3))
    for bad in (
        dict(n_states=0),
        dict(n_states=2, n_mix=0),
        dict(n_states=2, covariance="tied"),
        dict(n_states=2, topology="ring"),
        dict(n_states=2, tol=float("nan")),
        dict(n_states=2, covariance_floor=0.0),
        dict(n_states=2.5),
        dict(n_states=True),
    ):
        with pytest.raises(errors.InvalidParameterError):
            GaussianHMM(**bad)


def test_from_params_errors() -> None:
    p = _params(0, n=2, f=2)
    ok = dict(startprob=p["startprob"], transmat=p["transmat"], means=p["means"])
    ok["covars"] = p["covars"]
    GaussianHMM.from_params(**ok)
    with pytest.raises(errors.NotStochasticError):
        GaussianHMM.from_params(**{**ok, "startprob": np.array([0.7, 0.7])})
    with pytest.raises(errors.NotStochasticError):
        GaussianHMM.from_params(**{**ok, "transmat": np.array([[0.5, 0.6], [0.5, 0.5]])})
    with pytest.raises(errors.NotStochasticError):
        GaussianHMM.from_params(**{**ok, "transmat": np.array([[1.5, -0.5], [0.5, 0.5]])})
    with pytest.raises(errors.NotPositiveDefiniteError):
        GaussianHMM.from_params(**{**ok, "covars": np.array([[1.0, 0.0], [1.0, 1.0]])})
    with pytest.raises(errors.NotPositiveDefiniteError):
        singular = np.array([[[1.0, 1.0], [1.0, 1.0]], [[1.0, 0.0], [0.0, 1.0]]])
        GaussianHMM.from_params(**{**ok, "covars": singular}, covariance="full")
    with pytest.raises(errors.NonFiniteError):
        GaussianHMM.from_params(**{**ok, "means": np.array([[0.0, np.nan], [0.0, 0.0]])})
    with pytest.raises(errors.ShapeMismatchError):
        GaussianHMM.from_params(**{**ok, "transmat": np.eye(3)})
    with pytest.raises(errors.ShapeMismatchError):
        GaussianHMM.from_params(**{**ok, "covars": np.ones((2, 3))})
    with pytest.raises(errors.ShapeMismatchError):
        GaussianHMM.from_params(**{**ok, "covars": np.ones((2, 2))}, covariance="full")
    with pytest.raises(errors.ShapeMismatchError):
        GaussianHMM.from_params(**ok, weights=np.ones((2, 1)))  # means must then be 3-D
    with pytest.raises(errors.InvalidParameterError):
        GaussianHMM.from_params(**ok, covariance="spherical")


def test_json_errors(model: GaussianHMM) -> None:
    text = model.to_json()
    with pytest.raises(errors.ModelFormatError):
        GaussianHMM.from_json("{not json")
    with pytest.raises(errors.ModelFormatError):
        GaussianHMM.from_json(text[: len(text) // 2])
    with pytest.raises(errors.ModelFormatError, match="format_version 7"):
        GaussianHMM.from_json(text.replace('"format_version":1', '"format_version":7'))
    with pytest.raises(errors.ModelFormatError):
        GaussianHMM.from_json(text.replace('"format_version":1,', ""))
    doc = json.loads(text)
    doc["startprob"][0] = 5.0
    with pytest.raises(errors.NotStochasticError):
        GaussianHMM.from_json(json.dumps(doc))
    doc = json.loads(text)
    doc["covars"][1][0][1][1] = -1.0
    with pytest.raises(errors.NotPositiveDefiniteError):
        GaussianHMM.from_json(json.dumps(doc))
    with pytest.raises(errors.InvalidParameterError):
        GaussianHMM.from_json(b"{}")  # type: ignore[arg-type]
