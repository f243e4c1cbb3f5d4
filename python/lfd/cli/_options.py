"""Options shared by several subcommands (not a subcommand itself)."""

from __future__ import annotations

import argparse
from typing import get_args


def add_search_argument(parser: argparse.ArgumentParser, default: str, help: str) -> None:
    """``--search``: the stage-2 search of :func:`lfd.segment` (choices from its type)."""
    from ..segment.pipeline import Search

    parser.add_argument("--search", choices=get_args(Search), default=default, help=help)


def add_grammar_argument(parser: argparse.ArgumentParser, default: str, help: str) -> None:
    """``--grammar``: how :func:`lfd.segment` uses the skill grammar (choices from its type)."""
    from ..segment.pipeline import GrammarUse

    parser.add_argument("--grammar", choices=get_args(GrammarUse), default=default, help=help)
