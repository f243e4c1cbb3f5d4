"""``lfd templates train DIR -o templates.json``: train skill templates from labelled recordings."""

from __future__ import annotations

import argparse
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
    train.add_argument(
        "--base",
        metavar="default|FILE",
        help="adapt this template set (default: the shipped one) to the recordings instead of "
        "training from scratch; skills they do not show keep the base's models",
    )
    train.add_argument(
        "--min-keypoint-confidence",
        type=float,
        metavar="C",
        help="drop hand keypoints estimated with a confidence below C (0-1) when preprocessing "
        "the examples, and weight the rest by confidence; stored in the templates and used "
        "again when they segment (default: 0, confidence ignored; not with --base, which keeps "
        "the base's preprocessing)",
    )
    from ._options import add_recording_arguments

    add_recording_arguments(train, ros=False)  # ROS bags carry no ground truth
    from ._options import add_batch_options

    add_batch_options(train)  # reading and preprocessing the recordings; training is one step
    show = sub.add_parser("show", help="summarise a template file")
    show.add_argument("file", nargs="?", help="template file (default: the shipped one)")


def run(args: argparse.Namespace) -> int:

    from ..errors import UsageError
    from ..inputs import parse_json
    from ..outputs import check_output
    from ..segmentation import Method, Templates
    from ..segmentation.evaluate import expand_paths
    from ..segmentation.templates import (
        template_params,
    )
    from ._options import batch_options, check_inputs, load_options, make_console, read_files

    console = make_console()
    if args.action == "train":
        # check the parameters before any recording is read
        params = parse_json(args.params, "--params is not valid JSON") if args.params else None
        template_params(params)
        if args.base is not None and params is not None:
            raise UsageError("--params sets how to train from scratch; --base keeps its own")
        if args.base not in (None, "default"):
            check_inputs(base=args.base)
        conf = args.min_keypoint_confidence
        if conf is not None and not 0.0 <= conf <= 1.0:
            raise UsageError(f"--min-keypoint-confidence must be in [0, 1], got {conf:g}")
        if args.base is not None and conf is not None:
            raise UsageError(
                "--min-keypoint-confidence sets how to train from scratch; --base keeps its own"
            )
        load_options(args)  # a bad --object-size fails before any recording is read
    if args.action == "show":
        t = Method.load(args.file).templates if args.file else Templates.default()
        console.print(t)
        console.print(
            f"examples per skill: {dict(zip(t.skills, t.engine.n_examples, strict=True))}"
        )
        console.print(f"parameters: {t.engine.params_json}")
        return 0
    paths = expand_paths(args.inputs)
    if not paths:
        raise UsageError(f"no .mcap recordings in {' '.join(args.inputs)}")
    base_path = [args.base] if args.base not in (None, "default") else []
    check_output(args.output, inputs=read_files(args, *paths, *base_path), what="-o/--output")
    how = batch_options(args)
    failed: dict[str, str] = {}
    base = None
    if args.base is not None:
        base = Templates.default() if args.base == "default" else Method.load(args.base).templates
    try:
        templates = _train(args, paths, base, params, how, failed, console)
    except BaseException:
        _report_failed(failed, len(paths))  # the recordings that failed before training did
        raise
    templates.save(args.output)
    status = _report_failed(failed, len(paths))
    if base is not None:
        console.print(
            f"adapted {args.base} on {len(paths)} recordings, user examples per skill "
            f"{templates.meta['adapt_examples']}"
        )
    console.print(
        f"wrote {args.output}: {len(templates.skills)} skills x {len(templates.features)} features, "
        f"examples {dict(zip(templates.skills, templates.engine.n_examples, strict=True))}"
    )
    return status


def _report_failed(failed: dict[str, str], total: int) -> int:
    """Print the recordings that could not be read, one line each: exit status 2 if any."""
    import sys

    for path, message in failed.items():
        print(f"lfd templates: error: {path}: {message}", file=sys.stderr)
    if failed:
        print(
            f"lfd templates: trained on {total - len(failed)} of {total} recordings; "
            f"{len(failed)} failed",
            file=sys.stderr,
        )
    return 2 if failed else 0


def _train(args, paths, base, params, how, failed, console):  # type: ignore[no-untyped-def]
    """Read the recordings (in parallel) and train or adapt the templates, with a progress bar."""
    from rich.console import Console
    from rich.progress import Progress

    from ..errors import UsageError
    from ..segmentation import train_templates
    from ..segmentation.adapt import adapt_templates
    from ..segmentation.templates import MIN_KEYPOINT_CONFIDENCE, collect_examples
    from ._options import load_options

    sizes = load_options(args)["object_sizes"]
    err = Console(stderr=True)
    with Progress(console=err, disable=not err.is_terminal) as progress:
        task = progress.add_task("reading templates", total=len(paths) + 1)

        def step(name: str) -> None:
            progress.update(task, advance=1, description=f"read {Path(name).name}")

        if base is None:
            conf = args.min_keypoint_confidence
            templates = train_templates(
                paths,
                params=params,
                progress=step,
                min_keypoint_confidence=MIN_KEYPOINT_CONFIDENCE if conf is None else conf,
                failed=failed if len(paths) > 1 else None,
                object_sizes=sizes,
                **how,
            )
        else:
            names, examples = collect_examples(
                paths,
                preprocessing=base.preprocessing,
                progress=step,
                failed=failed if len(paths) > 1 else None,
                object_sizes=sizes,
                **how,
            )
            if not examples:
                raise UsageError(
                    f"none of the {len(paths)} recordings has ground-truth skill labels; "
                    "add them with `lfd label`"
                )
            templates = adapt_templates(base, examples, names=names, base_name=args.base)
        progress.update(task, advance=1, description="trained")
    return templates
