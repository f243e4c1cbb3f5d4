"""The ``--rerun*`` options shared by the commands that show their work in Rerun.

A command calls :func:`add_rerun_arguments` in ``add_arguments`` and, in ``run``::

    check_rerun_args(args, inputs)             # refuse bad values before any work
    if open_from_args(args, "lfd_segment"):    # opens the viewer/file/server, or does nothing
        lfd.viz.log_demonstration(demo)          # log as results are produced
    ...
    close_from_args(args)                        # flush; keep serving (Ctrl+C, --rerun-serve-for)

The session itself is :func:`lfd.viz.session.open_session` (plain values, no argparse);
:func:`lfd.cli.main` calls :func:`abort_from_args` when a command fails, so a failed run
leaves no ``--rerun-save`` file.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Iterable
from typing import Any

from ..viz.session import (
    DEFAULT_BIND,
    DEFAULT_GRPC_PORT,
    DEFAULT_WEB_PORT,
    Session,
    check_bind_address,
    check_viewer_url,
    open_session,
)
from ._types import seconds_or_forever

_SESSION_ATTR = "rerun_session"


def add_rerun_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``--rerun``, ``--rerun-save``, ``--rerun-connect``, ``--rerun-serve``,
    ``--rerun-bind`` and ``--rerun-serve-for`` to a parser."""
    group = parser.add_argument_group("Rerun visualisation")
    group.add_argument(
        "--rerun",
        action="store_true",
        help="stream to the native Rerun viewer (spawned; without a display the web viewer is "
        "served instead)",
    )
    group.add_argument(
        "--rerun-save",
        metavar="FILE.rrd",
        help="save the Rerun recording to a .rrd file (written when the command succeeds)",
    )
    group.add_argument(
        "--rerun-connect",
        metavar="URL",
        help="stream to a running viewer, e.g. rerun+http://127.0.0.1:9876/proxy",
    )
    group.add_argument(
        "--rerun-serve",
        action="store_true",
        help=f"serve the web viewer on http://{DEFAULT_BIND}:{DEFAULT_WEB_PORT} (gRPC on "
        f"{DEFAULT_GRPC_PORT}) and print its address",
    )
    group.add_argument(
        "--rerun-bind",
        metavar="ADDR",
        default=DEFAULT_BIND,
        help=f"address the served web viewer listens on ({DEFAULT_BIND}: this machine only; "
        "0.0.0.0: every network interface, anyone on the network can watch)",
    )
    group.add_argument(
        "--rerun-serve-for",
        metavar="SECONDS",
        type=seconds_or_forever,
        help="serve the web viewer (implies --rerun-serve) and keep serving this long after "
        "the command is done, also without a terminal; inf: until Ctrl+C or SIGTERM",
    )


def check_rerun_args(
    args: argparse.Namespace, inputs: Iterable[str | os.PathLike[str]] = ()
) -> None:
    """Refuse unusable ``--rerun-save`` / ``--rerun-connect`` values before any work.

    Raises
    ------
    UsageError
        ``--rerun-save`` is an input, not a ``.rrd`` file, or not writable; ``--rerun-connect``
        is not a viewer URL (:func:`lfd.viz.session.check_viewer_url`); ``--rerun-bind`` is
        not an IP address.
    """
    from ..outputs import check_output
    from ._options import read_files

    save = getattr(args, "rerun_save", None)
    if save is not None:
        reads = read_files(args, *inputs)
        check_output(save, inputs=reads, what="--rerun-save", suffixes=(".rrd",))
    url = getattr(args, "rerun_connect", None)
    if url is not None:
        check_viewer_url(url, what="--rerun-connect")
    check_bind_address(getattr(args, "rerun_bind", DEFAULT_BIND), what="--rerun-bind")


def wants_rerun(args: argparse.Namespace) -> bool:
    """Whether any ``--rerun*`` option was given."""
    return bool(
        getattr(args, "rerun", False)
        or getattr(args, "rerun_save", None)
        or getattr(args, "rerun_connect", None)
        or _serving(args)
    )


def _serving(args: argparse.Namespace) -> bool:
    return bool(
        getattr(args, "rerun_serve", False) or getattr(args, "rerun_serve_for", None) is not None
    )


def open_from_args(args: argparse.Namespace, app_id: str, **kwargs: Any) -> bool:
    """Open the Rerun session the options ask for; False (and nothing opened) without them.

    The recording becomes the global default, so ``lfd.viz.log_*(...)`` log to it. What was
    opened (file, viewer, web address) is printed to stderr. Extra keyword arguments go to
    :func:`lfd.viz.session.open_session` (e.g. ``blueprint=``).
    """
    if not wants_rerun(args):
        setattr(args, _SESSION_ATTR, None)
        return False
    session = open_session(
        app_id,
        spawn=bool(getattr(args, "rerun", False)),
        save=getattr(args, "rerun_save", None),
        connect=getattr(args, "rerun_connect", None),
        serve=_serving(args),
        bind=getattr(args, "rerun_bind", DEFAULT_BIND),
        atomic_save=True,
        **kwargs,
    )
    for message in session.messages:
        print(f"rerun: {message}", file=sys.stderr)
    setattr(args, _SESSION_ATTR, session)
    return True


def session_from_args(args: argparse.Namespace) -> Session | None:
    """The session :func:`open_from_args` opened, if any."""
    return getattr(args, _SESSION_ATTR, None)


def close_from_args(args: argparse.Namespace, *, wait_serving: bool | None = None) -> None:
    """Flush and close the session opened from ``args`` (no-op without one)."""
    session = session_from_args(args)
    if session is not None:
        setattr(args, _SESSION_ATTR, None)
        serve_for = getattr(args, "rerun_serve_for", None)
        session.close(wait_serving=wait_serving, serve_for=serve_for)


def abort_from_args(args: argparse.Namespace) -> None:
    """Drop the session of a failed command: its ``--rerun-save`` file is not written."""
    session = session_from_args(args)
    if session is not None:
        session.abort()
        setattr(args, _SESSION_ATTR, None)
