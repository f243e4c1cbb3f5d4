"""The ``lfd`` command line. Each subcommand lives in its own module under ``lfd.cli``.

A command module defines ``NAME``, ``HELP``, ``add_arguments(parser)`` and ``run(args) -> int``;
register it in :data:`COMMANDS`. Heavy imports belong inside ``run`` so ``lfd --help`` is fast.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

from ..errors import LfdError

COMMANDS: tuple[str, ...] = (
    # one module name per subcommand, in help order
    "info",
    "simulate",
    "segment",
    "templates",
    "eval",
    "reproduce",
    "record",
    "perception",
)


def build_parser() -> argparse.ArgumentParser:
    from .._version import __version__

    parser = argparse.ArgumentParser(
        prog="lfd",
        description="Learn a robot manipulation task from a human hand demonstration.",
    )
    parser.add_argument("--version", action="version", version=f"lfd {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMANDS:
        mod = importlib.import_module(f"{__name__}.{name}")
        p = sub.add_parser(mod.NAME, help=mod.HELP, description=mod.HELP)
        mod.add_arguments(p)
        p.set_defaults(_run=mod.run)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not hasattr(args, "_run"):
        parser.print_help()
        return 0
    try:
        return int(args._run(args) or 0)
    except LfdError as err:
        print(f"lfd {args.command}: error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
