"""Errors that meshplan reports to its users.

Every error a user can cause (a bad file, a bad option, a scan that holds no building) is a
:class:`MeshplanError`. It carries a one-line description of the *problem* and a *hint* saying what
to do about it; the command line prints ``error: <problem>; <hint>`` and exits with status 2,
without a traceback. Anything else escaping the pipeline is a bug in meshplan.
"""

from __future__ import annotations


class MeshplanError(Exception):
    """A problem with the user's input or options, explained in one line.

    Parameters
    ----------
    problem
        What is wrong, e.g. ``"scan.obj: file not found"``.
    hint
        What to do about it, e.g. ``"check the path"``.
    """

    exit_code = 2

    def __init__(self, problem: str, hint: str = "") -> None:
        self.problem = " ".join(str(problem).split())
        self.hint = " ".join(str(hint).split())
        super().__init__(self.message)

    @property
    def message(self) -> str:
        """The one-line message shown to users."""
        return f"{self.problem}; {self.hint}" if self.hint else self.problem


class InputError(MeshplanError):
    """The input file cannot be read as a mesh, or holds no usable mesh."""


class AnnotationError(MeshplanError):
    """The annotations file is malformed."""


class ParameterError(MeshplanError, ValueError):
    """An option or parameter has an invalid value."""


class GeometryError(MeshplanError):
    """The mesh was read but does not look like a building interior (no floor, no walls, ...)."""


class OutputError(MeshplanError):
    """The output location cannot be written, or already exists."""
