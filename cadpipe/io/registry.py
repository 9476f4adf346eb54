"""Named, pluggable stages: part kinds and exporters.

cadpipe's own entries register through the same entry-point groups a third-party
package uses (``cadpipe.io.parts``, ``cadpipe.io.files``), so a plugin's part kind or
file format is found by name exactly like a built-in one.
"""

from importlib.metadata import entry_points

from cadpipe.errors import InputError


class Registry:
    """A name -> object table filled from an entry-point group on first lookup."""

    def __init__(self, group, what):
        self.group = group
        self.what = what
        self._items = {}
        self._loaded = False

    def register(self, name, obj=None):
        """Register ``obj`` under ``name``; usable as a decorator when ``obj`` is omitted."""
        if obj is None:
            return lambda o: self.register(name, o)
        self._items[name] = obj
        return obj

    def _load(self):
        if not self._loaded:
            self._loaded = True
            for ep in entry_points(group=self.group):
                self._items.setdefault(ep.name, ep.load())

    def names(self):
        self._load()
        return sorted(self._items)

    def get(self, name):
        self._load()
        try:
            return self._items[name]
        except KeyError:
            raise InputError(f"unknown {self.what} {name!r}; known: {', '.join(self.names())}") \
                from None

    def __contains__(self, name):
        self._load()
        return name in self._items


part_kinds = Registry("cadpipe.parts", "part kind")
exporters = Registry("cadpipe.exporters", "output format")
