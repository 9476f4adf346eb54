"""Argument checks shared by every stage, so errors read the same everywhere."""

import numpy as np

from cadpipe.errors import InputError


def as_points(value, name, *, dim=3, min_count=1):
    """Return ``value`` as a float64 ``(N, dim)`` array of finite numbers."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name}: expected an (N, {dim}) array of numbers ({exc})") from None
    if arr.ndim != 2 or arr.shape[1] != dim:
        raise InputError(f"{name}: expected shape (N, {dim}), got {arr.shape}")
    if len(arr) < min_count:
        raise InputError(f"{name}: expected at least {min_count} points, got {len(arr)}")
    if not np.isfinite(arr).all():
        bad = ~np.isfinite(arr).all(axis=1)
        raise InputError(f"{name}: point {int(np.argmax(bad))} is not finite (NaN or inf); "
                         "remove or fix it")
    return arr


def as_positive(value, name, count=None):
    """Return ``value`` as a float64 scalar or ``(count,)`` array of finite numbers > 0."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{name}: expected a positive number, got {value!r}") from None
    if arr.ndim > 1 or (arr.ndim == 1 and count is not None and len(arr) != count):
        raise InputError(f"{name}: expected a number or {count} values (one per point), "
                         f"got shape {arr.shape}")
    if not np.isfinite(arr).all() or (arr <= 0).any():
        raise InputError(f"{name}: must be finite and > 0, got {value!r}")
    return arr


def as_int(value, name, *, low, high):
    """Return ``value`` as an int in ``[low, high]``."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise InputError(f"{name}: expected a whole number, got {value!r}")
    if not low <= value <= high:
        raise InputError(f"{name}: must be between {low} and {high}, got {value}")
    return int(value)


def as_choice(value, name, choices):
    """Return ``value`` if it is one of ``choices``."""
    if value not in choices:
        raise InputError(f"{name}: expected one of {', '.join(map(repr, choices))}, got {value!r}")
    return value
