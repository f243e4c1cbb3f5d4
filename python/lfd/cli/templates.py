"""``lfd templates train DIR -o templates.json``: train skill templates from labelled recordings."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

NAME = "templates"
HELP = "Train skill templates (one HMM per skill x feature) from labelled template recordings."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    train = sub.add_parser("train", help="train templates from a directory of MCAP recordings")
    train.add_argument("inputs", nargs="+", help="directories or .mcap files with skill labels")
    train.add_argument(
        "-o", "--output", required=True, metavar="FILE.json", help="template file to write (JSON)"
    )
    train.add_argument(
        "--params", metavar="JSON", help="engine template parameters to override (JSON object)"
    )
    show = sub.add_parser("show", help="summarise a template file")
    show.add_argument("file", nargs="?", help="template file (default: the shipped one)")


def run(args: argparse.Namespace) -> int:
    from rich.console import Console
    from rich.progress import Progress

    from ..errors import UsageError
    from ..outputs import check_output
    from ..segmentation import Templates, train_templates
    from ..segmentation.evaluate import expand_paths
    from ..segmentation.templates import template_params

    console = Console()
    if args.action == "train":
        # check the parameters before any recording is read
        try:
            params = json.loads(args.params) if args.params else None
        except json.JSONDecodeError as err:
            raise UsageError(f"--params is not valid JSON: {err}") from None
        template_params(params)
    if args.action == "show":
        t = Templates.load(args.file) if args.file else Templates.default()
        console.print(t)
        console.print(
            f"examples per skill: {dict(zip(t.skills, t.engine.n_examples, strict=True))}"
        )
        console.print(f"parameters: {t.engine.params_json}")
        return 0
    paths = expand_paths(args.inputs)
    if not paths:
        raise UsageError(f"no .mcap recordings in {' '.join(args.inputs)}")
    check_output(args.output, inputs=paths, what="-o/--output")
    with Progress(console=console) as progress:
        task = progress.add_task("reading templates", total=len(paths) + 1)

        def step(name: str) -> None:
            progress.update(task, advance=1, description=f"read {Path(name).name}")

        templates = train_templates(paths, params=params, progress=step)
        progress.update(task, advance=1, description="trained")
    templates.save(args.output)
    console.print(
        f"wrote {args.output}: {len(templates.skills)} skills x {len(templates.features)} features, "
        f"examples {dict(zip(templates.skills, templates.engine.n_examples, strict=True))}"
    )
    return 0
