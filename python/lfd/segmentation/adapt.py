"""Adapt a trained template set to a user's own labelled recordings.

Training from scratch needs examples of every skill and forgets what the shipped templates
learned; adaptation starts from a base template set instead. For every skill x feature HMM of
the base with user examples, Baum-Welch starts from the base model's parameters (same states,
mixture components and transitions; :meth:`lfd.engine.GaussianHMM.refit`) and re-estimates them
on the user's segments, normalised with the base's ranges and, like training, warped by DTW onto
their medoid. ``prior`` pseudo-sequences sampled from the base model join the user's sequences (a
MAP-style prior: the base counts as that many examples, so a few user examples move the model
part of the way). Skills without user examples keep the base model; features and parameters
stay the base's.

The normalisation ranges are widened to cover the user's data (the base's percentiles of it),
so motion faster or higher than the base's demonstrations is not clipped to the range's end;
every base model is carried into the wider ranges exactly (an affine change of variables of its
Gaussian means and covariances) before it is re-estimated. Measured on natural-style recordings
with careful-only base templates (benches/segment_adapt.py): the user's hand speed, object
height and TCP rise were outside the base ranges in 10-20 % of the samples.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..dtw import align_to_reference, dtw_distance
from ..engine import GaussianHMM, template_set
from ..errors import EngineError
from .templates import FRAME_SYMMETRY, TCP_IN_OBJECT_XY, Templates, augment

DEFAULT_PRIOR = 8
"""Pseudo-sequences drawn from the base model per skill x feature (before the frame
augmentation, which multiplies the user's examples by ``frame_symmetry``)."""


MEDOID_SEQUENCES = 24
"""The alignment reference is the DTW medoid of at most this many distinct sequences (drawn
evenly), which bounds the quadratic cost of finding it."""


def _medoid(seqs: list[np.ndarray], band: int | None) -> int:
    """Index of the sequence with the least summed DTW distance to the others (duplicates,
    e.g. frame turns that leave a feature unchanged, counted once; see MEDOID_SEQUENCES)."""
    distinct = list(
        {x.tobytes() + bytes(str(x.shape), "ascii"): i for i, x in enumerate(seqs)}.values()
    )
    if len(distinct) > MEDOID_SEQUENCES:
        distinct = [distinct[int(k)] for k in np.linspace(0, len(distinct) - 1, MEDOID_SEQUENCES)]
    n = len(distinct)
    cost = np.zeros(n)
    for a in range(n):
        for b in range(a + 1, n):
            d = dtw_distance(seqs[distinct[a]], seqs[distinct[b]], band=band)
            cost[a] += d
            cost[b] += d
    return distinct[int(np.argmin(cost))]


def widen_ranges(doc: dict[str, Any], data: Sequence[np.ndarray]) -> dict[str, Any]:
    """The template document ``doc`` (engine JSON as a dict) with ranges that also span the
    raw user ``data`` (the base's range percentiles of it) and every model carried into them:
    ``x' = a x + b`` per column, means ``a m + b``, covariances ``a_i a_j C_ij``."""
    if not data:
        return doc
    lo, hi = np.asarray(doc["ranges"], dtype=np.float64).T
    p_lo, p_hi = doc["params"]["range_percentiles"]
    x = np.vstack(data)
    new_lo = np.minimum(lo, np.percentile(x, p_lo, axis=0))
    new_hi = np.maximum(hi, np.percentile(x, p_hi, axis=0))
    for c in TCP_IN_OBJECT_XY:  # the turned object frames keep these symmetric
        b = max(abs(new_lo[c]), abs(new_hi[c]))
        new_lo[c], new_hi[c] = -b, b
    width = np.where(hi > lo, hi - lo, 1.0)
    new_width = np.where(new_hi > new_lo, new_hi - new_lo, 1.0)
    a = width / new_width
    b = (lo - new_lo) / new_width
    out = json.loads(json.dumps(doc))
    out["ranges"] = np.column_stack([new_lo, new_hi]).tolist()
    for per_skill in out["models"]:
        for feature, model in zip(doc["features"], per_skill, strict=True):
            c0, c1 = int(feature["start"]), int(feature["end"])
            ac, bc = a[c0:c1], b[c0:c1]
            model["means"] = (np.asarray(model["means"]) * ac + bc).tolist()
            model["covars"] = (np.asarray(model["covars"]) * np.outer(ac, ac)).tolist()
    return out


def adapt_templates(
    base: Templates,
    examples: Sequence[tuple[str, np.ndarray]],
    *,
    names: Sequence[str] = (),
    base_name: str = "default",
    prior: int = DEFAULT_PRIOR,
    seed: int = 0,
) -> Templates:
    """The ``base`` templates re-estimated on labelled segments.

    Parameters
    ----------
    base : Templates
        The template set to start from (e.g. :meth:`Templates.default`).
    examples : sequence of (skill, array, shape (m, 10))
        Labelled segments, raw features (see :func:`~lfd.segmentation.templates.collect_examples`).
    names : sequence of str
        Names of the recordings the examples come from (recorded in the metadata).
    base_name : str
        How the metadata names the base (``"default"`` or its file).
    prior : int
        Sequences sampled from each base model that join the user's ones (0: plain
        re-estimation from the base's parameters).
    seed : int
        Seed of the sampling.

    Returns
    -------
    Templates
        With ``meta["adapted_from"]``, ``meta["adapted_on"]`` (the recordings) and
        ``meta["adapt_examples"]`` (user segments per skill).
    """
    if prior < 0:
        raise ValueError(f"prior must be >= 0, got {prior}")
    doc = json.loads(base.engine.to_json())
    params = doc["params"]
    fit, band = params["fit"], params["dtw_band"]
    symmetry = int(base.meta.get("frame_symmetry", FRAME_SYMMETRY))
    skills = base.skills
    # no layout copies: the refit starts from the base templates (which have them), and copies
    # would outweigh its prior samples
    data = augment(examples, skills, symmetry, layout_scales=())
    doc = widen_ranges(doc, [x for _, x in data])
    engine = template_set(json.dumps(doc))
    counts = {s: sum(1 for k, _ in examples if k == s) for s in skills}
    unchanged: list[str] = []
    for si, skill in enumerate(skills):
        mine = [engine.normalise(x) for k, x in data if k == si]
        if not mine:
            continue
        for fi, (fname, c0, c1) in enumerate(base.features):
            model = GaussianHMM.from_json(
                json.dumps(doc["models"][si][fi]), covariance_floor=float(fit["covariance_floor"])
            )
            seqs = [np.ascontiguousarray(x[:, c0:c1]) for x in mine]
            lengths = [len(x) for x in seqs]
            rng_seed = seed + 1000 * si + fi
            for j in range(prior):
                n = int(lengths[j % len(lengths)])
                x, _ = model.sample(n, seed=rng_seed * 1000 + j)
                seqs.append(np.clip(x, 0.0, 1.0))
            if params["align"] and len(seqs) > 1:
                ref = seqs[_medoid(seqs, band)]
                seqs = align_to_reference(ref, seqs, band=band)
            try:
                model.refit(seqs, int(fit["max_iter"]), tol=float(fit["tol"]))
            except EngineError:
                unchanged.append(f"{skill}/{fname}")
                continue
            doc["models"][si][fi] = json.loads(model.to_json())
        doc["n_examples"][si] += len(mine)
    meta: dict[str, Any] = {
        "adapted_from": base_name,
        "base_trained_from": base.meta.get("trained_from", []),
        "adapted_on": list(names),
        "adapt_examples": {s: n for s, n in counts.items() if n},
        "adapt_prior": prior,
        **base.preprocessing,
        "frame_symmetry": symmetry,
    }
    if unchanged:
        meta["adapt_kept_base"] = unchanged
    return Templates(template_set(json.dumps(doc)), meta=meta)
