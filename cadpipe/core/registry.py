"""Named, pluggable tables: file formats by suffix, spec part kinds by name.

cadpipe's own entries are registered in code by the modules that define them (the
file formats when :mod:`cadpipe.io` is imported, the part kinds when
:mod:`cadpipe.spec` is), so a table sits below everything that fills it and the
arrows point down. Entry points only add plugins: a third-party package declares
its entries in the table's group, and they are found by name exactly like a
built-in one (a plugin cannot replace a built-in).

The plugins are loaded once, under a lock, on the first look-up of a name that is not
built in (or the first listing of all names): reading every installed distribution's
entry points took 32 ms of a fresh process's start, which a built-in name need not
pay. The table is published only when complete, so threads that look names up on a
cold start all see every entry.
"""

import threading
from importlib.metadata import entry_points

from cadpipe.errors import InputError, shown


class Registry:
    """A name -> object table: built-ins registered in code, plugins from an entry-point
    group.

    Parameters
    ----------
    group : str
        The entry-point group plugins register in.
    what : str
        What an entry is, for messages ("output format").
    """

    def __init__(self, group, what):
        self.group = group
        self.what = what
        self._own = {}
        self._items = None              # the complete table, once plugins are loaded
        self._lock = threading.RLock()  # loading a plugin may look names up

    def register(self, name, obj=None):
        """Register ``obj`` under ``name``; a decorator when ``obj`` is omitted."""
        if obj is None:
            return lambda o: self.register(name, o)
        with self._lock:
            self._own[name] = obj
            if self._items is not None:
                self._items = {**self._items, name: obj}
        return obj

    def _table(self):
        items = self._items
        if items is not None:
            return items
        with self._lock:
            if self._items is None:
                table = dict(self._own)
                for ep in entry_points(group=self.group):
                    if ep.name not in table:
                        table[ep.name] = ep.load()
                self._items = table       # published whole
            return self._items

    def names(self):
        return sorted(self._table())

    def get(self, name):
        own = self._own.get(name) if isinstance(name, str) else None
        if own is not None:                 # a built-in: no plugin can replace it
            return own
        try:
            return self._table()[name]
        except (KeyError, TypeError):
            raise InputError(f"unknown {self.what} {shown(name)}; known: "
                             f"{', '.join(self.names())}") from None

    def __contains__(self, name):
        if isinstance(name, str) and name in self._own:
            return True
        try:
            return name in self._table()
        except TypeError:
            return False
