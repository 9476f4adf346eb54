"""Named, pluggable stages: part kinds and exporters.

cadpipe's own entries are registered here in code, so they exist whenever the
package imports (installed or run from a source tree on ``PYTHONPATH``). Entry
points only add plugins: a third-party package declares its part kinds and file
formats in the ``cadpipe.parts`` and ``cadpipe.exporters`` groups, and they are
found by name exactly like a built-in one (a plugin cannot replace a built-in).

The table is filled once, under a lock, and published only when complete, so
threads that look names up on a cold start all see every entry.
"""

import threading
from importlib import import_module
from importlib.metadata import entry_points

from cadpipe.errors import InputError, shown


class Registry:
    """A name -> object table: built-ins named in code, plugins from an entry-point group.

    Parameters
    ----------
    group : str
        The entry-point group plugins register in.
    what : str
        What an entry is, for messages ("part kind").
    builtins : dict
        Name -> ``"module:attribute"`` of cadpipe's own entries, imported on first use
        (the modules import the registry, so they cannot be imported here).
    """

    def __init__(self, group, what, builtins):
        self.group = group
        self.what = what
        self._builtins = dict(builtins)
        self._extra = {}
        self._items = None            # the complete table, once loaded
        self._lock = threading.RLock()   # importing a built-in may look names up

    def register(self, name, obj=None):
        """Register ``obj`` under ``name``; usable as a decorator when ``obj`` is omitted."""
        if obj is None:
            return lambda o: self.register(name, o)
        with self._lock:
            self._extra[name] = obj
            if self._items is not None:
                self._items = {**self._items, name: obj}
        return obj

    def _table(self):
        items = self._items
        if items is not None:
            return items
        with self._lock:
            if self._items is None:
                table = {}
                for name, target in self._builtins.items():
                    module, _, attribute = target.partition(":")
                    table[name] = getattr(import_module(module), attribute)
                for ep in entry_points(group=self.group):
                    if ep.name not in table:
                        table[ep.name] = ep.load()
                table.update(self._extra)
                self._items = table       # published whole
            return self._items

    def names(self):
        return sorted(self._table())

    def get(self, name):
        try:
            return self._table()[name]
        except (KeyError, TypeError):
            raise InputError(f"unknown {self.what} {shown(name)}; known: "
                             f"{', '.join(self.names())}") from None

    def __contains__(self, name):
        try:
            return name in self._table()
        except TypeError:
            return False


part_kinds = Registry("cadpipe.parts", "part kind", {
    name: f"cadpipe.io.parts:{name}"
    for name in ("pipe", "junction", "chain", "box", "cylinder", "sphere", "mesh")})
exporters = Registry("cadpipe.exporters", "output format", {
    "stl": "cadpipe.io.stl:write_stl", "usda": "cadpipe.io.usd:write_usd",
    "usdc": "cadpipe.io.usd:write_usd", "usdz": "cadpipe.io.usd:write_usd",
    "3mf": "cadpipe.io.threemf:write_3mf", "glb": "cadpipe.io.trimesh_formats:write_glb",
    "obj": "cadpipe.io.trimesh_formats:write_obj", "ply": "cadpipe.io.trimesh_formats:write_ply"})
