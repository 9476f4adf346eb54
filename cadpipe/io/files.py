"""Writing and reading files: one exporter per format, chosen by the file's suffix.

Exporters are looked up in :data:`cadpipe.io.registry.exporters` (entry-point group
``cadpipe.io.files``), so a plugin adds a format the same way cadpipe does.
Every output is written whole or not at all: into a temporary file beside the
target, then renamed over it.
"""

import os
import tempfile
from contextlib import contextmanager
from pathlib import Path as FilePath

import numpy as np

from cadpipe.errors import ExportError, InputError, MeshError
from cadpipe.io.registry import exporters


def suffix_of(path):
    """The format key of a path: its lower-case suffix without the dot."""
    suffix = FilePath(path).suffix.lower().lstrip(".")
    if not suffix:
        raise InputError(f"{path}: no file suffix; use one of {', '.join(exporters.names())}")
    return suffix


def unique_name(name, taken):
    """``name``, or ``name_1``, ``name_2``, ... if already in ``taken``; adds the result."""
    candidate, n = str(name), 1
    while candidate in taken:
        candidate, n = f"{name}_{n}", n + 1
    taken.add(candidate)
    return candidate


def export(obj, path, **options):
    """Write a :class:`~cadpipe.Mesh` (or anything an exporter accepts) to ``path``.

    Returns the path written. Raises :class:`InputError` for an unknown suffix and
    :class:`ExportError` when the file cannot be written (no partial file remains).
    """
    key = suffix_of(path)
    if key not in exporters:
        raise InputError(f"{path}: unknown output format '.{key}'; supported: "
                         f"{', '.join('.' + n for n in exporters.names())}")
    exporters.get(key)(obj, FilePath(path), **options)
    return FilePath(path)


def _umask():
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _file_in_the_way(folder):
    """The file that stands where ``folder`` or one of its parents should be, if any."""
    return next((p for p in (folder, *folder.parents) if p.exists() and not p.is_dir()), None)


def check_target(path):
    """Raise :class:`ExportError` if ``path`` can never be written as a file: it is a
    folder, or a file stands where one of its folders should be."""
    path = FilePath(path)
    if path.is_dir():
        raise ExportError(f"{path}: is a folder; give the name of a file to write")
    blocker = _file_in_the_way(path.parent)
    if blocker is not None:
        raise ExportError(f"{path}: {blocker} is a file, not a folder; choose another path")


def ensure_folder(folder):
    """Create ``folder`` (and parents) or raise :class:`ExportError` saying why not."""
    folder = FilePath(folder)
    blocker = _file_in_the_way(folder)
    if blocker is not None:
        raise ExportError(f"{folder}: cannot create the output folder: {blocker} is a file; "
                          "choose another folder")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ExportError(f"{folder}: cannot create the output folder ({exc.strerror})") from None
    return folder


@contextmanager
def atomic_path(path):
    """Yield a temporary path beside ``path``; rename it over ``path`` only on success."""
    path = FilePath(path)
    directory = path.parent if str(path.parent) else FilePath(".")
    check_target(path)
    if not directory.is_dir():
        raise ExportError(f"{path}: folder {directory} does not exist; create it first")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp" + path.suffix,
                                   dir=directory)
    except OSError as exc:
        raise ExportError(f"{path}: cannot write there ({exc.strerror}); "
                          "choose a writable folder") from None
    os.close(fd)
    try:
        yield FilePath(tmp)
        os.chmod(tmp, 0o666 & ~_umask())      # mkstemp's 0600 is for the temporary only
        os.replace(tmp, path)
    except OSError as exc:
        raise ExportError(f"{path}: writing failed ({exc}); nothing was written") from None
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def load_mesh(path):
    """Read a mesh file through trimesh into a :class:`~cadpipe.Mesh`.

    Scenes are flattened into one mesh. Raises :class:`ExportError` for a missing or
    unreadable file and :class:`MeshError` for one holding no triangles.
    """
    from cadpipe import limits
    from cadpipe._validate import MAX_MAGNITUDE, as_input_file

    path = as_input_file(path, "mesh file")     # a FIFO or device is never opened
    limits.check_archive(path)                  # 3MF, USDZ: refuse a zip bomb unopened
    if path.suffix.lower() == ".stl":           # 50 bytes a triangle in binary, more in text
        limits.check("max_triangles", path.stat().st_size / 50, "this STL file", file=path)
    import trimesh  # after the check: a wrong name is reported at once

    from cadpipe.geometry.mesh import Mesh

    try:
        loaded = trimesh.load(path, force="mesh", process=False)
    except Exception as exc:  # trimesh raises many types for corrupt input
        raise MeshError(f"{path}: cannot read it as a mesh ({type(exc).__name__}: {exc})") \
            from None
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise MeshError(f"{path}: the file holds no triangles (empty, truncated or not a "
                        "mesh file)")
    limits.check("max_triangles", len(loaded.faces), "this mesh file", file=path)
    if not (np.abs(loaded.vertices) <= MAX_MAGNITUDE).all():
        raise MeshError(f"{path}: some vertex coordinates are NaN or infinite "
                        f"(or beyond {MAX_MAGNITUDE:g}); the file is corrupt")
    # files store each triangle's corners separately (STL): weld exact duplicates
    loaded.merge_vertices(merge_tex=True, merge_norm=True)
    return Mesh(loaded.vertices, loaded.faces, attributes={"source": str(path)})
