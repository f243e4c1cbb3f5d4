"""How the simulated demonstrator varies from one demonstration to the next.

Every field left as ``None`` is drawn per demonstration from its default distribution (below),
which depends on the demonstrator's ``style``; a value given by the user is used as is. All
draws happen in a fixed order whatever the user fixes, so fixing one parameter does not change
the others for the same seed.

Two styles (docs/skills.md):

- ``careful`` (default): the paper's demonstrator — deliberate, with pauses and hesitations,
  pinch grasps, sensed like the paper's RGB-D setup (keypoints at ~5 Hz, 2-3 mm noise, tag
  dropouts and occlusions).
- ``natural``: like people in motion capture — fast grasps and releases, no hesitation, several
  grasp types, a hand that lingers at the object between cycles, cubes of 5-9 cm, and mocap-like
  sensing (1-2 mm keypoint noise, almost no outliers or dropouts; keypoints at 30 Hz is the
  simulator's default rate for this style).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields, replace
from typing import Any, Literal, get_args

import numpy as np

from ..errors import UsageError

Style = Literal["careful", "natural"]
STYLES: tuple[str, ...] = get_args(Style)
"""The demonstrator styles."""

_FIXED: dict[str, dict[str, float]] = {
    "careful": {"outlier_rate": 0.03, "hand_miss": 0.02, "occlusion": 0.15, "object_noise_mm": 0.8},
    "natural": {"outlier_rate": 0.005, "hand_miss": 0.0, "occlusion": 0.0, "object_noise_mm": 0.5},
}
"""Per-style defaults of the fields that are not drawn."""


@dataclass(frozen=True)
class Variability:
    """Parameters of human variability and sensor imperfection.

    Attributes
    ----------
    style : {"careful", "natural"}
        The demonstrator (see the module docstring); it sets the default of every field left
        as ``None``: ``careful`` values first, ``natural`` ones in brackets.
    speed : float or None
        Overall speed factor (durations are divided by it). Default U(0.8, 1.25) per demo [U(0.85, 1.2)].
    speed_jitter : float
        Std of the log of a per-skill speed factor (default 0.12, i.e. about +-12 %).
    hand_scale : float or None
        Hand size factor (1 = adult hand, palm 9.5 cm). Default U(0.9, 1.1) [same].
    noise_mm : float or None
        Std of the gaussian keypoint noise in the image plane (1.5x along the viewing ray), mm.
        Default U(2, 3) [U(1, 2)].
    outlier_rate : float or None
        Fraction of hand frames with 1-3 keypoints off by 1-3 cm (default 0.03 [0.005]).
    hand_miss : float or None
        Fraction of hand-pose estimates that fail (the frame has no hand sample; default 0.02
        [0]).
    dropout : float or None
        Fraction of object samples missing, in bursts of ~0.2 s (mean). Default U(0.01, 0.03) [U(0, 0.005)].
    occlusion : float or None
        Extra probability that a tag is not detected while the hand is right above its object
        (default 0.15 [0]).
    tremor_mm : float or None
        RMS amplitude of physiological tremor (6-10 Hz) per axis, mm. Default U(0.3, 1.0) [same].
    detour : float or None
        Scale of path detours: the mid-path offset is ``detour * U(0.02, 0.12) * path length``
        in a random horizontal direction. 0 = straight lines. Default U(0.5, 1.5) [U(0.3, 1)].
    pauses : float or None
        Probability of a short pause (0.15-0.6 s) at the end of a skill and of a hesitation
        before contact inside Pick up / Place / Stack / Push. Default U(0.15, 0.5) [0].
    approach_deg : float
        Maximum deviation of the approach azimuth / hand yaw from the natural forearm direction
        (default 35 deg).
    object_noise_mm : float or None
        Std of the tag position noise (2x along the viewing ray), mm; the orientation gets
        ``object_noise_mm * 0.5`` degrees (default 0.8 [0.5]).
    finger_drift_deg : float
        Amplitude of slow (0.1-0.6 Hz) flexion drift of the middle, ring and little finger
        (default 4 deg).
    """

    style: Style = "careful"
    speed: float | None = None
    speed_jitter: float = 0.12
    hand_scale: float | None = None
    noise_mm: float | None = None
    outlier_rate: float | None = None
    hand_miss: float | None = None
    dropout: float | None = None
    occlusion: float | None = None
    tremor_mm: float | None = None
    detour: float | None = None
    pauses: float | None = None
    approach_deg: float = 35.0
    object_noise_mm: float | None = None
    finger_drift_deg: float = 4.0

    @classmethod
    def noise_free(cls, **overrides: Any) -> Variability:
        """Human motion variability only: no sensor noise, outliers, dropouts or tremor."""
        base: dict[str, Any] = {
            "noise_mm": 0.0,
            "outlier_rate": 0.0,
            "hand_miss": 0.0,
            "dropout": 0.0,
            "occlusion": 0.0,
            "tremor_mm": 0.0,
            "object_noise_mm": 0.0,
        }
        base.update(overrides)
        return cls(**base)

    def resolve(self, rng: np.random.Generator) -> Variability:
        """A copy with every ``None`` replaced by a draw from its default distribution."""
        self.validate()
        if self.style == "natural":
            drawn = {
                "speed": rng.uniform(0.85, 1.2),
                "hand_scale": rng.uniform(0.9, 1.1),
                "noise_mm": rng.uniform(1.0, 2.0),
                "dropout": rng.uniform(0.0, 0.005),
                "tremor_mm": rng.uniform(0.3, 1.0),
                "detour": rng.uniform(0.3, 1.0),
                "pauses": 0.0,
            }
        else:
            drawn = self._careful_draws(rng)
        drawn.update(_FIXED[self.style])
        values = {k: (drawn[k] if getattr(self, k) is None else getattr(self, k)) for k in drawn}
        resolved: dict[str, Any] = {k: float(v) for k, v in values.items()}
        out = replace(self, **resolved)
        out.validate()
        return out

    @staticmethod
    def _careful_draws(rng: np.random.Generator) -> dict[str, float]:
        return {
            "speed": rng.uniform(0.8, 1.25),
            "hand_scale": rng.uniform(0.9, 1.1),
            "noise_mm": rng.uniform(2.0, 3.0),
            "dropout": rng.uniform(0.01, 0.03),
            "tremor_mm": rng.uniform(0.3, 1.0),
            "detour": rng.uniform(0.5, 1.5),
            "pauses": rng.uniform(0.15, 0.5),
        }

    def validate(self) -> None:
        """Raise :class:`~lfd.errors.UsageError` (a ``ValueError``) for values outside their
        meaningful range."""
        if self.style not in STYLES:
            raise UsageError(f"style must be one of {', '.join(STYLES)}, got {self.style!r}")
        for f in fields(self):
            v = getattr(self, f.name)
            if v is None or f.name == "style":
                continue
            if not np.isfinite(v) or v < 0:
                raise UsageError(f"variability {f.name} must be a finite number >= 0, got {v}")
        if self.speed is not None and not 0.2 <= self.speed <= 5.0:
            raise UsageError(f"speed must be in [0.2, 5], got {self.speed}")
        if self.hand_scale is not None and not 0.6 <= self.hand_scale <= 1.5:
            raise UsageError(f"hand scale must be in [0.6, 1.5], got {self.hand_scale}")
        if not self.approach_deg <= 180.0:
            raise UsageError(f"approach_deg must be in [0, 180], got {self.approach_deg}")
        for name in ("dropout", "pauses", "outlier_rate", "occlusion", "hand_miss"):
            v = getattr(self, name)
            if v is not None and v > 0.9:
                raise UsageError(f"{name} must be a probability <= 0.9, got {v}")

    def as_dict(self) -> dict[str, str | float | None]:
        """Plain dict (for metadata)."""
        return {k: (v if k == "style" or v is None else float(v)) for k, v in asdict(self).items()}
