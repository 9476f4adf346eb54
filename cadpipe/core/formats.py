"""File formats by suffix: how a value below the file formats reaches them.

:meth:`Mesh.export <cadpipe.Mesh.export>`, :meth:`Mesh.load <cadpipe.Mesh.load>` and
:meth:`Assembly.export <cadpipe.Assembly.export>` look the file's suffix up here;
:mod:`cadpipe.io` registers every format's writer and reader when it is imported
(``import cadpipe`` does), and a plugin adds one in the entry-point groups
``cadpipe.writers`` and ``cadpipe.readers``. No format code lives here.

A writer is ``writer(obj, path, **options)``: ``obj`` a Mesh, Assembly or Scene, the
options its keyword-only parameters. A reader is ``reader(path)`` and returns a
Scene. :func:`export` and :func:`reader_for` are the one way in for both.
"""

import inspect
from pathlib import Path as FilePath

from cadpipe.core.registry import Registry
from cadpipe.errors import InputError

writers = Registry("cadpipe.writers", "output format")
readers = Registry("cadpipe.readers", "input format")


def writer(*suffixes):
    """Register the decorated function as the writer of files with these ``suffixes``
    (lower case, no dot)."""
    def register(fn):
        for suffix in suffixes:
            writers.register(suffix, fn)
        return fn
    return register


def reader(*suffixes):
    """Register the decorated function as the reader of files with these ``suffixes``."""
    def register(fn):
        for suffix in suffixes:
            readers.register(suffix, fn)
        return fn
    return register


def suffix_of(path):
    """The format key of a path: its lower-case suffix without the dot."""
    suffix = FilePath(path).suffix.lower().lstrip(".")
    if not suffix:
        raise InputError(f"no file suffix; use one of {_listed(writers)}", file=path)
    return suffix


def _listed(table):
    return ", ".join("." + n for n in table.names())


def writer_for(path):
    """The writer of ``path``'s format; :class:`InputError` naming the file otherwise."""
    key = suffix_of(path)
    if key not in writers:
        raise InputError(f"unknown output format '.{key}'; supported: {_listed(writers)}",
                         file=path)
    return writers.get(key)


def reader_for(path):
    """The reader of ``path``'s format; :class:`InputError` naming the file otherwise."""
    key = FilePath(path).suffix.lower().lstrip(".")
    if key not in readers:
        raise InputError(f"cannot read '.{key}' files; readable: {_listed(readers)}",
                         file=path)
    return readers.get(key)


def check_options(write, options, suffix):
    """:class:`InputError` naming the first of ``options`` that ``write`` does not take."""
    known = inspect.signature(write).parameters
    if any(p.kind is p.VAR_KEYWORD for p in known.values()):
        return
    unknown = sorted(set(options) - set(known))
    if unknown:
        usable = [n for n, p in known.items() if p.kind is p.KEYWORD_ONLY]
        raise InputError(f"'.{suffix}' files take no option {', '.join(unknown)}; they take "
                         f"{', '.join(usable) or 'none'}", key=unknown[0])


def export(obj, path, **options):
    """Write ``obj`` to ``path`` in the format its suffix names.

    Parameters
    ----------
    obj : Mesh, Assembly or Scene (or anything the format's writer takes)
    path : str or path-like
    **options
        The format's own options (``units``, ``ascii``, ``layout``, ...).

    Returns
    -------
    path : pathlib.Path
        The file written, whole (no partial file remains when writing fails).

    Raises
    ------
    InputError
        For an unknown suffix or option.
    ExportError
        When the file cannot be written.
    """
    write = writer_for(path)
    check_options(write, options, suffix_of(path))
    write(obj, FilePath(path), **options)
    return FilePath(path)


def load_scene(path):
    """Read a mesh or scene file into a Scene, Z up, in the format its suffix names.

    The readers keep what their formats hold: parts, names, colours and units (GLB,
    USD, 3MF; OBJ its objects and groups); exact duplicate vertices are welded
    (``Scene.welded``). A file without units is read in the unit the
    programs that use it assume (STL in millimetres, as slicers do) and its meshes'
    attributes say ``units_assumed``.

    Raises
    ------
    ExportError
        For a missing file (or a FIFO, a device, a folder: never opened).
    InputError
        For a suffix no reader takes.
    MeshError
        For a file that holds no triangles or is corrupt.
    LimitError
        For a file over a limit of :mod:`cadpipe.limits` (refused before the work).
    """
    from cadpipe import limits
    from cadpipe._validate import as_input_file

    path = as_input_file(path, "mesh file")     # a FIFO or device is never opened
    read = reader_for(path)
    limits.check_archive(path)                  # 3MF, USDZ: refuse a zip bomb unopened
    scene = read(path)
    limits.check("max_triangles", sum(len(p.mesh.faces) for p in scene.parts),
                 "this mesh file", file=path)
    return scene.welded()


def load_mesh(path):
    """Read a mesh file (any format :func:`load_scene` reads) into one Mesh in world
    coordinates: one part as it is, several as one mesh whose faces are labelled with
    their part's name (``Scene.as_mesh``)."""
    return load_scene(path).as_mesh()
