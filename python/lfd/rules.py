"""Typed, ranged fields: the one check of each kind of value a parameter or a file field holds.

A rule table maps the fields of a parameter dataclass (or of a JSON object in a file) to a rule:
:class:`Number` (a finite number in a range, or one of a few literal values), :class:`Whole` (an
integer in a range; ``3.0`` is refused), :class:`Flag` (``True``/``False``; ``"no"`` is refused),
:class:`Choice`, :class:`Text`, :class:`Items` (a list), :class:`Counts` (names to whole
numbers), :class:`Nested` (another table's dataclass, from a JSON object) and :class:`Instance`
(a Python object no file holds).
The same table serves both ends:

- :func:`check_fields` in a dataclass's ``__post_init__``: every field checked (and a number
  stored as a ``float``), so an instance is valid however it was made;
- :func:`from_document` for a JSON object read from a file: unknown keys refused by name, each
  value checked with its field's rule (the message names its place in the file), then the
  dataclass made from them.

Messages are one line, ``<name> must be <what the rule wants>, got <value>``, raised as the
caller's :class:`~lfd.errors.LfdError` subclass.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import numbers
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, TypeVar

from .errors import InvalidParameterError, LfdError

__all__ = [
    "Choice",
    "Counts",
    "Flag",
    "Instance",
    "Items",
    "Nested",
    "Number",
    "Rule",
    "Text",
    "Whole",
    "check_fields",
    "check_keys",
    "from_document",
]

T = TypeVar("T")
Error = type[LfdError]


def shown(value: Any) -> str:
    """A value as a message shows it: short, JSON-like (``'no'``, ``nan``, ``a list``)."""
    if isinstance(value, bool) or value is None:
        return {True: "true", False: "false", None: "null"}[value]
    if isinstance(value, (list, tuple)):
        return f"a list of {len(value)}"
    if isinstance(value, dict):
        return "a JSON object"
    text = repr(value) if isinstance(value, str) else str(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _is_number(value: Any) -> bool:
    return isinstance(value, numbers.Real) and not _is_bool(value)


def _is_bool(value: Any) -> bool:
    return isinstance(value, bool) or (
        type(value).__name__ in ("bool_", "bool") and (type(value).__module__ == "numpy")
    )


class Rule:
    """What one field holds. :meth:`check` returns the value (normalised) or raises."""

    def want(self) -> str:
        """What the rule wants, as the message says it (``a number in [0, 1]``)."""
        raise NotImplementedError

    def ok(self, value: Any) -> Any:
        """The value normalised, or ``None`` when it breaks the rule (subclasses)."""
        raise NotImplementedError

    def check(self, value: Any, name: str, error: Error = InvalidParameterError) -> Any:
        """``value`` as the field keeps it, or ``error("<name> must be ..., got ...")``."""
        out = self.ok(value)
        if out is _BAD:
            raise error(f"{name} must be {self.want()}, got {shown(value)}")
        return out


_BAD: Any = object()


def _interval(low: float, high: float, open_low: bool) -> str:
    return f"{'(' if open_low else '['}{low:g}, {high:g}]"


@dataclass(frozen=True)
class Number(Rule):
    """A finite number in ``[low, high]`` (``(low, high]`` with ``open_low``), kept as a
    ``float``; or one of the literal values ``also`` (``None``, ``"auto"``)."""

    low: float
    high: float
    unit: str = ""
    open_low: bool = False
    also: tuple[Any, ...] = ()

    def want(self) -> str:
        span = _interval(self.low, self.high, self.open_low) + (
            f" {self.unit}" if self.unit else ""
        )
        extra = " or ".join(shown(a) for a in self.also)
        return f"{extra + ' or ' if extra else ''}a number in {span}"

    def ok(self, value: Any) -> Any:
        if any(value is a or (isinstance(a, str) and value == a) for a in self.also):
            return value
        if not _is_number(value):
            return _BAD
        x = float(value)
        if (
            not math.isfinite(x)
            or x > self.high
            or x < self.low
            or (self.open_low and x <= self.low)
        ):
            return _BAD
        return x


@dataclass(frozen=True)
class Whole(Rule):
    """An integer in ``[low, high]`` (a ``float``, even ``3.0``, is refused)."""

    low: int
    high: int

    def want(self) -> str:
        return f"a whole number in [{self.low}, {self.high}]"

    def ok(self, value: Any) -> Any:
        if not isinstance(value, numbers.Integral) or _is_bool(value):
            return _BAD
        return int(value) if self.low <= int(value) <= self.high else _BAD


@dataclass(frozen=True)
class Flag(Rule):
    """``True`` or ``False`` (a JSON bool; ``"no"``, ``0`` are refused)."""

    def want(self) -> str:
        return "true or false"

    def ok(self, value: Any) -> Any:
        return bool(value) if _is_bool(value) else _BAD


@dataclass(frozen=True)
class Choice(Rule):
    """One of ``options`` (strings, or ``None``)."""

    options: tuple[Any, ...]

    def want(self) -> str:
        return "one of " + ", ".join(shown(o) for o in self.options)

    def ok(self, value: Any) -> Any:
        hit = any(value is o or (isinstance(value, str) and value == o) for o in self.options)
        return value if hit else _BAD


@dataclass(frozen=True)
class Text(Rule):
    """A string of at most ``max_len`` characters."""

    max_len: int = 10_000

    def want(self) -> str:
        return f"a string of at most {self.max_len} characters"

    def ok(self, value: Any) -> Any:
        return value if isinstance(value, str) and len(value) <= self.max_len else _BAD


@dataclass(frozen=True)
class Items(Rule):
    """A list of at most ``max_items`` values, each following ``item`` (kept as a list)."""

    item: Rule
    max_items: int = 100_000

    def want(self) -> str:
        return f"a list of at most {self.max_items} items, each {self.item.want()}"

    def ok(self, value: Any) -> Any:
        if not isinstance(value, (list, tuple)) or len(value) > self.max_items:
            return _BAD
        out = [self.item.ok(v) for v in value]
        return _BAD if any(v is _BAD for v in out) else out


@dataclass(frozen=True)
class Counts(Rule):
    """A JSON object of names (strings) to whole numbers in ``[0, high]``."""

    high: int = 10**9

    def want(self) -> str:
        return f"a JSON object of names to whole numbers in [0, {self.high}]"

    def ok(self, value: Any) -> Any:
        if not isinstance(value, dict):
            return _BAD
        count = Whole(0, self.high)
        out = {k: count.ok(v) for k, v in value.items() if isinstance(k, str)}
        return _BAD if len(out) != len(value) or _BAD in out.values() else out


@dataclass(frozen=True)
class Instance(Rule):
    """An instance of ``cls`` (a value no file holds: templates, a parameter set)."""

    cls: type

    def want(self) -> str:
        return f"a {self.cls.__name__}"

    def ok(self, value: Any) -> Any:
        return value if isinstance(value, self.cls) else _BAD


@dataclass(frozen=True)
class Nested(Rule):
    """An instance of the dataclass ``cls`` (checked by its own constructor); in a document, a
    JSON object of its fields (:func:`from_document` with ``rules``). ``nullable``: ``None``
    too."""

    cls: type
    rules: Mapping[str, Rule]
    nullable: bool = False

    def want(self) -> str:
        return f"{'null or ' if self.nullable else ''}a JSON object of {self.cls.__name__} fields"

    def ok(self, value: Any) -> Any:
        if value is None and self.nullable:
            return None
        return value if isinstance(value, self.cls) else _BAD

    def build(self, value: Any, name: str, error: Error) -> Any:
        """The field's value from a document: ``None`` or a dict made into ``cls``."""
        if value is None and self.nullable:
            return None
        if not isinstance(value, dict):
            raise error(f"{name} must be {self.want()}, got {shown(value)}")
        return from_document(self.cls, value, self.rules, f"{name}.", error)


def check_fields(obj: Any, rules: Mapping[str, Rule], prefix: str = "") -> None:
    """Check every field of the dataclass instance ``obj`` with its rule (in ``__post_init__``):
    :class:`~lfd.errors.InvalidParameterError` naming ``<prefix><field>``; a value a rule
    normalises (an ``int`` for a ``float`` field) is stored normalised, frozen or not."""
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        kept = rules[f.name].check(value, f"{prefix}{f.name}")
        if kept is not value:
            object.__setattr__(obj, f.name, kept)


def check_keys(doc: Any, known: Any, where: str, error: Error) -> dict[str, Any]:
    """``doc`` if it is a JSON object whose keys are all in ``known``, else ``error`` naming
    the first unknown key (and the known one it is closest to)."""
    if not isinstance(doc, dict):
        raise error(
            f"{where.rstrip('.') or 'the document'} must be a JSON object, got {shown(doc)}"
        )
    for key in doc:
        if key not in known:
            names = [str(k) for k in known]
            near = difflib.get_close_matches(str(key), names, n=1)
            hint = f" (did you mean {near[0]!r}?)" if near else f"; known: {', '.join(names)}"
            raise error(f"unknown key {where}{key}{hint}")
    return doc


def from_document(
    cls: type[T],
    doc: Any,
    rules: Mapping[str, Rule],
    prefix: str = "",
    error: Error = InvalidParameterError,
) -> T:
    """``cls(**doc)`` for a JSON object ``doc`` of its fields (missing ones: the defaults),
    every value checked with its rule first, so a bad one is ``error`` naming its place
    (``<prefix><field>``); unknown keys are refused (:func:`check_keys`)."""
    check_keys(doc, rules, prefix, error)
    kwargs: dict[str, Any] = {}
    for key, value in doc.items():
        rule = rules[key]
        name = f"{prefix}{key}"
        kwargs[key] = (
            rule.build(value, name, error)
            if isinstance(rule, Nested)
            else rule.check(value, name, error)
        )
    try:
        return cls(**kwargs)
    except InvalidParameterError as err:  # a rule across fields, checked by the constructor
        raise error(f"{prefix}{err}" if error is not InvalidParameterError else str(err)) from None
