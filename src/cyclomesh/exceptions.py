"""Exceptions raised by cyclomesh. Every one carries a one-line message for the user."""

__all__ = ["CyclomeshError", "DesignError", "ConvergenceError", "StudyError", "OutputError"]


class CyclomeshError(ValueError):
    """Base class: an input or a computation that cyclomesh refuses, with the reason."""


class DesignError(CyclomeshError):
    """The design, modification or errors describe a gear pair that cannot be analysed."""


class ConvergenceError(CyclomeshError):
    """A solver did not converge; the message says where (crank angle, pin) and why."""


class StudyError(CyclomeshError):
    """A study file, its values or a file it names is wrong."""


class OutputError(CyclomeshError):
    """A result file or folder cannot be written (disk full, locked folder) or read
    (incomplete folder)."""
