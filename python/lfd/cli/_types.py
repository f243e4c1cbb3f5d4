"""argparse ``type=`` converters that refuse out-of-range numbers before any work starts.

Each converter parses one option value and raises :class:`argparse.ArgumentTypeError` with a
message saying what is expected, so ``lfd simulate --duration -1`` ends with exit status 2 and
``argument --duration: must be a number > 0, got '-1'``. NaN and infinity are refused by every
float converter: no option of lfd means anything with them. Numbers are read with
:func:`lfd.inputs.parse_number` (and ``parse_integer``): ``1_0`` is refused, not taken as 10.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable


def _float(text: str) -> float:
    from ..inputs import parse_number

    try:
        v = parse_number(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number, got {text!r}") from None
    if not math.isfinite(v):
        raise argparse.ArgumentTypeError(f"must be a finite number, got {text!r}")
    return v


def _int(text: str) -> int:
    from ..inputs import parse_integer

    try:
        return parse_integer(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be an integer, got {text!r}") from None


def finite_float(text: str) -> float:
    """Any finite number."""
    return _float(text)


def positive_float(text: str) -> float:
    """A finite number > 0."""
    v = _float(text)
    if v <= 0:
        raise argparse.ArgumentTypeError(f"must be a number > 0, got {text!r}")
    return v


def float_range(lo: float, hi: float, *, lo_open: bool = False) -> Callable[[str], float]:
    """A converter for a finite number in ``[lo, hi]`` (``(lo, hi]`` with ``lo_open``)."""

    def convert(text: str) -> float:
        v = _float(text)
        if (v <= lo if lo_open else v < lo) or v > hi:
            interval = f"{'(' if lo_open else '['}{lo:g}, {hi:g}]"
            raise argparse.ArgumentTypeError(f"must be a number in {interval}, got {text!r}")
        return v

    convert.__name__ = f"number in [{lo:g}, {hi:g}]"
    return convert


def duration(text: str) -> float:
    """``--duration``: seconds > 0, at most :data:`lfd.inputs.MAX_DURATION_S` (24 h), by
    :func:`lfd.inputs.duration_problem` (the rule :func:`lfd.sim.demonstrator.crop` applies)."""
    from ..inputs import duration_problem

    v = _float(text)
    if v <= 0:
        raise argparse.ArgumentTypeError(f"must be a number > 0, got {text!r}")
    problem = duration_problem(v)
    if problem is not None:
        raise argparse.ArgumentTypeError(f"{problem}, got {text!r}")
    return v


def positive_int(text: str) -> int:
    """An integer >= 1."""
    v = _int(text)
    if v < 1:
        raise argparse.ArgumentTypeError(f"must be an integer >= 1, got {text!r}")
    return v


SEED_MAX = 2**63 - 1
"""Largest seed accepted (numpy's generators take any non-negative int; recordings store int64)."""


def seed(text: str) -> int:
    """A random seed: an integer in [0, 2**63 - 1]."""
    v = _int(text)
    if not 0 <= v <= SEED_MAX:
        raise argparse.ArgumentTypeError(f"must be an integer in [0, 2**63 - 1], got {text!r}")
    return v


def seconds_or_forever(text: str) -> float:
    """A number of seconds >= 0, or ``inf`` / ``forever`` (``math.inf``)."""
    if text.strip().lower() in ("inf", "forever"):
        return math.inf
    v = _float(text)
    if v < 0:
        raise argparse.ArgumentTypeError(f"must be seconds >= 0 or 'inf', got {text!r}")
    return v


def object_size(text: str) -> tuple[str, tuple[float, float, float]]:
    """``NAME=X,Y,Z``: an object's box size, three positive finite lengths in metres, each at
    most :data:`lfd.io.sizes.MAX_OBJECT_SIDE_M`."""
    from ..errors import UsageError
    from ..io.sizes import parse_object_size

    try:
        return parse_object_size(text)
    except UsageError as err:
        raise argparse.ArgumentTypeError(str(err).removeprefix(f"--object-size {text}: ")) from None


def layout_count(text: str) -> int:
    """``--randomise N``: a number of layouts, 1 to
    :data:`lfd.reproduce.randomise.MAX_LAYOUTS` (its rule, imported when the option is given)."""
    from ..errors import UsageError
    from ..reproduce.randomise import check_layout_count

    try:
        return check_layout_count(_int(text))
    except UsageError as err:
        raise argparse.ArgumentTypeError(f"{str(err).partition(': ')[2]}, got {text!r}") from None
