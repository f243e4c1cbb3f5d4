"""The runs of stage-1 sections a segment may span, and the stage-2 score tables over them.

A skill segment lasts at most ``SegmentParams.max_segment_s``, so of the ``K (K + 1) / 2`` runs
of sections ``i..j`` only those of at most ``max_len`` samples are candidates (and every single
section, however long). The boundaries increase, so the admissible ends of start section ``i``
are the contiguous range ``i + 1 ..= last[i]``: tables store those runs start by start, ``(N,
...)`` with ``N ~ K x (sections per max_len)``, linear in the demonstration's length where a
dense ``(K, K + 1, ...)`` table grows with its square.

The band is defined once, by the engine (``hmmseg::segment::Band``, bound as
:class:`lfd._hmmseg.Band`): which runs are admissible and their row order. :class:`Band` here is
a numpy view of it, its arrays for indexing the tables.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import _hmmseg


@dataclass(frozen=True, eq=False)
class Band:
    """The admissible runs of sections over ``bounds`` (``[0, ..., n]``), ``max_len`` samples
    at most (0: no bound): the arrays of the engine's :class:`lfd._hmmseg.Band` (:meth:`of`).

    Attributes
    ----------
    bounds : array, shape (K + 1,)
        Stage-1 section boundaries (sample indices).
    max_len : int
        Longest run in samples (a single section is admissible however long; 0: no bound).
    last : array, shape (K,)
        The last admissible end section of the runs starting at each section.
    offsets : array, shape (K + 1,)
        Run ``r`` starts at section ``i`` for ``offsets[i] <= r < offsets[i + 1]``.
    start, end : array, shape (N,)
        Start and end section of every run, in the tables' order.
    """

    bounds: np.ndarray
    max_len: int
    last: np.ndarray
    offsets: np.ndarray
    start: np.ndarray
    end: np.ndarray

    @classmethod
    def of(cls, bounds: np.ndarray | list[int], max_len: int) -> Band:
        """The band of ``max_len`` samples over ``bounds``, as the engine defines it."""
        band = _hmmseg.Band(np.ascontiguousarray(bounds, dtype=np.int64), int(max_len))
        start, end = band.runs()
        return cls(band.boundaries, band.max_len, band.last_ends, band.offsets, start, end)

    @property
    def n_sections(self) -> int:
        """Number of sections ``K``."""
        return len(self.last)

    @property
    def n_runs(self) -> int:
        """Number of admissible runs ``N``."""
        return int(self.offsets[-1])

    def index(self, i: int, j: int) -> int | None:
        """Row of run ``i..j`` in a banded table; None outside the band."""
        if 0 <= i < j <= self.n_sections and j <= self.last[i]:
            return int(self.offsets[i]) + j - i - 1
        return None

    def ends(self, i: int) -> np.ndarray:
        """The admissible end sections of the runs starting at section ``i``."""
        return np.arange(i + 1, int(self.last[i]) + 1)

    def rows(self, i: int) -> slice:
        """The rows of the runs starting at section ``i`` (ends ``i + 1, i + 2, ...``)."""
        return slice(int(self.offsets[i]), int(self.offsets[i + 1]))

    def take(self, dense: np.ndarray) -> np.ndarray:
        """The band's entries ``(N, ...)`` of a dense ``(K, K + 1, ...)`` table."""
        k = self.n_sections
        if dense.shape[:2] != (k, k + 1):
            raise ValueError(f"a dense table over {k} sections has shape ({k}, {k + 1}, ...)")
        return np.asarray(dense[self.start, self.end])

    def dense(self, values: np.ndarray, fill: float | int = -np.inf) -> np.ndarray:
        """A dense ``(K, K + 1, ...)`` table of the banded ``values`` ``(N, ...)``, ``fill``
        outside the band (quadratic in ``K``: for small demonstrations and plots)."""
        k = self.n_sections
        out = np.full((k, k + 1, *values.shape[1:]), fill, dtype=values.dtype)
        out[self.start, self.end] = values
        return out


@dataclass(frozen=True, eq=False)
class StageTwoScores:
    """The stage-2 score table as the search sees it: per run of the band and skill the summed
    log-likelihood of the best-explaining target object, and that object.

    Attributes
    ----------
    band : Band
        The admissible runs.
    scores : array, shape (N, S)
        Summed log-likelihood (plus co-motion evidence) of each run under each skill, ``-inf``
        where excluded.
    target : array, shape (N, S), int
        Index of the target object that scores best.
    """

    band: Band
    scores: np.ndarray
    target: np.ndarray

    def table(self) -> np.ndarray:
        """The scores as a dense ``(K, K + 1, S)`` table, ``-inf`` outside the band."""
        return self.band.dense(self.scores)
