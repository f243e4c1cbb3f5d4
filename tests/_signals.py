"""Start a child as a shell started from a terminal would, so a test's SIGINT is a user's Ctrl+C.

The test process may pass SIGINT on ignored (a CI runner starts jobs in the background, and a
non-interactive shell ignores SIGINT for those) or blocked (a library imported by another test
module can leave it so); a child inherits both, and Python keeps an ignored SIGINT ignored."""

from __future__ import annotations

import signal


def ctrl_c_as_from_a_terminal() -> None:
    """``preexec_fn`` for ``subprocess.Popen``: SIGINT unblocked and at its default, so the
    Python started next installs its KeyboardInterrupt handler."""
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    signal.signal(signal.SIGINT, signal.SIG_DFL)
