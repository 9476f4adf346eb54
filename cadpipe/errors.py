"""Exception types. Every error a user can cause is a :class:`CadpipeError`.

Input errors also subclass :class:`ValueError`, so code that already catches
``ValueError`` keeps working. Messages name the offending input and the fix.
"""


class CadpipeError(Exception):
    """Base class of every error cadpipe raises on purpose."""


class InputError(CadpipeError, ValueError):
    """An argument has the wrong shape, type or value."""


class GeometryError(CadpipeError, ValueError):
    """The input is well formed but describes an invalid solid (e.g. a self-intersecting tube)."""


class SpecError(CadpipeError, ValueError):
    """A spec file is malformed; the message names the file and the key path."""


class MeshError(CadpipeError, ValueError):
    """A mesh is not a closed, consistently oriented solid where one is needed."""


class ExportError(CadpipeError, OSError):
    """A file could not be read or written; nothing partial is left behind."""
