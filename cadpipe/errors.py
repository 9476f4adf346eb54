"""Exception types. Every error a user can cause is a :class:`CadpipeError`.

An error carries what it is about as fields, not only as text: ``key`` (the
argument or spec key path, ``"radius"`` or ``"parts[0].radius"``), ``part`` (an
assembly part's name), ``file`` (the file read or written) and ``index`` (a row,
point or face number). Layers that know more add it with :meth:`CadpipeError.at`
as the error passes through (the spec loader prefixes the table's key path, the
CLI the file) instead of parsing the message. ``str(error)`` reads
``file: key: message``, so the one line the CLI prints says where and what.

Input errors also subclass :class:`ValueError`, so code that already catches
``ValueError`` keeps working.
"""

from __future__ import annotations

import os


class CadpipeError(Exception):
    """Base class of every error cadpipe raises on purpose.

    Parameters
    ----------
    message : str
        What is wrong and what to change, in the caller's terms.
    key : str, optional
        The argument or spec key the error is about (a dotted path with ``[i]``).
    part, file, index : optional
        The assembly part, the file and the row/point/face number concerned.
    """

    def __init__(self, message: str, *, key: str | None = None, part: str | None = None,
                 file: str | os.PathLike | None = None, index: int | None = None):
        super().__init__(message)
        self.message = message
        self.key = key
        self.part = part
        self.file = None if file is None else os.fspath(file)
        self.index = index

    def at(self, key: str | None = None, *, part: str | None = None,
           file: str | os.PathLike | None = None, index: int | None = None) -> CadpipeError:
        """Add where the error happened, seen from an enclosing layer; returns ``self``.

        ``key`` is prefixed to the key already held (``"parts[0]"`` + ``"radius"``
        gives ``"parts[0].radius"``); ``part``, ``file`` and ``index`` are kept when
        already set by a layer closer to the cause.
        """
        if key:
            if not self.key:
                self.key = key
            elif self.key.startswith("["):
                self.key = key + self.key
            else:
                self.key = f"{key}.{self.key}"
        self.part = self.part if self.part is not None else part
        if self.file is None and file is not None:
            self.file = os.fspath(file)
        self.index = self.index if self.index is not None else index
        return self

    def __str__(self) -> str:
        where = [w for w in (self.file, self.key) if w]
        return ": ".join([*where, self.message])

    def __reduce__(self):
        """Pickle with the fields (errors travel back from worker processes)."""
        return (_rebuild, (type(self), self.message, self.key, self.part, self.file, self.index))


def _rebuild(cls, message, key, part, file, index):
    return cls(message, key=key, part=part, file=file, index=index)


class InputError(CadpipeError, ValueError):
    """An argument has the wrong shape, type or value."""


class GeometryError(CadpipeError, ValueError):
    """The input is well formed but describes an invalid solid (e.g. a self-intersecting tube)."""


class SpecError(CadpipeError, ValueError):
    """A spec file is malformed; ``file`` and ``key`` say where."""


class MeshError(CadpipeError, ValueError):
    """A mesh is not a closed, consistently oriented solid where one is needed."""


class ExportError(CadpipeError, OSError):
    """A file could not be read or written; nothing partial is left behind."""


class LimitError(CadpipeError, ValueError):
    """The work asked for exceeds a safety limit; the message names the limit and its override."""
