"""Segment one recording file: the task :mod:`lfd.batch` runs for ``lfd segment A B ... | DIR``.

A task takes a path and plain options (picklable, so it runs in a worker process or on a Ray
node) and gives plain data back: the ``lfd segment --json`` document of the recording.
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path
from typing import Any

from .pipeline import DEFAULT_GRAMMAR, DEFAULT_SEARCH, GrammarUse, Search, SegmentParams
from .templates import TemplateChoice, Templates


@lru_cache(maxsize=4)
def templates_from_json(text: str) -> Templates:
    """:meth:`Templates.from_json`, parsed once per worker process for a given text."""
    return Templates.from_json(text)


def portable_templates(templates: Templates | TemplateChoice | None) -> str | None:
    """``templates`` as a worker can take them: a shipped set's name, ``None``, or JSON text."""
    return templates.to_json() if isinstance(templates, Templates) else templates


def worker_templates(templates: str | None) -> Templates | TemplateChoice | None:
    """The inverse of :func:`portable_templates` (in the worker)."""
    if templates is None or templates in ("default", "paper"):
        return templates  # type: ignore[return-value]
    return templates_from_json(templates)


def segment_file(
    path: str | Path,
    *,
    templates: str | None = None,
    search: Search = DEFAULT_SEARCH,
    grammar: GrammarUse = DEFAULT_GRAMMAR,
    params: SegmentParams | None = None,
    load_options: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """Load ``path``, segment it and return the ``lfd segment --json`` document
    (:meth:`~lfd.segmentation.Segmentation.report` with its ground truth).

    ``templates``: a shipped set's name, ``None`` (the default set) or a template set's JSON
    text (:func:`portable_templates`); ``load_options``: keyword arguments of :func:`lfd.load`
    (``object_sizes``, a ROS ``mapping``).
    """
    from ..io import load
    from . import segment

    demo = load(path, images=False, **(load_options or {}))
    result = segment(
        demo, worker_templates(templates), search=search, grammar=grammar, params=params
    )
    return result.report(demo.labels, recording=str(path))
