"""Stage 1 (paper Sec. III-B.3): over-segment a demonstration at threshold crossings.

Boundaries are put where the fingertip distance crosses ``d_i + gamma``, the hand speed crosses
``v_th`` or the TCP vertical velocity changes sign (Table I thresholds, per sample, from
:func:`lfd.features.compute_features`), and — beyond the paper, with ``object_criteria`` — where
any object leaves or regains its resting height (``+ gamma``) or starts or stops moving
(``v_th``): lift-off and set-down are skill boundaries the hand signals can miss when a real
hand lingers at the cube between fast cycles. A hysteresis band per criterion and a minimum section
length suppress chatter. The crossing logic runs in the engine
(:func:`lfd._hmmseg.stage1_boundaries`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from .. import _hmmseg
from ..rules import Flag, Number, Rule, check_fields

FEATURE_COLUMNS: dict[str, int] = {
    name: _hmmseg.FEATURE_NAMES.index(name)
    for name in ("fingertip_distance", "tcp_rise_fall", "hand_velocity")
}
"""Columns of the feature matrix that stage 1 watches."""


@dataclass(frozen=True)
class Stage1Params:
    """Hysteresis half-widths and the minimum section length.

    Attributes
    ----------
    opening_hysteresis : float
        Fingertip distance band, metres.
    velocity_hysteresis : float
        Hand speed band, m/s.
    rise_hysteresis : float
        TCP vertical velocity band around 0, m/s.
    min_section_s : float
        Minimum section length, seconds.
    object_criteria : bool
        Also cut where each object's own height and speed cross their thresholds.
    height_hysteresis : float
        Object height band, metres.
    """

    opening_hysteresis: float = 0.005
    velocity_hysteresis: float = 0.02
    rise_hysteresis: float = 0.02
    min_section_s: float = 0.1
    object_criteria: bool = True
    height_hysteresis: float = 0.005

    def __post_init__(self) -> None:
        check_fields(self, STAGE1_RULES, "stage1.")


STAGE1_RULES: dict[str, Rule] = {
    "opening_hysteresis": Number(0.0, 1.0, "m"),
    "velocity_hysteresis": Number(0.0, 10.0, "m/s"),
    "rise_hysteresis": Number(0.0, 10.0, "m/s"),
    "min_section_s": Number(0.0, 3600.0, "s"),
    "object_criteria": Flag(),
    "height_hysteresis": Number(0.0, 1.0, "m"),
}
"""What each :class:`Stage1Params` field holds (:mod:`lfd.rules`; docs/method-files.md)."""


OBJECT_COLUMNS: dict[str, int] = {"object_height": 4, "object_velocity": 8}
"""Columns of a per-object feature matrix that stage 1 watches with ``object_criteria``."""


def section_boundaries(
    values: npt.ArrayLike,
    thresholds: npt.ArrayLike,
    dt: float,
    params: Stage1Params | None = None,
    *,
    objects: Sequence[tuple[npt.ArrayLike, npt.ArrayLike]] = (),
) -> np.ndarray:
    """Section boundaries ``[0, b_1, ..., n]`` (int64 sample indices).

    Parameters
    ----------
    values, thresholds : array, shape (n, 10)
        Feature values and Table I thresholds (``lfd.features`` column order).
    dt : float
        Sample period in seconds.
    params : Stage1Params, optional
        Hysteresis and minimum length; defaults if omitted.
    objects : sequence of (values, thresholds)
        The feature matrices with each object as the target (``compute_features(traj,
        target=o)``), watched for lift-off, set-down and motion when ``object_criteria`` is on.
    """
    p = params or Stage1Params()
    v = np.ascontiguousarray(values, dtype=np.float64)
    t = np.ascontiguousarray(thresholds, dtype=np.float64)
    cols, hyst = criteria(p, len(objects), v.shape[1])
    if p.object_criteria and objects:
        vs, ts = [v], [t]
        for ov, ot in objects:
            vs.append(np.asarray(ov, dtype=np.float64)[:, list(OBJECT_COLUMNS.values())])
            ts.append(np.asarray(ot, dtype=np.float64)[:, list(OBJECT_COLUMNS.values())])
        v = np.ascontiguousarray(np.hstack(vs))
        t = np.ascontiguousarray(np.hstack(ts))
    return np.asarray(
        _hmmseg.stage1_boundaries(v, t, cols, hyst, min_section(p, dt)), dtype=np.int64
    )


def min_section(params: Stage1Params, dt: float) -> int:
    """The minimum section length in samples."""
    return max(1, round(params.min_section_s / dt)) if dt > 0 else 1


def criteria(params: Stage1Params, n_objects: int, n_columns: int) -> tuple[list[int], list[float]]:
    """The watched columns and their hysteresis in a stage-1 row: the hand feature row
    (``n_columns`` wide) followed, with ``object_criteria``, by the :data:`OBJECT_COLUMNS` of
    every object (what :func:`section_boundaries` stacks)."""
    p = params
    cols = [FEATURE_COLUMNS[k] for k in ("fingertip_distance", "hand_velocity", "tcp_rise_fall")]
    hyst = [p.opening_hysteresis, p.velocity_hysteresis, p.rise_hysteresis]
    if p.object_criteria:
        for o in range(n_objects):
            base = n_columns + len(OBJECT_COLUMNS) * o
            cols += [base, base + 1]
            hyst += [p.height_hysteresis, p.velocity_hysteresis]
    return cols, hyst
