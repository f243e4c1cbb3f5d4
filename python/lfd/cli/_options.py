"""Options shared by several subcommands (not a subcommand itself)."""

from __future__ import annotations

import argparse
from typing import get_args


def add_segmentation_arguments(parser: argparse.ArgumentParser, *, used_with: str = "") -> None:
    """``--search``, ``--grammar`` and ``--paper``: the stage-2 options of :func:`lfd.segment`.

    The defaults are the most accurate method (segmental DP under the grammar); ``--paper``
    selects the paper's algorithm (greedy cut loop, grammar warnings). Read the chosen values with
    :func:`segmentation_options`.
    """
    from ..segmentation.pipeline import DEFAULT_GRAMMAR, DEFAULT_SEARCH, GrammarUse, Search

    when = f" {used_with}" if used_with else ""
    group = parser.add_argument_group("segmentation method")
    group.add_argument(
        "--search",
        choices=get_args(Search),
        default=None,
        help=f"stage-2 search{when}: dp = optimal segmental DP (default), greedy = the paper's loop",
    )
    group.add_argument(
        "--grammar",
        choices=get_args(GrammarUse),
        default=None,
        help=f"skill grammar{when}: enforce it (default), warn about impossible transitions, or off",
    )
    group.add_argument(
        "--paper",
        action="store_true",
        help=f"the paper's algorithm{when}: --search greedy --grammar warn "
        f"(default: --search {DEFAULT_SEARCH} --grammar {DEFAULT_GRAMMAR})",
    )


def segmentation_options(args: argparse.Namespace) -> tuple[str, str]:
    """(search, grammar) chosen by :func:`add_segmentation_arguments`'s options."""
    from ..errors import UsageError
    from ..segmentation.pipeline import (
        DEFAULT_GRAMMAR,
        DEFAULT_SEARCH,
        PAPER_GRAMMAR,
        PAPER_SEARCH,
    )

    if args.paper:
        if args.search not in (None, PAPER_SEARCH) or args.grammar not in (None, PAPER_GRAMMAR):
            raise UsageError(
                f"--paper means --search {PAPER_SEARCH} --grammar {PAPER_GRAMMAR}; "
                "drop --paper to choose other values"
            )
        return PAPER_SEARCH, PAPER_GRAMMAR
    return args.search or DEFAULT_SEARCH, args.grammar or DEFAULT_GRAMMAR
