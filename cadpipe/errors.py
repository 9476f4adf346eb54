"""Exception types. Every error a user can cause is a :class:`CadpipeError`.

An error carries what it is about as fields, not only as text: ``key`` (the
argument or spec key path, ``"radius"`` or ``"parts[0].radius"``), ``part`` (an
assembly part's name), ``file`` (the file read or written) and ``index`` (a row,
point or face number). Layers that know more add it with :meth:`CadpipeError.at`
as the error passes through (the spec loader prefixes the table's key path, the
CLI the file) instead of parsing the message. ``str(error)`` reads
``file: key: message``, so the one line the CLI prints says where and what.

Advice that names a setting is given as ``fix={"strict": False}``, not written into
the message, so it reads in the caller's terms: ``pass strict=False`` from Python,
``set parts[0].strict = false`` once the spec loader has located the error.
Control characters in names and values are escaped in ``str(error)``, so an
error is always one line; :func:`shown` keeps echoed values short.

Input errors also subclass :class:`ValueError`, so code that already catches
``ValueError`` keeps working.
"""

from __future__ import annotations

import json
import os
import re

_CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f\u2028\u2029]")


def one_line(text: str) -> str:
    """``text`` with control characters (newlines, NUL, ...) written as escapes: one line,
    safe to print."""
    return _CONTROL.sub(lambda m: m.group().encode("unicode_escape").decode("ascii"), text)


def shown(value, limit: int = 60) -> str:
    """``repr(value)`` cut to about ``limit`` characters, safe for any value.

    Huge integers (a 5,000-digit spec number) and long lists are not echoed whole.
    """
    if isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > 200:
        return f"an integer of about {int(value.bit_length() * 0.30103) + 1} digits"
    try:
        text = repr(value)
    except Exception:                    # noqa: BLE001 (a repr that fails is still shown)
        text = f"<{type(value).__name__}>"
    return text if len(text) <= limit else text[:limit - 4] + " ..."


def _spec_value(value) -> str:
    """``value`` written as TOML/JSON, the way a spec user types it."""
    try:
        return json.dumps(value)
    except (TypeError, ValueError):
        return shown(value)


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
                 file: str | os.PathLike | None = None, index: int | None = None,
                 fix: dict | None = None):
        super().__init__(message)
        self.message = message
        self.key = key
        self.part = part
        self.file = None if file is None else os.fspath(file)
        self.index = index
        self.fix = dict(fix or {})
        self.in_spec = False        # set by the spec loader: advice names spec keys
        self._part_located = False  # the key path already says which part

    def at(self, key: str | None = None, *, part: str | None = None,
           file: str | os.PathLike | None = None, index: int | None = None,
           spec: bool = False) -> CadpipeError:
        """Add where the error happened, seen from an enclosing layer; returns ``self``.

        ``key`` is prefixed to the key already held (``"parts[0]"`` + ``"radius"``
        gives ``"parts[0].radius"``), and to the keys of ``fix``; ``part``, ``file``
        and ``index`` are kept when already set by a layer closer to the cause.
        ``spec=True`` says the keys are spec keys (advice then reads as a spec edit);
        a ``key`` given with ``part`` is where that part is, so the part's name is
        not repeated in ``str()``.
        """
        if key:
            self.key = _join(key, self.key)
            self.fix = {_join(key, k): v for k, v in self.fix.items()}
            if part is not None:
                self._part_located = True
        self.part = self.part if self.part is not None else part
        if self.file is None and file is not None:
            self.file = os.fspath(file)
        self.index = self.index if self.index is not None else index
        self.in_spec = self.in_spec or spec
        return self

    def advice(self) -> str:
        """The ``fix`` settings in the caller's terms ("" without any)."""
        if not self.fix:
            return ""
        if self.in_spec:
            return "set " + " and ".join(f"{k} = {_spec_value(v)}" for k, v in self.fix.items())
        return "pass " + ", ".join(f"{k.rpartition('.')[2]}={v!r}" for k, v in self.fix.items())

    def __str__(self) -> str:
        part = None if self._part_located or self.part is None else self.part
        where = [w for w in (self.file, part, self.key) if w]
        message = "; ".join(m for m in (self.message, self.advice()) if m)
        return one_line(": ".join([*where, message]))

    def __reduce__(self):
        """Pickle with the fields (errors travel back from worker processes)."""
        return (_rebuild, (type(self), self.message, self.key, self.part, self.file, self.index,
                           self.fix, self.in_spec, self._part_located))


def _join(outer: str, inner: str | None) -> str:
    if not inner:
        return outer
    return outer + inner if inner.startswith("[") else f"{outer}.{inner}"


def _rebuild(cls, message, key, part, file, index, fix=None, in_spec=False, located=False):
    error = cls(message, key=key, part=part, file=file, index=index, fix=fix)
    error.in_spec, error._part_located = in_spec, located
    return error


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
