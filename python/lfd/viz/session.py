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
DEFAULT_BIND = "127.0.0.1"
"""Address the served web viewer and its gRPC server listen on: this machine only. ``0.0.0.0``
(or ``::``) shows the demonstration to anyone on the network."""
SERVER_START_S = 20.0
"""How long the web viewer's server may take to start listening."""


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


def web_viewer_url(grpc_url: str, web_port: int = DEFAULT_WEB_PORT, host: str = "localhost") -> str:
    """The address of the bundled web viewer connected to a gRPC server URL."""
    return f"http://{host}:{web_port}/?url={urllib.parse.quote(grpc_url, safe='')}"


def check_bind_address(bind: str, *, what: str = "bind") -> str:
    """``bind`` if it is an IP address to listen on (``127.0.0.1``, ``0.0.0.0``, ``::``).

    Raises
    ------
    UsageError
        ``bind`` is not an IPv4 or IPv6 address.
    """
    import ipaddress

    try:
        ipaddress.ip_address(bind)
    except ValueError:
        raise UsageError(
            f"{what} {bind!r} is not an IP address; give e.g. 127.0.0.1 (this machine only, "
            "the default) or 0.0.0.0 (every network interface)"
        ) from None
    return bind


def _url_host(bind: str) -> str:
    """The host a browser on this machine uses for a server bound to ``bind``."""
    import ipaddress

    ip = ipaddress.ip_address(bind)
    if ip.is_unspecified:
        return "localhost"
    return f"[{bind}]" if ip.version == 6 else bind


def ipaddress_unspecified(bind: str) -> bool:
    """Whether ``bind`` listens on every interface (``0.0.0.0``, ``::``)."""
    import ipaddress

    return ipaddress.ip_address(bind).is_unspecified


def _start_server(bind: str, grpc_port: int, web_port: int) -> Any:
    """Start the Rerun web viewer + gRPC server (the ``rerun`` CLI) listening on ``bind``.

    The SDK's own ``serve_web_viewer`` always listens on every interface (0.0.0.0) and cannot
    be told otherwise; the ``rerun`` executable shipped with the SDK can (``--bind``).

    Raises
    ------
    LfdError
        The server exited or did not listen within :data:`SERVER_START_S`.
    """
    import subprocess
    import tempfile

    probe = "127.0.0.1" if _url_host(bind) == "localhost" else bind
    log = tempfile.TemporaryFile(mode="w+")
    cmd = [_rerun_executable(), "--serve-web", "--bind", bind,
           "--port", str(grpc_port), "--web-viewer-port", str(web_port)]  # fmt: skip
    env = dict(os.environ)
    env.setdefault("RERUN_TELEMETRY", "0")
    proc = subprocess.Popen(
        cmd,
        stdin=subprocess.DEVNULL,
        stdout=log,
        stderr=log,
        env=env,
        preexec_fn=_die_with_parent if sys.platform == "linux" else None,
    )
    deadline = time.monotonic() + SERVER_START_S
    while not (_port_open(grpc_port, probe) and _port_open(web_port, probe)):
        if proc.poll() is not None or time.monotonic() > deadline:
            _stop_server(proc)
            log.seek(0)
            tail = " ".join(log.read().split()[-30:])
            raise LfdError(
                f"cannot serve the Rerun web viewer on {bind} (ports {grpc_port}, {web_port}): "
                f"the server did not start ({tail or 'no output'})"
            )
        time.sleep(0.1)
    log.close()
    return proc


def _die_with_parent() -> None:
    """In the server process (Linux): get SIGTERM when lfd dies, even killed with SIGKILL."""
    import ctypes
    import signal

    ctypes.CDLL(None).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG


def _rerun_executable() -> str:
    """The ``rerun`` executable shipped with the SDK (package ``rerun_cli``), run directly so
    that stopping it stops the server (``python -m rerun_cli`` would leave it running).

    Raises
    ------
    LfdError
        Not found.
    """
    import importlib.util
    import shutil

    override = os.environ.get("RERUN_CLI_PATH")
    if override:
        return override
    spec = importlib.util.find_spec("rerun_cli")
    for folder in (spec.submodule_search_locations or []) if spec else []:
        exe = Path(folder) / ("rerun.exe" if sys.platform == "win32" else "rerun")
        if exe.is_file():
            return str(exe)
    found = shutil.which("rerun")
    if found:
        return found
    raise LfdError("cannot serve the Rerun web viewer: the rerun executable (rerun-sdk) is missing")


def _stop_server(proc: Any) -> None:
    """Stop the server process started by :func:`_start_server`."""
    import subprocess

    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(timeout=5.0)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


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
    server: Any = None
    """When serving: the process of the web viewer and its gRPC server (stopped by close)."""
    bind: str | None = None
    """When serving: the address the web viewer listens on."""

    def flush(self) -> None:
        """Send everything logged so far to every sink."""
        self.recording.flush()

    def close(self, *, wait_serving: bool | None = None, serve_for: float | None = None) -> None:
        """Flush and close the sinks.

        Parameters
        ----------
        wait_serving : bool, optional
            When serving the web viewer, keep the process (and with it the server) alive until
            Ctrl+C or SIGTERM. Defaults to waiting only when stdin is a terminal.
        serve_for : float, optional
            When serving, keep serving this many seconds (Ctrl+C or SIGTERM stop it sooner);
            ``math.inf`` serves until Ctrl+C or SIGTERM, with or without a terminal. Overrides
            ``wait_serving``.
        """
        try:
            self.recording.flush(timeout_sec=30.0)
        except RuntimeError as err:  # e.g. the viewer was closed or never started
            print(f"rerun: could not deliver all data: {err}", file=sys.stderr)
        try:
            if self.serve_url is not None:
                self._keep_serving(wait_serving, serve_for)
        finally:
            self._disconnect()
        if self.pending_save is not None:
            self.pending_save.commit()

    def _keep_serving(self, wait_serving: bool | None, serve_for: float | None) -> None:
        import math
        import signal
        import threading

        if serve_for is None:
            if wait_serving is None:
                wait_serving = sys.stdin is not None and sys.stdin.isatty()
            if not wait_serving:
                print(
                    "rerun: stdin is not a terminal, so the web viewer stops with this process; "
                    "keep it with --rerun-serve-for SECONDS (inf: until Ctrl+C or SIGTERM), or "
                    "save the data with --rerun-save FILE.rrd",
                    file=sys.stderr,
                )
                return
            serve_for = math.inf
        until = "Ctrl+C" if math.isinf(serve_for) else f"{serve_for:g} s, or Ctrl+C"
        print(f"Rerun web viewer: {self.serve_url}  (serving until {until})", flush=True)
        stop = threading.Event()
        old = None
        if threading.current_thread() is threading.main_thread():

            def on_term(signum: int, frame: Any) -> None:
                stop.set()

            old = signal.signal(signal.SIGTERM, on_term)
        try:
            end = time.monotonic() + serve_for
            # wake twice a second: a Ctrl+C the kernel hands to another thread (the viewer's)
            # is only acted on once the main thread runs Python again
            while not stop.wait(min(0.5, max(0.0, end - time.monotonic()))):
                if time.monotonic() >= end:
                    break
        except KeyboardInterrupt:
            pass
        finally:
            if old is not None:
                signal.signal(signal.SIGTERM, old)

    def abort(self) -> None:
        """Stop streaming without keeping the ``.rrd`` file (when it was opened atomically)."""
        self._disconnect()
        if self.pending_save is not None:
            self.pending_save.discard()

    def _disconnect(self) -> None:
        self.recording.disconnect()
        if self.server is not None:
            _stop_server(self.server)
            self.server = None
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
    bind: str = DEFAULT_BIND,
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
        Host a gRPC server on ``grpc_port`` and the bundled web viewer on ``web_port``, both
        listening on ``bind`` (a separate ``rerun`` process, stopped by :meth:`Session.close`).
    bind : str
        The address to serve on: :data:`DEFAULT_BIND` (this machine only), ``0.0.0.0`` for
        every network interface.
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
        spawned = _spawn(rr, rec, messages)
        connect_url, serve = spawned or connect_url, serve or spawned is None
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
    server = None
    if serve:
        check_bind_address(bind)
        if connect_url is not None and grpc_port == SPAWN_PORT:
            grpc_port = SPAWN_PORT + 1  # the spawned viewer holds the default port
        try:
            server, grpc_url, serve_url = _serve(bind, grpc_port, web_port, messages)
        except LfdError:
            if pending is not None:
                pending.discard()
            raise
        sinks.append(rr.GrpcSink(grpc_url))
    if sinks:
        rec.set_sinks(
            *sinks, default_blueprint=default_blueprint() if blueprint is None else blueprint
        )
    if make_default:
        rr.set_global_data_recording(rec)
    return Session(
        recording=rec,
        save_path=save_path,
        connect_url=connect_url,
        serve_url=serve_url,
        messages=messages,
        pending_save=pending,
        server=server,
        bind=bind if serve else None,
    )


def _spawn(rr: Any, rec: Any, messages: list[str]) -> str | None:
    """Spawn the native viewer for ``rec``: the URL to stream to it, or None (said in
    ``messages``) if it did not start, when the web viewer is served instead."""
    rr.spawn(port=SPAWN_PORT, connect=False, recording=rec)
    if _port_open(SPAWN_PORT):
        url = f"rerun+http://127.0.0.1:{SPAWN_PORT}/proxy"
        messages.append(f"spawned the Rerun viewer ({url})")
        return url
    messages.append(
        "the native Rerun viewer did not start (see its error above): serving the web "
        "viewer instead"
    )
    return None


def _serve(bind: str, grpc_port: int, web_port: int, messages: list[str]) -> tuple[Any, str, str]:
    """Start the gRPC server and the web viewer on ``bind`` (an :class:`LfdError` if a port is
    in use; ``bind`` is checked): the server, the gRPC URL to stream to and the web viewer's
    URL."""
    probe = "127.0.0.1" if _url_host(bind) == "localhost" else bind
    for port in (grpc_port, web_port):
        if _port_open(port, probe):
            raise LfdError(
                f"cannot serve the Rerun web viewer: port {port} is in use (a viewer "
                f"already running? stream to it with --rerun-connect "
                f"rerun+http://127.0.0.1:{grpc_port}/proxy)"
            )
    server = _start_server(bind, grpc_port, web_port)
    host = _url_host(bind)
    grpc_url = f"rerun+http://{host}:{grpc_port}/proxy"
    serve_url = web_viewer_url(grpc_url, web_port, host)
    messages.append(f"Rerun web viewer: {serve_url}")
    if ipaddress_unspecified(bind):
        messages.append(
            f"the web viewer listens on every network interface ({bind}): anyone who can "
            "reach this machine can watch"
        )
    return server, grpc_url, serve_url


def init(
    app_id: str = "lfd",
    *,
    spawn: bool = False,
    save: str | os.PathLike[str] | None = None,
    connect: str | None = None,
    serve: bool = False,
    bind: str = DEFAULT_BIND,
) -> Session:
    """Open a session for interactive use (notebooks, scripts) and print where it goes.

    Same parameters as :func:`open_session`; the recording becomes the global default, so the
    ``lfd.viz.log_*`` functions can be called without ``recording=``.
    """
    session = open_session(app_id, spawn=spawn, save=save, connect=connect, serve=serve, bind=bind)
    for message in session.messages:
        print(message)
    return session
