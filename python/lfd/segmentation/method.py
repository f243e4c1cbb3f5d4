"""A segmentation method as one value: templates, their preprocessing, parameters, search, grammar.

>>> import lfd
>>> method = lfd.Method.load("paper")                     # doctest: +SKIP
>>> lfd.segment(lfd.load("recordings/exp1.mcap"), method=method)   # doctest: +SKIP

The CLI turns its options (``--paper``, ``--templates``, ``--search``, ``--grammar``) into one
:class:`Method` (:meth:`Method.load` and :meth:`Method.with_options`); library calls take one.
A method is saved with its templates (the ``method`` entry of the template file's ``lfd``
block) and shown by ``lfd info FILE.json`` and ``lfd segment --json`` (:meth:`Method.describe`).
"""

from __future__ import annotations

import dataclasses
import json
import os
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any, get_args

from ..errors import InvalidParameterError, LfdError, ModelFormatError
from ..rules import Choice, Instance, Rule, Text, check_fields, check_keys, from_document
from .schema import SEGMENT_RULES
from .settings import (
    DEFAULT_GRAMMAR,
    DEFAULT_SEARCH,
    PAPER_GRAMMAR,
    PAPER_PARAMS,
    PAPER_SEARCH,
    GrammarUse,
    Search,
    SegmentParams,
)
from .templates import Templates

NAMES: tuple[str, ...] = ("default", "paper")
"""The named methods :meth:`Method.load` knows (any other argument is a template file)."""

METHOD_RULES: dict[str, Rule] = {
    "name": Text(1000),
    "templates": Instance(Templates),
    "params": Instance(SegmentParams),
    "search": Choice(get_args(Search)),
    "grammar": Choice(get_args(GrammarUse)),
}
"""What a :class:`Method`'s fields hold. A file's ``lfd.method`` entry (:data:`METHOD_KEYS`)
has the plain ones and ``params`` as a JSON object of the
:data:`~lfd.segmentation.schema.SEGMENT_RULES` fields."""
METHOD_KEYS: frozenset[str] = frozenset({"name", "search", "grammar", "params"})


@dataclass(frozen=True)
class Method:
    """How a demonstration is segmented, as one value.

    Attributes
    ----------
    name : str
        ``default``, ``paper`` or the template file it was loaded from.
    templates : Templates
        The skill templates; their preprocessing (:attr:`preprocessing`) is the method's.
    params : SegmentParams
        Stage-1 and stage-2 parameters (stage-1 thresholds, rise rule, co-motion, contacts).
    search : {"dp", "greedy"}
    grammar : {"enforce", "warn", "off"}
    """

    name: str = "default"
    templates: Templates = field(default_factory=Templates.default, compare=False)
    params: SegmentParams = field(default_factory=SegmentParams)
    search: Search = DEFAULT_SEARCH
    grammar: GrammarUse = DEFAULT_GRAMMAR

    def __post_init__(self) -> None:
        check_fields(self, METHOD_RULES, "method.")

    @property
    def preprocessing(self) -> dict[str, Any]:
        """Keyword arguments of :func:`lfd.preprocess` the templates were trained with (every
        recording this method segments is preprocessed with them, once)."""
        return dict(self.templates.preprocessing)

    @classmethod
    def default(cls) -> Method:
        """lfd's default: the shipped templates, segmental DP under the grammar, contact
        boundaries."""
        return cls()

    @classmethod
    def paper(cls) -> Method:
        """The paper's algorithm: the greedy cut loop that warns about impossible transitions,
        on templates of the paper's recipe, stage 1 on the hand signals only, no contacts."""
        return cls("paper", Templates.paper(), PAPER_PARAMS, PAPER_SEARCH, PAPER_GRAMMAR)

    @classmethod
    def load(cls, spec: str | os.PathLike[str] | Method | Templates | None = None) -> Method:
        """A method from a name (``default``, ``paper``), a template file (with the method saved
        in it, else the default parameters), a :class:`Templates` or a method (returned)."""
        if isinstance(spec, Method):
            return spec
        if spec is None or spec == "default":
            return cls.default()
        if spec == "paper":
            return cls.paper()
        if isinstance(spec, Templates):
            return cls.of_templates(spec)
        if isinstance(spec, (str, os.PathLike)):
            path = Path(spec)
            try:
                exists = path.exists()
            except (OSError, ValueError):  # a name too long, a NUL byte
                exists = False
            if not exists:
                raise InvalidParameterError(
                    f"method {str(spec)!r} is neither {' nor '.join(NAMES)} nor a template file"
                )
            templates = Templates.load(path)  # its errors name the file
            try:
                return cls.of_templates(templates, name=str(path))
            except ModelFormatError as err:
                raise ModelFormatError(f"{path}: {err}") from None
        raise InvalidParameterError(
            f"a method is a name ({', '.join(NAMES)}), a template file, Templates or a Method, "
            f"got {type(spec).__name__}"
        )

    @classmethod
    def of_templates(cls, templates: Templates, *, name: str = "templates") -> Method:
        """The method saved with ``templates`` (:meth:`save`), else the default one on them.
        A saved method that breaks the schema (:mod:`lfd.segmentation.schema`) raises
        :class:`~lfd.errors.ModelFormatError` naming the field."""
        return cls.from_entry(templates, templates.meta.get("method"), name=name)

    @classmethod
    def from_entry(cls, templates: Templates, entry: Any, *, name: str = "templates") -> Method:
        """The method a file's ``lfd.method`` entry (:data:`METHOD_KEYS`) describes on
        ``templates`` (an empty or missing entry: the default method, named ``name``)."""
        if not entry:
            return cls(name, templates)
        doc = dict(check_keys(entry, METHOD_KEYS, "lfd.method.", ModelFormatError))
        params = doc.pop("params", {})
        kwargs = {
            key: METHOD_RULES[key].check(value, f"lfd.method.{key}", ModelFormatError)
            for key, value in doc.items()
        }
        return cls(
            templates=templates,
            params=params_from_dict(params, "lfd.method.params.", ModelFormatError),
            **{"name": name, **kwargs},
        )

    def with_options(
        self,
        *,
        search: Search | None = None,
        grammar: GrammarUse | None = None,
        params: SegmentParams | None = None,
    ) -> Method:
        """This method with the options given (``None``: keep this method's)."""
        changes: dict[str, Any] = {}
        if search is not None:
            changes["search"] = search
        if grammar is not None:
            changes["grammar"] = grammar
        if params is not None:
            changes["params"] = params
        return dataclasses.replace(self, **changes) if changes else self

    def describe(self) -> dict[str, Any]:
        """The method as a JSON-ready dict (``lfd segment --json``, ``lfd info``)."""
        return {
            "name": self.name,
            "search": self.search,
            "grammar": self.grammar,
            "templates": {
                "skills": self.templates.skills,
                "features": [f[0] for f in self.templates.features],
            },
            "preprocessing": self.preprocessing,
            "params": dataclasses.asdict(self.params),
        }

    def entry(self) -> dict[str, Any]:
        """The method as a file's ``lfd.method`` entry (:meth:`from_entry` reads it back)."""
        return {
            "name": self.name,
            "search": self.search,
            "grammar": self.grammar,
            "params": dataclasses.asdict(self.params),
        }

    def to_templates(self) -> Templates:
        """The templates with this method saved in them (what :meth:`save` writes)."""
        return Templates(
            self.templates.engine, meta={**self.templates.meta, "method": self.entry()}
        )

    def portable(self) -> str:
        """The method as text a worker process or Ray node takes (:meth:`from_portable`): the
        name of its shipped templates and its entry, or the whole template file. A method is
        pickled as this text (what :mod:`lfd.batch` sends a worker), and rebuilt, checked
        like a file, once per process for a given text."""
        for shipped, templates in (("default", Templates.default()), ("paper", Templates.paper())):
            if self.templates is templates:
                return json.dumps({"shipped": shipped, "method": self.entry()})
        return self.to_templates().to_json()

    @classmethod
    def from_portable(cls, text: str | None) -> Method:
        """The inverse of :meth:`portable` (``None``: the default method)."""
        return cls.default() if text is None else _from_portable(text)

    def __reduce__(self) -> tuple[Any, ...]:
        return (Method.from_portable, (self.portable(),))

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write the templates with this method in them; :meth:`load` reads it back."""
        self.to_templates().save(Path(path))


@lru_cache(maxsize=4)
def _from_portable(text: str) -> Method:
    from ..inputs import parse_json

    doc = parse_json(text, "a portable method is not JSON", ModelFormatError)
    shipped = doc.get("shipped") if isinstance(doc, dict) else None
    if shipped is None:
        return Method.of_templates(Templates.from_json(text))
    templates = {"default": Templates.default, "paper": Templates.paper}[shipped]()
    return Method.from_entry(templates, doc["method"])


def params_from_dict(
    doc: Any, where: str = "params.", error: type[LfdError] = InvalidParameterError
) -> SegmentParams:
    """:class:`SegmentParams` from a JSON object of its fields (:func:`dataclasses.asdict`
    output; missing keys: the defaults), every field checked by its rule
    (:data:`~lfd.segmentation.schema.SEGMENT_RULES`): ``error`` naming ``<where><field>``."""
    return from_document(SegmentParams, doc, SEGMENT_RULES, where, error)
