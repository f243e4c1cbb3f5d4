"""Skill templates: train them from labelled template recordings, save, load, ship.

A template set holds one left-right HMM with Gaussian-mixture emissions per skill x Table I
feature, trained by Baum-Welch (in the engine) on the labelled segments of template
demonstrations, after mapping every feature column to [0, 1] with ranges learned from the
templates and warping the sequences onto their medoid by DTW (paper Sec. III-B.2). The default
set ships in the package (``lfd/data/templates.json``) and was trained from
``recordings/templates`` with ``lfd templates train``.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Iterable, Mapping, Sequence
from functools import cache
from importlib import resources
from pathlib import Path
from typing import Any, Literal

import numpy as np

from .. import _hmmseg
from ..demo import Demonstration
from ..errors import DemonstrationError, EngineError, InvalidParameterError, ModelFormatError
from ..inputs import shown
from ..preprocessing.grasp import Aperture
from ..skills import SKILLS
from ..trajectory import Trajectory

FEATURE_GROUPS: tuple[tuple[str, int, int], ...] = _hmmseg.FEATURE_GROUPS
"""The eight features of Table I as ``(name, first column, end column)`` of the feature matrix
(defined in the engine, ``lfd._hmmseg.FEATURE_GROUPS``)."""

FEATURE_CUTOFF_HZ: float | Literal["auto"] = "auto"
"""Low-pass cut-off (Hz) of the hand keypoints the template features are computed from; stored
in the template file and used again at segmentation time. ``"auto"``: 2 Hz for a 5 Hz hand-pose
estimator, 6 Hz for 30 Hz motion capture (:func:`lfd.preprocessing.pipeline.auto_cutoff`)."""

LEGACY_FEATURE_CUTOFF_HZ = 2.0
"""The hand cut-off of template files that do not name one."""

OBJECT_CUTOFF_HZ = 10.0
"""Low-pass cut-off (Hz) of the object positions: tag and motion-capture poses are smooth
already; 10 Hz keeps a fast lift's height and a resting object's rest height
(docs/segmentation.md) and still quiets the object speed below ``v_th``."""

APERTURE: Aperture = "grasp"
"""What the templates' fingertip-distance feature measures (:mod:`lfd.preprocessing.grasp`)."""

MIN_KEYPOINT_CONFIDENCE = 0.0
"""``min_keypoint_confidence`` of :func:`lfd.preprocess` for training templates (stored in the
template file and used again at segmentation time). 0: the hand's confidence is ignored, as when
the shipped templates were trained; templates trained with a threshold record it."""

LEGACY_PREPROCESSING: dict[str, Any] = {
    "object_cutoff_hz": None,
    "aperture": "thumb_index",
    "min_keypoint_confidence": 0.0,
}
"""Preprocessing of template files that predate these settings (objects filtered like the hand,
Table I's thumb-index opening, the hand's confidence ignored)."""

FRAME_SYMMETRY = 4
"""Training examples are augmented with this many turns of the object frame about its vertical
axis (``k * 360 / FRAME_SYMMETRY`` degrees): the axes of a box are interchangeable for a skill
(a Push acts on whichever face lies in the push direction), but the nine template demonstrations
of a skill need not cover every face."""

TCP_IN_OBJECT_XY = (5, 6)
"""Columns of the horizontal TCP position in the object frame (turned by the augmentation)."""

OBJECT_DISTANCE = 3
"""Column of ``object_distance`` (the target's distance to the nearest other object)."""

LAYOUT_SCALES = (1.5, 2.0, 3.0)
"""Training examples of every skill but a Stack (:data:`RELATIONAL`) are also used with
``object_distance`` scaled by each of these factors: for them it says how the scene was laid
out, not what the hand does. The template demos' pushed boxes lie 0.13-0.25 m from the others;
without this a Push of a box 0.35-0.4 m away scores about 20 nats per sample below a Move with,
and is read live as Pick up -> Move with."""

RELATIONAL = frozenset({"stack"})
"""Skills whose ``object_distance`` is part of the skill (a Stack ends on another object): not
scaled by :data:`LAYOUT_SCALES`. (Leaving Place out as well made the Pick up template broader
than its mirror image, and a Pick up of the shipped exp1 read as a Place with the grammar
warning only.)"""

DEFAULT_TEMPLATES = "data/templates.json"
"""Package resource of the shipped templates."""
PAPER_TEMPLATES = "data/templates_paper.json"
"""Package resource of the templates of the paper's recipe (``lfd segment --paper``): careful
template demos only, hand and objects low-passed at 2 Hz, Table I's thumb-index opening,
covariance floor 1e-3 (lfd 0.1's shipped templates)."""

TemplateChoice = Literal["default", "paper"]
"""Names of the shipped template sets."""


class Templates:
    """A trained template set (wraps the engine's ``TemplateSet``).

    Use :meth:`load`, :meth:`default` or :func:`train_templates` to get one.
    """

    def __init__(self, engine: _hmmseg.TemplateSet, *, meta: dict[str, Any] | None = None):
        from .schema import check_block

        if not isinstance(engine, _hmmseg.TemplateSet):
            raise InvalidParameterError(
                f"Templates wraps the engine's TemplateSet, got {type(engine).__name__}"
            )
        self.engine = engine
        self.meta: dict[str, Any] = check_block(meta or {}, "lfd.", InvalidParameterError)

    @property
    def skills(self) -> list[str]:
        """Skill names in model order."""
        return list(self.engine.skills)

    @property
    def features(self) -> list[tuple[str, int, int]]:
        """Features as ``(name, first column, end column)``."""
        return list(self.engine.features)

    @property
    def ranges(self) -> np.ndarray:
        """Normalisation ranges, shape (n_columns, 2)."""
        return np.asarray(self.engine.ranges, dtype=np.float64)

    def to_json(self) -> str:
        """The templates as JSON text (the engine's format, plus an ``lfd`` metadata block)."""
        from .schema import FORMAT_VERSION

        doc = json.loads(self.engine.to_json())
        doc["lfd"] = {"format_version": FORMAT_VERSION, **self.meta}
        return json.dumps(doc)

    @classmethod
    def from_json(cls, text: str) -> Templates:
        """Read templates from JSON text; any problem (JSON, version, unknown skill, a field
        of the ``lfd`` block: :mod:`lfd.segmentation.schema`) raises ModelFormatError. The
        saved method's own entry is read by :meth:`lfd.Method.load`."""
        from ..inputs import parse_json
        from .schema import check_block

        doc = parse_json(text, "template file is not valid JSON", ModelFormatError)
        if not isinstance(doc, dict):
            raise ModelFormatError("template file must contain a JSON object")
        meta = check_block(doc.pop("lfd", {}))
        _check_skills(doc.get("skills", []))
        _check_features(doc.get("features", []))
        try:
            engine = _hmmseg.TemplateSet.from_json(json.dumps(doc))
        except ModelFormatError:
            raise
        except EngineError as err:  # what the engine refuses is the file's fault
            raise ModelFormatError(f"template file: {err}") from None
        return cls(engine, meta=meta)

    @classmethod
    def load(cls, path: str | Path) -> Templates:
        """Read a template file."""
        from ..inputs import read_text

        p = Path(path)
        try:
            text = read_text(
                p,
                error=ModelFormatError,
                not_text="is not a template file (binary, not UTF-8 JSON text); "
                "train one with `lfd templates train`",
            )
        except OSError as err:
            raise ModelFormatError(f"cannot read template file {p}: {err}") from None
        try:
            return cls.from_json(text)
        except ModelFormatError as err:
            raise ModelFormatError(f"{p}: {err}") from None

    def save(self, path: str | Path) -> None:
        """Write the templates as JSON (atomically: a failed write leaves no partial file)."""
        from ..outputs import atomic_write_text

        atomic_write_text(path, self.to_json())

    @classmethod
    def default(cls) -> Templates:
        """The templates shipped with the package."""
        return _shipped(DEFAULT_TEMPLATES)

    @classmethod
    def paper(cls) -> Templates:
        """The shipped templates of the paper's recipe (:data:`PAPER_TEMPLATES`)."""
        return _shipped(PAPER_TEMPLATES)

    @property
    def preprocessing(self) -> dict[str, Any]:
        """Keyword arguments of :func:`lfd.preprocess` the templates were trained with."""
        m = {**LEGACY_PREPROCESSING, **self.meta}
        return preprocessing_options(
            m.get("feature_cutoff_hz", LEGACY_FEATURE_CUTOFF_HZ),
            m["object_cutoff_hz"],
            m["aperture"],
            m["min_keypoint_confidence"],
        )

    def __repr__(self) -> str:
        return f"Templates(skills={self.skills}, features={[f[0] for f in self.features]})"


def _check_skills(skills: Any) -> None:
    """A template file's ``skills``: at least one, each known (the engine checks the types)."""
    if isinstance(skills, list) and not skills:
        raise ModelFormatError("template file: skills is empty; a template set needs at least one")
    unknown = [s for s in skills if s not in SKILLS] if isinstance(skills, list) else []
    if unknown:
        raise ModelFormatError(
            f"template file names unknown skill(s) {unknown}; known: {', '.join(SKILLS)}"
        )


def _check_features(features: Any) -> None:
    """A template file's ``features``: each one of Table I's (:data:`FEATURE_GROUPS`), by name
    and columns (the engine checks the types, repeats and the models' dimensions)."""
    groups = {name: (start, end) for name, start, end in FEATURE_GROUPS}
    for k, feature in enumerate(features if isinstance(features, list) else []):
        name = feature.get("name") if isinstance(feature, dict) else None
        if not isinstance(name, str):
            continue
        if name not in groups:
            raise ModelFormatError(
                f"template file: features[{k}].name {shown(name)} is not a feature; "
                f"known: {', '.join(groups)}"
            )
        columns = (feature.get("start"), feature.get("end"))
        if columns != groups[name]:
            raise ModelFormatError(
                f"template file: features[{k}] {name!r} is columns {groups[name][0]}.."
                f"{groups[name][1]} of the feature matrix, got {shown(columns[0])}.."
                f"{shown(columns[1])}"
            )


def resolve_templates(templates: Templates | TemplateChoice | None) -> Templates:
    """A template set, the shipped ``"default"`` (also for ``None``) or ``"paper"`` one."""
    if templates is None or templates == "default":
        return Templates.default()
    if templates == "paper":
        return Templates.paper()
    if isinstance(templates, Templates):
        return templates
    raise InvalidParameterError(
        f"templates must be a Templates object, 'default' or 'paper', got {templates!r}"
    )


@cache
def _shipped(resource: str) -> Templates:
    res = resources.files("lfd").joinpath(resource)
    if not res.is_file():
        raise ModelFormatError(
            f"the package has no shipped templates ({resource}); "
            "train some with `lfd templates train recordings/templates -o templates.json`"
        )
    return Templates.from_json(res.read_text(encoding="utf-8"))


def target_from_labels(traj: Trajectory, demo: Demonstration) -> np.ndarray | None:
    """Per-sample target object index from the labels' ``object`` names, shape (n,).

    Samples no label covers (or whose label names no known object) take the object of the
    nearest labelled sample. ``None`` if no label names an object.
    """
    n = len(traj)
    idx = np.full(n, -1, dtype=np.int64)
    for lab in demo.labels:
        if lab.object in traj.object_names:
            sel = (traj.t_ns >= lab.start_ns) & (traj.t_ns <= lab.end_ns)
            idx[sel] = traj.object_names.index(lab.object)
    known = np.flatnonzero(idx >= 0)
    if known.size == 0:
        return None
    nearest = known[np.clip(np.searchsorted(known, np.arange(n)), 0, known.size - 1)]
    return np.where(idx >= 0, idx, idx[nearest])


def label_range(traj: Trajectory, start_ns: int, end_ns: int) -> tuple[int, int]:
    """Sample index range ``[i0, i1)`` of a labelled span on the trajectory clock."""
    i0 = int(np.searchsorted(traj.t_ns, start_ns, side="left"))
    i1 = int(np.searchsorted(traj.t_ns, end_ns, side="left"))
    return i0, max(i1, i0)


def preprocessing_options(
    feature_cutoff_hz: float | Literal["auto"] = FEATURE_CUTOFF_HZ,
    object_cutoff_hz: float | None = OBJECT_CUTOFF_HZ,
    aperture: Aperture = APERTURE,
    min_keypoint_confidence: float = MIN_KEYPOINT_CONFIDENCE,
) -> dict[str, Any]:
    """The preprocessing keyword arguments templates are trained (and used) with
    (``object_cutoff_hz=None``: the objects are filtered like the hand)."""
    fc = feature_cutoff_hz if feature_cutoff_hz == "auto" else float(feature_cutoff_hz)
    return {
        "feature_cutoff_hz": fc,
        "object_cutoff_hz": object_cutoff_hz
        if object_cutoff_hz is None
        else float(object_cutoff_hz),
        "aperture": aperture,
        "min_keypoint_confidence": float(min_keypoint_confidence),
    }


def template_examples(
    demo: Demonstration,
    *,
    feature_cutoff_hz: float | Literal["auto"] = FEATURE_CUTOFF_HZ,
    preprocessing: dict[str, Any] | None = None,
) -> list[tuple[str, np.ndarray]]:
    """The labelled segments of one template demonstration as ``(skill, features (m, 10))``.

    ``preprocessing``: keyword arguments of :func:`lfd.preprocess` (default:
    :func:`preprocessing_options` with ``feature_cutoff_hz``)."""
    from ..features import compute_features
    from ..preprocessing import preprocess
    from .gaps import fill_gaps

    if not demo.labels:
        raise DemonstrationError("a template demonstration needs skill labels")
    opts = preprocessing or preprocessing_options(feature_cutoff_hz)
    traj, _ = fill_gaps(preprocess(demo, **opts))
    feats = compute_features(traj, target=target_from_labels(traj, demo))
    out = []
    for lab in demo.labels:
        i0, i1 = label_range(traj, lab.start_ns, lab.end_ns)
        if i1 - i0 >= 2:
            out.append((lab.skill, np.asarray(feats.values[i0:i1], dtype=np.float64)))
    return out


def turn_object_frame(x: np.ndarray, k: int, symmetry: int = FRAME_SYMMETRY) -> np.ndarray:
    """Feature matrix ``x`` (m, 10) with the object frame turned by ``k * 2 pi / symmetry`` about z.

    Only the horizontal TCP-in-object columns change; every other feature is invariant.
    """
    a = 2.0 * np.pi * k / symmetry
    c, s = np.cos(a), np.sin(a)
    i, j = TCP_IN_OBJECT_XY
    out = np.array(x, dtype=np.float64, copy=True)
    out[:, i] = c * x[:, i] - s * x[:, j]
    out[:, j] = s * x[:, i] + c * x[:, j]
    return out


def template_params(params: dict[str, Any] | None = None) -> str:
    """The engine's default template parameters with ``params`` applied and checked, as JSON.

    Raises :class:`~lfd.errors.InvalidParameterError` for an unknown key (at any level), a value
    of the wrong type or one out of range (e.g. ``{"fit": {"n_states": 0}}``).
    """
    if params is None:
        params = {}
    if not isinstance(params, dict):
        raise InvalidParameterError(
            f"template parameters must be a dict (JSON object), got {type(params).__name__}"
        )
    try:
        text = json.dumps(params, allow_nan=False)
    except (TypeError, ValueError, RecursionError) as err:
        why = "nested too deeply" if isinstance(err, RecursionError) else err
        raise InvalidParameterError(f"template parameters are not plain JSON: {why}") from None
    return _hmmseg.template_params(text)


def train_templates(
    recordings: Iterable[str | Path | Demonstration],
    *,
    params: dict[str, Any] | None = None,
    features: Sequence[tuple[str, int, int]] = FEATURE_GROUPS,
    skills: Sequence[str] = SKILLS,
    progress: Callable[[str], None] | None = None,
    feature_cutoff_hz: float | Literal["auto"] = FEATURE_CUTOFF_HZ,
    object_cutoff_hz: float | None = OBJECT_CUTOFF_HZ,
    aperture: Aperture = APERTURE,
    frame_symmetry: int = FRAME_SYMMETRY,
    min_keypoint_confidence: float = MIN_KEYPOINT_CONFIDENCE,
    object_sizes: Mapping[str, Sequence[float]] | None = None,
    jobs: int | None = 1,
    ray_address: str | None = None,
    failed: dict[str, str] | None = None,
) -> Templates:
    """Train templates from labelled template recordings (MCAP paths or demonstrations).

    Parameters
    ----------
    recordings : iterable
        Template demonstrations; every labelled segment becomes a training example.
    params : dict, optional
        Overrides of the engine's template parameters (``_hmmseg.default_template_params()``),
        e.g. ``{"fit": {"n_states": 5}, "align": False}``. Checked before any recording is
        read: an unknown key at any level or a value of the wrong type or out of range raises
        :class:`~lfd.errors.InvalidParameterError` naming the key.
    features : sequence of (name, start, end)
        Feature groups, one HMM each.
    skills : sequence of str
        Skills to train (each needs at least one example).
    progress : callable, optional
        Called with each recording's name after it is processed.
    feature_cutoff_hz, object_cutoff_hz, aperture, min_keypoint_confidence
        Preprocessing of the examples (:func:`lfd.preprocess`), stored with the templates and
        used again when they segment.
    frame_symmetry : int
        Every example is used ``frame_symmetry`` times, with the object frame turned by
        multiples of ``360 / frame_symmetry`` degrees about z (:data:`FRAME_SYMMETRY`; 1 = off).
    object_sizes : mapping of name -> (x, y, z), optional
        Object sizes for recordings that do not carry them (:func:`lfd.load`).
    jobs, ray_address, failed
        How the recordings are read and preprocessed (in parallel; training is one step), and
        what a recording that fails does (:func:`collect_examples`).
    """
    if frame_symmetry < 1:
        raise ValueError(f"frame_symmetry must be at least 1, got {frame_symmetry}")
    template_params(params)  # checked before any recording is read
    opts = preprocessing_options(
        feature_cutoff_hz, object_cutoff_hz, aperture, min_keypoint_confidence
    )
    names, examples = collect_examples(
        recordings,
        preprocessing=opts,
        progress=progress,
        jobs=jobs,
        ray_address=ray_address,
        failed=failed,
        object_sizes=object_sizes,
    )
    return fit_templates(
        examples,
        names=names,
        params=params,
        features=features,
        skills=skills,
        preprocessing=opts,
        frame_symmetry=frame_symmetry,
    )


def collect_examples(
    recordings: Iterable[str | Path | Demonstration],
    *,
    preprocessing: dict[str, Any] | None = None,
    progress: Callable[[str], None] | None = None,
    object_sizes: Mapping[str, Sequence[float]] | None = None,
    jobs: int | None = 1,
    ray_address: str | None = None,
    failed: dict[str, str] | None = None,
) -> tuple[list[str], list[tuple[str, np.ndarray]]]:
    """The recordings' names and labelled segments ``(skill, features (m, 10))``, in order,
    preprocessed with ``preprocessing`` (default: :func:`preprocessing_options`);
    recordings given as paths are read with ``object_sizes`` (:func:`lfd.load`).

    ``jobs`` / ``ray_address``: how many recordings are read and preprocessed at once, and
    where (:func:`lfd.batch.run_batch`). A recording that fails raises its error, or with
    ``failed`` (a dict) is recorded there as ``{path: message}`` and left out."""
    from functools import partial

    from ..batch import raise_failed, reemit_warnings, run_batch

    opts = preprocessing or preprocessing_options()

    def step(res: Any) -> None:
        if progress is not None:
            progress(res.value[0] if res.ok else str(res.item))

    results = run_batch(
        partial(
            recording_examples,
            preprocessing=opts,
            object_sizes=dict(object_sizes) if object_sizes else None,
        ),
        list(recordings),
        jobs=jobs,
        ray_address=ray_address,
        progress=step,
    )
    names: list[str] = []
    examples: list[tuple[str, np.ndarray]] = []
    for res in results:
        reemit_warnings(res)
        if not res.ok:
            if failed is None:
                raise_failed([res])
            else:
                failed[str(res.item)] = str(res.error)
            continue
        name, ex = res.value  # type: ignore[misc]
        examples.extend(ex)
        names.append(Path(name).name)
    return names, examples


def recording_examples(
    rec: str | Path | Demonstration,
    *,
    preprocessing: dict[str, Any] | None = None,
    object_sizes: Mapping[str, Sequence[float]] | None = None,
) -> tuple[str, list[tuple[str, np.ndarray]]]:
    """One recording's name and :func:`template_examples`: the task :func:`collect_examples`
    runs per recording (a path read with ``object_sizes``, :func:`lfd.load`)."""
    from ..io import load

    demo = (
        rec
        if isinstance(rec, Demonstration)
        else load(rec, images=False, object_sizes=object_sizes)
    )
    name = str(rec) if not isinstance(rec, Demonstration) else demo.metadata.get("name", "demo")
    return str(name), template_examples(demo, preprocessing=preprocessing)


def augment(
    examples: Iterable[tuple[str, np.ndarray]],
    skills: Sequence[str],
    frame_symmetry: int = FRAME_SYMMETRY,
    layout_scales: Sequence[float] = LAYOUT_SCALES,
) -> list[tuple[int, np.ndarray]]:
    """``(skill index, x)`` of the examples of ``skills``, each turned ``frame_symmetry`` times,
    and those of skills not in :data:`RELATIONAL` also with ``object_distance`` scaled by each of
    ``layout_scales`` (:data:`LAYOUT_SCALES`)."""
    if any(not (np.isfinite(f) and f > 0) for f in layout_scales):
        raise InvalidParameterError(
            f"layout scales must be positive numbers, got {list(layout_scales)}"
        )
    kept = [(skill, np.asarray(x, dtype=np.float64)) for skill, x in examples if skill in skills]
    scaled = []
    for skill, x in kept:
        if skill not in RELATIONAL:
            for f in layout_scales:
                y = x.copy()
                y[:, OBJECT_DISTANCE] *= f
                scaled.append((skill, y))
    return [
        (list(skills).index(skill), turn_object_frame(x, k, frame_symmetry))
        for skill, x in kept + scaled
        for k in range(frame_symmetry)
    ]


def fit_templates(
    examples: Sequence[tuple[str, np.ndarray]],
    *,
    names: Sequence[str] = (),
    params: dict[str, Any] | None = None,
    features: Sequence[tuple[str, int, int]] = FEATURE_GROUPS,
    skills: Sequence[str] = SKILLS,
    preprocessing: dict[str, Any] | None = None,
    frame_symmetry: int = FRAME_SYMMETRY,
    layout_scales: Sequence[float] = LAYOUT_SCALES,
) -> Templates:
    """Train templates from labelled segments (see :func:`train_templates`) that were
    preprocessed with ``preprocessing`` (stored in the templates' meta; default:
    :func:`preprocessing_options`), augmented by :func:`augment`."""
    params_json = template_params(params)
    data = augment(examples, skills, frame_symmetry, layout_scales)
    engine = _hmmseg.TemplateSet.train(list(skills), list(features), data, params_json)
    meta = {
        "trained_from": list(names),
        **(preprocessing or preprocessing_options()),
        "frame_symmetry": frame_symmetry,
        "layout_scales": list(layout_scales),
    }
    return Templates(engine, meta=meta)
