"""``lfd import ros BAG --map map.toml -o demo.mcap``: another tool's recording as an lfd one."""

from __future__ import annotations

import argparse

NAME = "import"
HELP = "Convert another tool's recording (a ROS 1/2 bag) into an lfd MCAP recording."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from ._options import add_recording_arguments

    sub = parser.add_subparsers(dest="source", metavar="SOURCE", required=True)
    ros = sub.add_parser(
        "ros",
        help="a ROS 1 .bag, a ROS 2 bag directory (or its .db3) or a ROS 2 .mcap, through a "
        "topic mapping (docs/ros.md)",
    )
    ros.add_argument("bag", metavar="BAG", help="the ROS bag")
    ros.add_argument(
        "-o", "--output", required=True, metavar="OUT.mcap", help="the lfd recording to write"
    )
    add_recording_arguments(ros)
    for action in ros._actions:  # --map is what this command is about: required
        if action.dest == "map":
            action.required = True


def run(args: argparse.Namespace) -> int:
    from rich.console import Console

    from ..io import load, save
    from ..outputs import check_output
    from ._options import load_options, read_files

    # every file of the bag counts: nothing is written into a bag directory being read
    reads = read_files(args, args.bag)
    check_output(args.output, inputs=reads, what="-o/--output", suffixes=(".mcap",))
    options = load_options(args)
    demo = load(args.bag, images=False, **options)
    save(demo, args.output)
    Console().print(
        f"wrote {args.output}: {len(demo.hand)} hand frames, "
        + ", ".join(
            f"{o.name} ({len(o)} poses, {' x '.join(f'{v:g}' for v in o.size)} m)"
            for o in demo.objects.values()
        )
        + f", {demo.duration_s:.2f} s"
    )
    return 0
