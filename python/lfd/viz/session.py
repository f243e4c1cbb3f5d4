"""Rerun sessions: open a recording with its sinks (rerun itself: :mod:`lfd.viz.recording`).

A :class:`Session` is one Rerun recording stream with any combination of sinks: the native
viewer (spawned, or the fallback when there is no display), an ``.rrd`` file, a remote viewer
(gRPC URL) and a local gRPC server with the bundled web viewer. Everything logged is streamed to
all sinks as it is produced.
"""

from __future__ import annotations

import os
import sys
import time
import urllib.parse
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..errors import LfdError, UsageError
from ..outputs import PendingOutput
from .blueprint import default_blueprint
from .recording import import_rerun

if TYPE_CHECKING:
    import rerun as rr

DEFAULT_GRPC_PORT = 9876
"""Port of the gRPC server that ``--rerun-serve`` hosts (the web viewer connects to it)."""
DEFAULT_WEB_PORT = 9090
"""Port of the HTTP server of the bundled web viewer."""
SPAWN_PORT = 9876
"""Port the spawned native viewer listens on."""


CONNECT_SCHEMES = ("rerun", "rerun+http", "rerun+https")
"""URL schemes of a viewer to stream to: those the Rerun SDK's ``GrpcSink`` accepts (its URLs
end in ``/proxy``)."""


def check_viewer_url(url: str, *, what: str = "connect") -> None:
    """Refuse a viewer URL :func:`open_session` cannot stream to, before any work.

    ``what`` names the value in the message (the ``lfd`` commands pass ``--rerun-connect``).

    Raises
    ------
    UsageError
        ``url`` is not a ``rerun+http://HOST:PORT/proxy`` URL (``rerun://``, ``rerun+https://``
        too), or its port is not a number in range.
    """
    parts = urllib.parse.urlsplit(url)
    bad_path = parts.path.rstrip("/") != "/proxy"
    if parts.scheme not in CONNECT_SCHEMES or not parts.hostname or bad_path:
        raise UsageError(
            f"{what} {url!r} is not a viewer URL; give e.g. "
            f"rerun+http://127.0.0.1:{DEFAULT_GRPC_PORT}/proxy "
            f"(schemes: {', '.join(s + '://' for s in CONNECT_SCHEMES)})"
        )
    try:
        parts.port  # noqa: B018 - raises ValueError on a bad port
    except ValueError as err:
        raise UsageError(f"{what} {url!r}: {err}") from err


def has_display() -> bool:
    """Whether a native viewer window can open here (macOS/Windows, or X11/Wayland set)."""
    if sys.platform in ("darwin", "win32"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def _port_open(port: int, host: str = "127.0.0.1") -> bool:
    """Whether something accepts TCP connections on ``host:port``."""
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.settimeout(1.0)
        return sock.connect_ex((host, port)) == 0


def web_viewer_url(grpc_url: str, web_port: int = DEFAULT_WEB_PORT) -> str:
    """The address of the bundled web viewer connected to a gRPC server URL."""
    return f"http://localhost:{web_port}/?url={urllib.parse.quote(grpc_url, safe='')}"


@dataclass
class Session:
    """An open Rerun recording and where it goes.

    Attributes
    ----------
    recording : rerun.RecordingStream
        The stream every ``lfd.viz.log_*`` function logs to (also made the global default).
    save_path : Path or None
        The ``.rrd`` file being written.
    connect_url : str or None
        The gRPC URL of a viewer the data is streamed to (spawned or given).
    serve_url : str or None
        The web viewer address when serving.
    messages : list of str
        What was opened, for printing to the user.
    """

    recording: rr.RecordingStream
    save_path: Path | None = None
    connect_url: str | None = None
    serve_url: str | None = None
    messages: list[str] = field(default_factory=list)
    pending_save: PendingOutput | None = None
    """With ``atomic_save``: the temporary file beside :attr:`save_path` written until close."""

    def flush(self) -> None:
        """Send everything logged so far to every sink."""
        self.recording.flush()

    def close(self, *, wait_serving: bool | None = None) -> None:
        """Flush and close the sinks.

        Parameters
        ----------
        wait_serving : bool, optional
            When serving the web viewer, keep the process (and with it the server) alive until
            Ctrl+C. Defaults to waiting only when stdin is a terminal.
        """
        try:
            self.recording.flush(timeout_sec=30.0)
        except RuntimeError as err:  # e.g. the viewer was closed or never started
            print(f"rerun: could not deliver all data: {err}", file=sys.stderr)
        if self.serve_url is not None:
            if wait_serving is None:
                wait_serving = sys.stdin is not None and sys.stdin.isatty()
            if wait_serving:
                print(f"Rerun web viewer: {self.serve_url}  (Ctrl+C to stop serving)")
                try:
                    while True:
                        time.sleep(1.0)
                except KeyboardInterrupt:
                    pass
            else:
                print(
                    "rerun: stdin is not a terminal, so the web viewer stops with this process; "
                    "use --rerun-save FILE.rrd to keep the data",
                    file=sys.stderr,
                )
        self._disconnect()
        if self.pending_save is not None:
            self.pending_save.commit()

    def abort(self) -> None:
        """Stop streaming without keeping the ``.rrd`` file (when it was opened atomically)."""
        self._disconnect()
        if self.pending_save is not None:
            self.pending_save.discard()

    def _disconnect(self) -> None:
        self.recording.disconnect()
        rr = import_rerun()
        current = rr.get_global_data_recording()
        if current is not None and current.get_recording_id() == self.recording.get_recording_id():
            rr.set_global_data_recording(None)


def open_session(
    app_id: str,
    *,
    spawn: bool = False,
    save: str | os.PathLike[str] | None = None,
    connect: str | None = None,
    serve: bool = False,
    grpc_port: int = DEFAULT_GRPC_PORT,
    web_port: int = DEFAULT_WEB_PORT,
    recording_id: str | None = None,
    blueprint: Any = None,
    make_default: bool = True,
    atomic_save: bool = False,
) -> Session:
    """Open a Rerun recording with the requested sinks and send the default blueprint.

    Parameters
    ----------
    app_id : str
        Application id (e.g. ``"lfd_segment"``); the viewer keys blueprints by it.
    spawn : bool
        Spawn the native viewer and stream to it. Without a display this falls back to
        ``serve=True`` and says so in :attr:`Session.messages`.
    save : path, optional
        Also write everything to this ``.rrd`` file.
    connect : str, optional
        Stream to a running viewer, e.g. ``rerun+http://127.0.0.1:9876/proxy``.
    serve : bool
        Host a gRPC server on ``grpc_port`` and the bundled web viewer on ``web_port``.
    recording_id : str, optional
        Recording id (random by default).
    blueprint : rerun.blueprint.Blueprint, optional
        The default blueprint; :func:`lfd.viz.blueprint.default_blueprint` when omitted.
    make_default : bool
        Make the recording the global default, so ``recording=None`` logs to it.
    atomic_save : bool
        Write ``save`` to a temporary file beside it, renamed onto it by :meth:`Session.close`
        (and removed by :meth:`Session.abort`): a failed run leaves no ``.rrd``, and two runs
        saving to the same file cannot interleave. The ``lfd`` commands use it.

    Returns
    -------
    Session
    """
    rr = import_rerun()

    messages: list[str] = []
    if spawn and not has_display():
        messages.append(
            "no display found (DISPLAY/WAYLAND_DISPLAY unset): serving the web viewer instead "
            "of spawning the native one"
        )
        spawn, serve = False, True
    rec = rr.RecordingStream(app_id, recording_id=recording_id)
    sinks: list[Any] = []
    connect_url = connect
    if spawn:
        rr.spawn(port=SPAWN_PORT, connect=False, recording=rec)
        if _port_open(SPAWN_PORT):
            connect_url = f"rerun+http://127.0.0.1:{SPAWN_PORT}/proxy"
            messages.append(f"spawned the Rerun viewer ({connect_url})")
        else:
            messages.append(
                "the native Rerun viewer did not start (see its error above): serving the web "
                "viewer instead"
            )
            serve = True
    if connect_url is not None:
        sinks.append(rr.GrpcSink(connect_url))
        if connect is not None:
            messages.append(f"streaming to {connect_url}")
    save_path = None
    pending = None
    if save is not None:
        save_path = Path(save)
        save_path.parent.mkdir(parents=True, exist_ok=True)
        pending = PendingOutput(save_path) if atomic_save else None
        sinks.append(rr.FileSink(str(save_path if pending is None else pending.path)))
        if not atomic_save:  # the lfd commands stay quiet about it (stderr is for problems)
            messages.append(f"saving to {save_path}")
    serve_url = None
    if serve:
        if connect_url is not None and grpc_port == SPAWN_PORT:
            grpc_port = SPAWN_PORT + 1  # the spawned viewer holds the default port
        for port in (grpc_port, web_port):
            if _port_open(port):
                if pending is not None:
                    pending.discard()
                raise LfdError(
                    f"cannot serve the Rerun web viewer: port {port} is in use (a viewer "
                    f"already running? stream to it with --rerun-connect "
                    f"rerun+http://127.0.0.1:{grpc_port}/proxy)"
                )
        server = rr.GrpcServerSink("127.0.0.1", grpc_port)
        sinks.append(server)
    if sinks:
        rec.set_sinks(
            *sinks, default_blueprint=default_blueprint() if blueprint is None else blueprint
        )
    if serve:
        grpc_url = server.uri
        rr.serve_web_viewer(web_port=web_port, open_browser=False, connect_to=grpc_url)
        serve_url = web_viewer_url(grpc_url, web_port)
        messages.append(f"Rerun web viewer: {serve_url}")
    if make_default:
        rr.set_global_data_recording(rec)
    return Session(
        recording=rec,
        save_path=save_path,
        connect_url=connect_url,
        serve_url=serve_url,
        messages=messages,
        pending_save=pending,
    )


def init(
    app_id: str = "lfd",
    *,
    spawn: bool = False,
    save: str | os.PathLike[str] | None = None,
    connect: str | None = None,
    serve: bool = False,
) -> Session:
    """Open a session for interactive use (notebooks, scripts) and print where it goes.

    Same parameters as :func:`open_session`; the recording becomes the global default, so the
    ``lfd.viz.log_*`` functions can be called without ``recording=``.
    """
    session = open_session(app_id, spawn=spawn, save=save, connect=connect, serve=serve)
    for message in session.messages:
        print(message)
    return session
