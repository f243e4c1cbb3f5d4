"""Exceptions raised by lfd. Catch :class:`LfdError` for everything, or a specific subclass.

The compiled engine (``lfd._hmmseg``) raises the :class:`EngineError` subclasses below. The
binding imports them once, when it is loaded (a missing class makes ``import lfd._hmmseg``
fail), and maps each engine error variant to one class; a Rust panic is an
:class:`InternalError`. Their names are part of the engine's contract.
"""

from __future__ import annotations


class LfdError(Exception):
    """Base class of every error lfd raises on purpose."""


# --- engine (crates/hmmseg) -----------------------------------------------------------------
class EngineError(LfdError):
    """An error reported by the Rust engine."""


class EmptySequenceError(EngineError, ValueError):
    """A sequence or a set of sequences had no samples."""


class ShapeMismatchError(EngineError, ValueError):
    """Array shapes or dimensions do not agree."""


class NonFiniteError(EngineError, ValueError):
    """NaN or infinity where finite numbers are required."""


class InvalidParameterError(EngineError, ValueError):
    """A parameter is outside its valid range."""


class NotStochasticError(EngineError, ValueError):
    """A probability vector/matrix has negative entries or does not sum to one."""


class NotPositiveDefiniteError(EngineError, ValueError):
    """A covariance matrix is not symmetric positive definite."""


class NotConvergedError(EngineError):
    """An iterative procedure did not converge or degenerated."""


class ModelFormatError(EngineError, ValueError):
    """A serialised model or template file cannot be read (bad JSON, version, unknown skill)."""


class InternalError(EngineError):
    """A bug in the engine (a Rust panic or an impossible state), not the caller's fault."""


# --- data and files -------------------------------------------------------------------------
class DemonstrationError(LfdError, ValueError):
    """A demonstration is inconsistent or lacks data a stage needs."""


class RecordingFormatError(LfdError, ValueError):
    """An MCAP file is not a readable lfd recording (missing channels, bad messages)."""


class UnknownSkillError(LfdError, ValueError):
    """A skill name is not one of :data:`lfd.skills.SKILLS`."""


class UsageError(LfdError, ValueError):
    """An argument or option value is invalid (out of range, inconsistent, unusable path)."""


class MissingExtraError(LfdError):
    """An optional extra a call needs is not installed; the message says how to install it."""

    def __init__(self, message: str, *, extra: str, module: str | None = None) -> None:
        super().__init__(message)
        self.extra = extra
        """The extra to install (``sim``, ``viz``, ``perception``, ``ros``, ``lerobot``, ``robots``,
        ``ray``)."""
        self.module = module
        """The module found missing."""


# --- warnings -------------------------------------------------------------------------------
class BatchError(LfdError):
    """A recording of a batch failed in another process (its error, as one line)."""


class LfdWarning(UserWarning):
    """Base class of the warnings lfd emits when it repairs or drops data."""


class RecoveredFileWarning(LfdWarning):
    """A recording was truncated or never closed; only its complete chunks were read."""


class TimestampWarning(LfdWarning):
    """Out-of-order samples were sorted or duplicate timestamps dropped while loading."""


class DefaultSizeWarning(LfdWarning):
    """An object's size was not given anywhere; a default cube was used (see
    :data:`lfd.io.sizes.DEFAULT_OBJECT_SIZE`)."""
