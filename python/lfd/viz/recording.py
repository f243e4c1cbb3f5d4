"""The Rerun SDK, imported lazily with telemetry off, and the recording a view logs to.

The lowest module of :mod:`lfd.viz`: every other one imports ``rerun`` through
:func:`import_rerun`, so importing ``lfd.viz`` stays cheap and works without ``rerun-sdk``.
"""

from __future__ import annotations

import os
from types import ModuleType
from typing import TYPE_CHECKING, Any

from ..errors import LfdError

if TYPE_CHECKING:
    import rerun as rr


def import_rerun() -> ModuleType:
    """Import ``rerun`` with telemetry off unless the user chose otherwise.

    Sets ``RERUN_TELEMETRY=0`` in the environment before the first import (a value the user
    set is kept), so the SDK and any viewer it spawns send nothing.

    Raises
    ------
    LfdError
        If the ``rerun-sdk`` package is not installed.
    """
    os.environ.setdefault("RERUN_TELEMETRY", "0")
    try:
        import rerun
    except ImportError as err:  # pragma: no cover - rerun-sdk is in the dev and viz extras
        from .._extras import install_hint
        from ..errors import MissingExtraError

        raise MissingExtraError(
            f"Rerun views need the rerun-sdk package: {install_hint('viz')}", extra="viz"
        ) from err
    return rerun


def get_recording(recording: Any = None) -> rr.RecordingStream:
    """The recording to log to: ``recording`` or the current default one.

    Raises
    ------
    LfdError
        If none is given and no default recording exists.
    """
    rr = import_rerun()
    if recording is not None:
        return recording  # type: ignore[no-any-return]
    rec = rr.get_data_recording()
    if rec is None:
        raise LfdError(
            "no Rerun recording to log to: call lfd.viz.init(...) or rerun.init(...) first, "
            "or pass recording="
        )
    return rec  # type: ignore[no-any-return]
