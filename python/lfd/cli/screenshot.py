"""``python -m lfd.cli.screenshot IN.rrd OUT.png``: a still of a saved recording (docs, tests).

A developer tool beside the ``lfd`` commands (not one of them): the argparse front of
:func:`lfd.viz.screenshot.screenshot`.
"""

from __future__ import annotations

import argparse


def main(argv: list[str] | None = None) -> int:
    """``python -m lfd.cli.screenshot IN.rrd OUT.png [--time S] [--width PX] [--view NAME]``."""
    parser = argparse.ArgumentParser(prog="python -m lfd.cli.screenshot", description=main.__doc__)
    parser.add_argument("rrd")
    parser.add_argument("png")
    parser.add_argument("--time", type=float, help="pause demo_time at this many seconds")
    parser.add_argument("--width", type=int, help="downscale to at most this width (pixels)")
    parser.add_argument("--view", help="capture only the view with this name")
    parser.add_argument("--settle", type=float, default=6.0, help="seconds to wait (6)")
    args = parser.parse_args(argv)
    from ..viz.screenshot import screenshot

    out = screenshot(
        args.rrd,
        args.png,
        settle_s=args.settle,
        max_width=args.width,
        time_s=args.time,
        view=args.view,
    )
    print(out)
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
