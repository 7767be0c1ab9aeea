"""Typed errors of cq-fairing.

Every error a user can cause derives from :class:`FairingError`, so callers
(the CLI, the FreeCAD workbench) can catch one class and show its one-line
message.  Errors caused by bad arguments also derive from :class:`ValueError`,
as scipy's do, so generic code that expects ``ValueError`` keeps working.

Messages follow one pattern: *what was expected, what arrived, what to do*.
"""

__all__ = [
    "FairingError",
    "InvalidInputError",
    "InvalidTargetError",
    "InvalidToleranceError",
    "ToleranceNotMetError",
    "UnsupportedGeometryError",
    "NumericalError",
    "FileFormatError",
    "OutputPathError",
    "InvalidOutputError",
]


class FairingError(Exception):
    """Base class of every error cq-fairing raises on purpose."""


class InvalidInputError(FairingError, ValueError):
    """An argument has the wrong shape, type or value (NaN, inf, too few poles...)."""


class InvalidTargetError(InvalidInputError):
    """The requested target size (scale ``n`` or pole count) is out of range."""


class InvalidToleranceError(InvalidInputError):
    """A tolerance is not a positive finite length."""


class ToleranceNotMetError(FairingError):
    """No admissible target size keeps the result within the tolerance.

    Attributes
    ----------
    tolerance : float
        The tolerance that was asked for.
    best_deviation : float
        The smallest deviation reached by any admissible target size.
    """

    def __init__(self, message, *, tolerance=None, best_deviation=None):
        super().__init__(message)
        self.tolerance = tolerance
        self.best_deviation = best_deviation


class UnsupportedGeometryError(FairingError):
    """The geometry is valid but of a kind this operation does not fair."""


class NumericalError(FairingError):
    """An internal consistency check failed (ill-conditioned or degenerate data)."""


class FileFormatError(FairingError):
    """A model file is missing, empty, corrupt, truncated or of an unknown format."""


class OutputPathError(FairingError):
    """An output path exists (without ``force``), is the input, or cannot be written."""


class InvalidOutputError(FairingError):
    """The model to write could not be turned into a file that reads back as itself (valid
    by ``BRepCheck``, the same number of faces); nothing was written."""
