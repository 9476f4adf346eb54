"""Argument checks shared by every stage, so errors read the same everywhere.

Each check raises :class:`~cadpipe.errors.InputError` with ``key`` set to the
argument's name; the message never repeats the name, so an enclosing layer (the
spec loader, an assembly) can prefix its own location with ``.at()``.
"""

import numpy as np

from cadpipe.errors import InputError, shown

#: largest coordinate or length magnitude accepted: far beyond any part (1e12 m is
#: seven times the Sun's distance), small enough that squares and sums of squares
#: stay finite in float64
MAX_MAGNITUDE = 1e12


def as_points(value, name, *, dim=3, min_count=1):
    """Return ``value`` as a float64 ``(N, dim)`` array of finite numbers.

    Raises :class:`InputError` with ``key=name`` (and ``index`` for a bad point).
    """
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        raise InputError(f"expected an (N, {dim}) array of numbers, got {shown(value)}",
                         key=name) from None
    if arr.ndim != 2 or arr.shape[1] != dim:
        raise InputError(f"expected shape (N, {dim}), got {arr.shape}", key=name)
    if len(arr) < min_count:
        raise InputError(f"expected at least {min_count} points, got {len(arr)}", key=name)
    bad = ~(np.abs(arr) <= MAX_MAGNITUDE).all(axis=1)
    if bad.any():
        i = int(np.argmax(bad))
        what = "is not finite (NaN or inf)" if not np.isfinite(arr[i]).all() else \
            f"is farther than {MAX_MAGNITUDE:g} from the origin"
        raise InputError(f"point {i} {what}; remove or fix it", key=name, index=i)
    return arr


def as_positive(value, name, count=None):
    """Return ``value`` as a float64 scalar or ``(count,)`` array of finite numbers > 0."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        raise InputError(f"expected a positive number, got {shown(value)}", key=name) from None
    if arr.ndim > 1 or (arr.ndim == 1 and len(arr) != count):
        raise InputError("expected a number" if count is None else
                         f"expected a number or {count} values (one per point), "
                         f"got shape {arr.shape}", key=name)
    if not np.isfinite(arr).all() or (arr <= 0).any():
        raise InputError(f"must be finite and > 0, got {shown(value)}", key=name)
    if (arr > MAX_MAGNITUDE).any():
        raise InputError(f"must be at most {MAX_MAGNITUDE:g}, got {shown(value)}", key=name)
    return arr


def as_int(value, name, *, low, high):
    """Return ``value`` as an int in ``[low, high]``."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise InputError(f"expected a whole number, got {shown(value)}", key=name)
    if not low <= value <= high:
        raise InputError(f"must be between {low} and {high}, got {shown(value)}", key=name)
    return int(value)


def as_choice(value, name, choices):
    """Return ``value`` if it is one of ``choices``."""
    try:
        known = value in choices
    except TypeError:                    # an unhashable value (a list from a spec)
        known = False
    if not known:
        raise InputError(f"expected one of {', '.join(map(repr, choices))}, got {shown(value)}",
                         key=name)
    return value


def as_input_file(path, what="file", *, key=None, shown_as=None):
    """Return ``path`` (a :class:`pathlib.Path`) if it names a regular file to read.

    A FIFO, a device (a link to ``/dev/zero``), a folder or a dangling link each get
    their own message, so none reads "no such file", and none is opened (reading a
    FIFO would wait forever, a device would never end). Raises
    :class:`~cadpipe.errors.ExportError` with ``file=path``; with ``key`` (a spec
    key naming the file as ``shown_as``) an :class:`InputError` about that key.
    """
    import stat
    from pathlib import Path as FilePath

    from cadpipe.errors import ExportError

    path = FilePath(path)
    name = f" {shown(shown_as)}" if key else ""
    where = {"key": key} if key else {"file": path}
    error = InputError if key else ExportError
    try:
        mode = path.stat().st_mode
    except FileNotFoundError:
        why = f"no such file{name}" if not path.is_symlink() else \
            f"{what}{name} is a link to a missing file"
        raise error(why + (f" in {path.parent}" if key else ""), **where) from None
    except (OSError, ValueError) as exc:
        raise error(f"cannot read {what}{name} ({getattr(exc, 'strerror', None) or exc})",
                    **where) from None
    if stat.S_ISREG(mode):
        return path
    kind = ("a folder" if stat.S_ISDIR(mode) else "a FIFO (named pipe)" if stat.S_ISFIFO(mode)
            else "a device" if stat.S_ISCHR(mode) or stat.S_ISBLK(mode) else
            "a socket" if stat.S_ISSOCK(mode) else "not a regular file")
    noun = what if kind == "a folder" else "regular file"
    raise error(f"{what}{name} is {kind}, not a {noun}" if key else f"is {kind}, not a {noun}",
                **where)
