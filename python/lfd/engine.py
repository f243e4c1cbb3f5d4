"""Continuous hidden Markov models — the skill templates of the segmentation stage.

:class:`GaussianHMM` wraps the Rust engine ``lfd._hmmseg.Hmm`` (Gaussian or Gaussian-mixture
emissions, diag or full covariances, ergodic or left-right topology). It checks and converts
inputs here, so mistakes get clear messages; the engine checks again and raises the
:mod:`lfd.errors` classes (:class:`~lfd.errors.EmptySequenceError`,
:class:`~lfd.errors.ShapeMismatchError`, :class:`~lfd.errors.NonFiniteError`, ...).

Observations are arrays of shape ``(n_samples, n_features)``, one row per time step; a 1-D
array is one feature. Parameters use hmmlearn's shapes and meaning, so a model can be moved
between the two libraries with :meth:`GaussianHMM.from_params`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, TypeVar, get_args

import numpy as np
import numpy.typing as npt

from . import _hmmseg
from ._hmmseg import CovarianceType, Topology
from .errors import InvalidParameterError, ShapeMismatchError

__all__ = ["FitMonitor", "GaussianHMM", "template_set"]

_Choice = TypeVar("_Choice", bound=str)

_COVARIANCES: tuple[CovarianceType, ...] = get_args(CovarianceType)
_TOPOLOGIES: tuple[Topology, ...] = get_args(Topology)


@dataclass(frozen=True)
class FitMonitor:
    """What the last :meth:`GaussianHMM.fit` / :meth:`GaussianHMM.refit` did.

    Attributes
    ----------
    history : tuple of float
        Total log-likelihood of the training sequences before each M-step.
    n_iter : int
        EM iterations performed.
    converged : bool
        Whether the improvement fell below ``tol`` before ``max_iter`` iterations.
    """

    history: tuple[float, ...]
    n_iter: int
    converged: bool


def template_set(doc: str) -> _hmmseg.TemplateSet:
    """The engine's skill-template set (one :class:`GaussianHMM` per skill and feature group,
    the feature ranges and parameters) of the JSON text ``doc`` (``TemplateSet.to_json``'s
    document); raises ``ModelFormatError`` if the engine cannot read it."""
    if not isinstance(doc, str):
        raise InvalidParameterError(f"template_set needs a str, got {type(doc).__name__}")
    return _hmmseg.TemplateSet.from_json(doc)


def _as_observations(x: npt.ArrayLike, name: str = "x") -> np.ndarray:
    """One sequence as a C-contiguous float64 array of shape ``(n_samples, n_features)``."""
    a = np.asarray(x)
    if a.dtype.kind not in "biuf":
        raise InvalidParameterError(
            f"{name} must be a numeric array, got dtype {a.dtype} (convert it to float first)"
        )
    if a.ndim == 1:
        a = a[:, np.newaxis]
    elif a.ndim != 2:
        raise ShapeMismatchError(
            f"{name} must have shape (n_samples, n_features) or (n_samples,), got {a.shape}"
        )
    return np.ascontiguousarray(a, dtype=np.float64)


def _as_sequences(xs: Sequence[npt.ArrayLike], name: str = "sequences") -> list[np.ndarray]:
    """A list of sequences; a bare array is refused because it would be ambiguous."""
    if isinstance(xs, np.ndarray) or not isinstance(xs, Sequence) or isinstance(xs, str):
        raise InvalidParameterError(
            f"{name} must be a list of arrays (one per sequence), got {type(xs).__name__}"
        )
    return [_as_observations(x, f"{name}[{i}]") for i, x in enumerate(xs)]


def _as_float_array(a: npt.ArrayLike, name: str, ndim: int) -> np.ndarray:
    arr = np.asarray(a)
    if arr.dtype.kind not in "biuf":
        raise InvalidParameterError(f"{name} must be numeric, got dtype {arr.dtype}")
    if arr.ndim != ndim:
        raise ShapeMismatchError(f"{name} must be {ndim}-D, got shape {arr.shape}")
    return np.ascontiguousarray(arr, dtype=np.float64)


def _check_int(value: Any, name: str, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < minimum:
        raise InvalidParameterError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


def _check_choice(value: Any, name: str, choices: tuple[_Choice, ...]) -> _Choice:
    for choice in choices:
        if isinstance(value, str) and value == choice:
            return choice
    raise InvalidParameterError(f"{name} must be one of {choices}, got {value!r}")


class GaussianHMM:
    """HMM with Gaussian (``n_mix=1``) or Gaussian-mixture emissions.

    Parameters
    ----------
    n_states : int
        Number of hidden states.
    n_mix : int, default 1
        Gaussian components per state.
    covariance : {"diag", "full"}, default "diag"
        Covariance shape of every component.
    topology : {"left-right", "ergodic"}, default "left-right"
        Left-right: start in state 0, only ``i -> i`` and ``i -> i + 1`` (the other
        transitions stay exactly zero through training). Ergodic: all transitions.
    seed : int, default 0
        Seed of the initialisation; the same seed and data give the same model, bit for bit.
    max_iter : int, default 100
        Maximum number of EM iterations.
    tol : float, default 1e-4
        Stop when the total log-likelihood improves by less than this.
    covariance_floor : float, default 1e-3
        Lower bound on every covariance eigenvalue (diag: every variance).

    Examples
    --------
    >>> import numpy as np
    >>> from lfd.engine import GaussianHMM
    >>> rng = np.random.default_rng(0)
    >>> demos = [np.r_[rng.normal(0, 0.1, 30), rng.normal(1, 0.1, 30)] for _ in range(5)]
    >>> model = GaussianHMM(2).fit(demos)
    >>> model.means_.round(1).ravel().tolist()
    [0.0, 1.0]
    """

    def __init__(
        self,
        n_states: int,
        *,
        n_mix: int = 1,
        covariance: CovarianceType = "diag",
        topology: Topology = "left-right",
        seed: int = 0,
        max_iter: int = 100,
        tol: float = 1e-4,
        covariance_floor: float = 1e-3,
    ) -> None:
        self.n_states = _check_int(n_states, "n_states", 1)
        self.n_mix = _check_int(n_mix, "n_mix", 1)
        self.covariance = _check_choice(covariance, "covariance", _COVARIANCES)
        self.topology = _check_choice(topology, "topology", _TOPOLOGIES)
        self.seed = _check_int(seed, "seed", 0)
        self.max_iter = _check_int(max_iter, "max_iter", 0)
        self.tol = float(tol)
        if np.isnan(self.tol):
            raise InvalidParameterError("tol must be a number, got nan")
        self.covariance_floor = float(covariance_floor)
        if not (np.isfinite(self.covariance_floor) and self.covariance_floor > 0):
            raise InvalidParameterError(
                f"covariance_floor must be finite and > 0, got {covariance_floor!r}"
            )
        self._model: _hmmseg.Hmm | None = None
        self.monitor_: FitMonitor | None = None

    # --- construction ------------------------------------------------------------------
    @classmethod
    def _wrap(cls, model: _hmmseg.Hmm, **options: Any) -> GaussianHMM:
        self = cls(model.n_states, n_mix=model.n_mix, covariance=model.covariance, **options)
        self._model = model
        return self

    @classmethod
    def from_params(
        cls,
        startprob: npt.ArrayLike,
        transmat: npt.ArrayLike,
        means: npt.ArrayLike,
        covars: npt.ArrayLike,
        *,
        weights: npt.ArrayLike | None = None,
        covariance: CovarianceType = "diag",
        **options: Any,
    ) -> GaussianHMM:
        """Build a model from parameters in hmmlearn's shapes.

        Parameters
        ----------
        startprob : array, shape (n_states,)
        transmat : array, shape (n_states, n_states)
            ``transmat[i, j] = P(j | i)``; every row sums to 1.
        means : array, shape (n_states, n_features), or (n_states, n_mix, n_features) with weights
        covars : array
            Without ``weights`` (GaussianHMM): diag ``(n_states, n_features)``, full
            ``(n_states, n_features, n_features)``. With ``weights`` (GMMHMM): diag
            ``(n_states, n_mix, n_features)``, full ``(n_states, n_mix, n_features, n_features)``.
        weights : array, shape (n_states, n_mix), optional
            Mixture weights; omit for single Gaussians.
        covariance : {"diag", "full"}
        **options
            Training options for later :meth:`fit` / :meth:`refit` calls (``seed``,
            ``max_iter``, ``tol``, ``covariance_floor``, ``topology``).

        Raises
        ------
        ShapeMismatchError, NotStochasticError, NotPositiveDefiniteError, NonFiniteError
        """
        covariance = _check_choice(covariance, "covariance", _COVARIANCES)
        full = covariance == "full"
        start = _as_float_array(startprob, "startprob", 1)
        trans = _as_float_array(transmat, "transmat", 2)
        if weights is None:
            mu = _as_float_array(means, "means", 2)[:, np.newaxis, :]
            cov = _as_float_array(covars, "covars", 3 if full else 2)[:, np.newaxis]
            w = np.ones((mu.shape[0], 1))
        else:
            w = _as_float_array(weights, "weights", 2)
            mu = _as_float_array(means, "means", 3)
            cov = _as_float_array(covars, "covars", 4 if full else 3)
        model = _hmmseg.Hmm.from_params(
            start,
            trans,
            np.ascontiguousarray(w),
            np.ascontiguousarray(mu),
            np.ascontiguousarray(cov),
            covariance=covariance,
        )
        return cls._wrap(model, **options)

    @classmethod
    def from_json(cls, text: str, **options: Any) -> GaussianHMM:
        """Read a model written by :meth:`to_json` (raises ``ModelFormatError`` if unreadable)."""
        if not isinstance(text, str):
            raise InvalidParameterError(f"from_json needs a str, got {type(text).__name__}")
        return cls._wrap(_hmmseg.Hmm.from_json(text), **options)

    def to_json(self) -> str:
        """The model as JSON (with a ``format_version``); :meth:`from_json` restores it exactly."""
        return self._fitted().to_json()

    # --- training ------------------------------------------------------------------------
    def fit(self, sequences: Sequence[npt.ArrayLike]) -> GaussianHMM:
        """Train on several sequences (each ``(n_samples, n_features)``, lengths may differ).

        Initialisation is seeded k-means (ergodic) or a uniform segmentation of each sequence
        (left-right), followed by Baum-Welch. Returns ``self``.
        """
        xs = _as_sequences(sequences)
        model, history, n_iter, converged = _hmmseg.Hmm.fit(
            xs,
            n_states=self.n_states,
            n_mix=self.n_mix,
            covariance=self.covariance,
            topology=self.topology,
            seed=self.seed,
            max_iter=self.max_iter,
            tol=self.tol,
            covariance_floor=self.covariance_floor,
        )
        self._model = model
        self.monitor_ = FitMonitor(tuple(history), n_iter, converged)
        return self

    def refit(
        self, sequences: Sequence[npt.ArrayLike], n_iter: int, *, tol: float = -np.inf
    ) -> GaussianHMM:
        """Run ``n_iter`` Baum-Welch iterations from the current parameters (no re-init).

        With the default ``tol=-inf`` exactly ``n_iter`` iterations run (as hmmlearn does with
        ``init_params=""``). Returns ``self``.
        """
        xs = _as_sequences(sequences)
        n_iter = _check_int(n_iter, "n_iter", 0)
        model, history, done, converged = self._fitted().refit(
            xs, max_iter=n_iter, tol=float(tol), covariance_floor=self.covariance_floor
        )
        self._model = model
        self.monitor_ = FitMonitor(tuple(history), done, converged)
        return self

    # --- inference -----------------------------------------------------------------------
    def score(self, x: npt.ArrayLike) -> float:
        """Log-likelihood ``ln P(x | model)`` of one sequence (forward algorithm)."""
        return self._fitted().log_likelihood(_as_observations(x))

    def score_many(self, sequences: Sequence[npt.ArrayLike]) -> np.ndarray:
        """Log-likelihood of each sequence (computed in parallel), shape ``(n_sequences,)``."""
        return self._fitted().log_likelihood_many(_as_sequences(sequences))

    def prefix_scores(self, x: npt.ArrayLike) -> np.ndarray:
        """``out[t] = ln P(x[:t + 1])`` for every ``t`` in one pass, shape ``(n_samples,)``."""
        return self._fitted().prefix_log_likelihoods(_as_observations(x))

    def viterbi(self, x: npt.ArrayLike) -> tuple[float, np.ndarray]:
        """Most likely state path: ``(ln P(x, path), path)``, path int64 of shape ``(n_samples,)``."""
        return self._fitted().viterbi(_as_observations(x))

    def predict(self, x: npt.ArrayLike) -> np.ndarray:
        """The Viterbi state path, shape ``(n_samples,)``."""
        return self.viterbi(x)[1]

    def predict_proba(self, x: npt.ArrayLike) -> np.ndarray:
        """State posteriors ``P(s_t = j | x)``, shape ``(n_samples, n_states)``; rows sum to 1."""
        return self._fitted().posteriors(_as_observations(x))

    def sample(self, n_samples: int, *, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """Draw ``(x, states)``: observations ``(n_samples, n_features)`` and their states."""
        n = _check_int(n_samples, "n_samples", 1)
        return self._fitted().sample(n, seed=_check_int(seed, "seed", 0))

    # --- parameters (hmmlearn shapes) ---------------------------------------------------------
    def _fitted(self) -> _hmmseg.Hmm:
        if self._model is None:
            raise InvalidParameterError(
                "this GaussianHMM has no parameters yet: call fit(), or build it with "
                "GaussianHMM.from_params() / GaussianHMM.from_json()"
            )
        return self._model

    @property
    def n_features(self) -> int:
        """Dimension of one observation."""
        return self._fitted().n_features

    @property
    def startprob_(self) -> np.ndarray:
        """Start probabilities, shape ``(n_states,)``."""
        return self._fitted().startprob

    @property
    def transmat_(self) -> np.ndarray:
        """Transition matrix, shape ``(n_states, n_states)``."""
        return self._fitted().transmat

    @property
    def weights_(self) -> np.ndarray:
        """Mixture weights, shape ``(n_states, n_mix)``."""
        return self._fitted().weights

    @property
    def means_(self) -> np.ndarray:
        """Means: ``(n_states, n_features)`` if ``n_mix == 1``, else ``(n_states, n_mix, n_features)``."""
        means = self._fitted().means
        return means[:, 0] if self.n_mix == 1 else means

    @property
    def covars_(self) -> np.ndarray:
        """Covariances in hmmlearn's shape for ``covariance``.

        diag: ``(n_states, n_features)`` (``n_mix == 1``) or ``(n_states, n_mix, n_features)``;
        full: ``(n_states, n_features, n_features)`` or ``(n_states, n_mix, n_features, n_features)``.
        """
        covars = self._fitted().covars
        if self.covariance == "diag":
            covars = np.diagonal(covars, axis1=2, axis2=3).copy()
        return covars[:, 0] if self.n_mix == 1 else covars

    @property
    def history_(self) -> np.ndarray:
        """Log-likelihood before each M-step of the last fit/refit, shape ``(n_iter,)``."""
        return np.asarray(self.monitor_.history if self.monitor_ else (), dtype=np.float64)

    @property
    def converged_(self) -> bool:
        """Whether the last fit/refit converged (stopped by ``tol``)."""
        return bool(self.monitor_ and self.monitor_.converged)

    # --- Python protocol -----------------------------------------------------------------
    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        state["_model"] = None if self._model is None else self._model.to_json()
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        model = state.pop("_model")
        self.__dict__.update(state)
        self._model = None if model is None else _hmmseg.Hmm.from_json(model)

    def __repr__(self) -> str:
        fitted = "fitted" if self._model is not None else "not fitted"
        return (
            f"GaussianHMM(n_states={self.n_states}, n_mix={self.n_mix}, "
            f"covariance={self.covariance!r}, topology={self.topology!r}, {fitted})"
        )
