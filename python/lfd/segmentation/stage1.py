"""Stage 1 (paper Sec. III-B.3): over-segment a demonstration at threshold crossings.

Boundaries are put where the fingertip distance crosses ``d_i + gamma``, the hand speed crosses
``v_th`` or the TCP vertical velocity changes sign (Table I thresholds, per sample, from
:func:`lfd.features.compute_features`). A hysteresis band per criterion and a minimum section
length suppress chatter. The crossing logic runs in the engine
(:func:`lfd._hmmseg.stage1_boundaries`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from .. import _hmmseg

FEATURE_COLUMNS: dict[str, int] = {
    "fingertip_distance": 0,
    "tcp_rise_fall": 1,
    "hand_velocity": 9,
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
    """

    opening_hysteresis: float = 0.005
    velocity_hysteresis: float = 0.02
    rise_hysteresis: float = 0.02
    min_section_s: float = 0.2


def section_boundaries(
    values: npt.ArrayLike,
    thresholds: npt.ArrayLike,
    dt: float,
    params: Stage1Params | None = None,
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
    """
    p = params or Stage1Params()
    v = np.ascontiguousarray(values, dtype=np.float64)
    t = np.ascontiguousarray(thresholds, dtype=np.float64)
    cols = [FEATURE_COLUMNS[k] for k in ("fingertip_distance", "hand_velocity", "tcp_rise_fall")]
    hyst = [p.opening_hysteresis, p.velocity_hysteresis, p.rise_hysteresis]
    min_len = max(1, round(p.min_section_s / dt)) if dt > 0 else 1
    return np.asarray(_hmmseg.stage1_boundaries(v, t, cols, hyst, min_len), dtype=np.int64)
