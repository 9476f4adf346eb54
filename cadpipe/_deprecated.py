"""Names of cadpipe 0.1 that 0.2 renamed, kept working for one release with a warning.

A method that became a property (``pipe.attributes()`` -> ``pipe.attributes``)
returns a value that may still be called: the call warns and returns the value.
"""

import warnings
from collections.abc import Mapping


def warn(old, new, stacklevel=3):
    """A :class:`DeprecationWarning` that ``old`` is now ``new`` (gone in cadpipe 0.3)."""
    warnings.warn(f"{old} is deprecated: use {new} (the old form goes in cadpipe 0.3)",
                  DeprecationWarning, stacklevel=stacklevel)


class _Called:
    """Calling the value, as when it was a method, warns and returns it."""

    _old = ""

    def __call__(self):
        warn(f"{self._old}()", self._old)
        return self


class Attributes(_Called, Mapping):
    """A read-only mapping of the parameters that made a part (callable for 0.1 code)."""

    def __init__(self, items, old):
        self._items = dict(items)
        self._old = old

    def __getitem__(self, key):
        return self._items[key]

    def __iter__(self):
        return iter(self._items)

    def __len__(self):
        return len(self._items)

    def __repr__(self):
        return repr(self._items)


class Listing(_Called, list):
    """A list that a property returns where a method used to (callable for 0.1 code)."""

    def __init__(self, items, old):
        super().__init__(items)
        self._old = old
