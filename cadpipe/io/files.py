"""What every reader and writer shares: whole-or-nothing writes, checked file meshes.

Every output is written whole or not at all: into a temporary file beside the
target, then renamed over it. The writer holds a lock on its temporary file,
so the next write to the same target can tell a temporary file left by a
killed write (no lock, older than this run) from one being written, and
removes it.
"""

import fcntl
import glob
import os
import tempfile
import time
from contextlib import contextmanager
from pathlib import Path as FilePath
from types import MappingProxyType

import numpy as np

from cadpipe._validate import MAX_MAGNITUDE
from cadpipe.core import formats
from cadpipe.core.kernels import native
from cadpipe.core.units import UNITS
from cadpipe.errors import ExportError, MeshError
from cadpipe.geometry.mesh import Mesh
from cadpipe.solids.scene import Scene, ScenePart, unique_name


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
        raise ExportError("is a folder; give the name of a file to write", file=path)
    blocker = _file_in_the_way(path.parent)
    if blocker is not None:
        raise ExportError(f"{blocker} is a file, not a folder; choose another path", file=path)


def ensure_folder(folder):
    """Create ``folder`` (and parents) or raise :class:`ExportError` saying why not."""
    folder = FilePath(folder)
    blocker = _file_in_the_way(folder)
    if blocker is not None:
        raise ExportError(f"cannot create the output folder: {blocker} is a file; "
                          "choose another folder", file=folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ExportError(f"cannot create the output folder ({exc.strerror})",
                          file=folder) from None
    return folder


#: when this process started writing: temporary files older than it are from earlier runs
_RUN_STARTED = time.time()


def _temp_pattern(path):
    """The names of :func:`atomic_path`'s temporary files for ``path`` (``.NAME.*.tmp.SUFFIX``)
    and of the writer's own temporaries beside them (usd-core saves ``.NAME.*.tmp`` through
    ``.NAME.*.tmp.XXXXXX``): a glob."""
    return str(path.parent / f".{glob.escape(path.name)}.*.tmp*")


def _remove_stale(path):
    """Remove temporary files of earlier, killed writes to ``path`` (none is locked)."""
    for stale in glob.glob(_temp_pattern(path)):
        try:
            if os.stat(stale).st_mtime >= _RUN_STARTED:
                continue
            fd = os.open(stale, os.O_RDONLY)
        except OSError:
            continue
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)   # a live writer holds it
            os.unlink(stale)
        except OSError:
            pass
        finally:
            os.close(fd)


@contextmanager
def atomic_path(path):
    """Yield a temporary path beside ``path``; rename it over ``path`` only on success."""
    path = FilePath(path)
    directory = path.parent if str(path.parent) else FilePath(".")
    check_target(path)
    if not directory.is_dir():
        raise ExportError(f"folder {directory} does not exist; create it first", file=path)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp" + path.suffix,
                                   dir=directory)
    except OSError as exc:
        raise ExportError(f"cannot write there ({exc.strerror}); "
                          "choose a writable folder", file=path) from None
    fcntl.flock(fd, fcntl.LOCK_EX)            # ours until written: not stale
    _WRITING.add(tmp)
    try:
        _remove_stale(path)
        yield FilePath(tmp)
        os.chmod(tmp, 0o666 & ~_umask())      # mkstemp's 0600 is for the temporary only
        os.replace(tmp, path)
    except OSError as exc:
        raise ExportError(f"writing failed ({exc}); nothing was written", file=path) from None
    finally:
        _WRITING.discard(tmp)
        if os.path.exists(tmp):
            os.unlink(tmp)
        os.close(fd)


#: temporary files of the writes under way in this process
_WRITING = set()


def abandon_writes():
    """Remove the temporary files of the writes under way: a process interrupted while a
    writer thread is inside a long call, about to exit, leaves no partial file."""
    for tmp in list(_WRITING):
        try:
            os.unlink(tmp)
        except OSError:
            pass


#: unit a file without one is read in, as the programs that use it read it
ASSUMED_UNITS = {"stl": "mm", "obj": "m", "ply": "m", "off": "m"}


def file_mesh(vertices, faces, path, name, *, face_part=None, part_names=(), attributes=None):
    """A :class:`~cadpipe.Mesh` of part ``name`` read from ``path``; :class:`MeshError`
    (naming the file and part) for non-finite coordinates, bad face indices or labels.

    What a file can get wrong is checked here, in compiled passes over the
    reader's own arrays (kept as they are, not copied); ``Mesh``'s own checks,
    numpy reductions over rows of 3, took most of the time of reading a GLB.
    """
    vertices, faces = np.asarray(vertices, dtype=np.float64), np.asarray(faces)
    if vertices.ndim != 2 or vertices.shape[1] != 3 or faces.ndim != 2 or \
            faces.shape[1] != 3 or not np.issubdtype(faces.dtype, np.integer):
        raise MeshError(f"expected (N, 3) points and (F, 3) vertex indices, got shapes "
                        f"{vertices.shape} and {faces.shape}", file=path, part=name)
    if not native.within(np.ascontiguousarray(vertices).reshape(-1), MAX_MAGNITUDE):
        raise MeshError(f"some vertex coordinates are NaN or infinite (or beyond "
                        f"{MAX_MAGNITUDE:g}); the file is corrupt", file=path, part=name)
    faces = np.ascontiguousarray(faces, np.int64)
    low, high = native.index_range(faces.reshape(-1))
    if faces.size and (low < 0 or high >= len(vertices)):
        raise MeshError(f"face indices must lie in [0, {len(vertices) - 1}], got "
                        f"[{low}, {high}]", key="faces", file=path, part=name)
    if face_part is not None:
        face_part = np.ascontiguousarray(face_part, np.int32)
        low, high = native.index_range(face_part)
        if face_part.shape != (len(faces),) or (len(faces) and (
                low < 0 or high >= len(part_names))):
            raise MeshError("face labels must point into the part names", key="face_part",
                            file=path, part=name)
    return Mesh.trusted(vertices, faces, face_part=face_part, part_names=part_names,
                        attributes=attributes)


@formats.reader("ply", "off", "dae")
def read_trimesh(path):
    """A Scene of a file trimesh reads (PLY, OFF, COLLADA as robot packages ship it; and an
    ASCII STL, through :func:`cadpipe.io.stl.read_stl`), its face colours as part labels."""
    import trimesh

    key = FilePath(path).suffix.lower().lstrip(".")
    try:
        loaded = trimesh.load(path, process=False)
    except Exception as exc:  # trimesh raises many types for corrupt input
        raise MeshError(f"cannot read it as a mesh ({type(exc).__name__}: {exc})",
                        file=path) from None
    if isinstance(loaded, trimesh.Trimesh):
        pieces = [(path.stem, loaded)]
    elif isinstance(loaded, trimesh.Scene):
        from cadpipe import limits

        # a 3MF's build items and components may repeat one object many times over
        limits.check("max_triangles", sum(len(getattr(loaded.geometry[loaded.graph[n][1]],
                                                      "faces", ())) for n in
                                          loaded.graph.nodes_geometry),
                     "this file's placed objects", file=path)
        pieces = []
        for node in loaded.graph.nodes_geometry:
            matrix, name = loaded.graph[node]
            geometry = loaded.geometry[name]
            if isinstance(geometry, trimesh.Trimesh) and len(geometry.faces):
                pieces.append((node, geometry.copy().apply_transform(matrix)))
    else:
        pieces = []
    pieces = [(name, tm) for name, tm in pieces if len(tm.faces)]
    if not pieces:
        raise MeshError("the file holds no triangles (empty, truncated or not a mesh file)",
                        file=path)
    units = getattr(loaded, "units", None)
    units = {"millimeter": "mm", "meter": "m", "centimeter": "cm", "inch": "in",
             "foot": "ft", "millimeters": "mm", "meters": "m"}.get(units, units)
    assumed = units not in UNITS
    if assumed:
        units = ASSUMED_UNITS.get(key, "m")
    parts, taken, colors = [], set(), {}
    for name, tm in pieces:
        labels, names, rgb = _face_colour_labels(tm, str(name))
        colors.update(zip(names, rgb))
        mesh = file_mesh(tm.vertices, tm.faces, path, name, face_part=labels, part_names=names,
                         attributes={"source": str(path), "units": units,
                                     "units_assumed": assumed})
        parts.append(ScenePart(unique_name(str(name), taken), mesh))
    return Scene(name=path.stem, parts=tuple(parts), units=units,
                 colors=MappingProxyType(colors))


def _face_colour_labels(tm, name):
    """Labels of a trimesh's faces by face colour (a PLY's, a 3MF's), names and colours."""
    raw = tm.metadata.get("_ply_raw", {}).get("face", {}).get("data")
    fields = raw if isinstance(raw, dict) else getattr(getattr(raw, "dtype", None), "names", None)
    if fields and all(c in fields for c in ("red", "green", "blue")):   # ASCII PLY: a dict
        rgb = np.column_stack([raw["red"], raw["green"], raw["blue"]]).astype(np.uint8)
    elif tm.visual.kind == "face":
        rgb = np.asarray(tm.visual.face_colors)[:, :3]
    else:
        return None, (), ()
    # one integer per colour: a sort of ints, not of 3-byte rows
    packed = (rgb[:, 0].astype(np.int32) << 16) | (rgb[:, 1].astype(np.int32) << 8) | rgb[:, 2]
    codes, labels = np.unique(packed, return_inverse=True)
    colours = np.stack([codes >> 16, (codes >> 8) & 255, codes & 255], axis=1)
    names = tuple(f"{name}_{r:02x}{g:02x}{b:02x}" for r, g, b in colours)
    return labels.ravel(), names, [tuple(v / 255.0 for v in c) for c in colours.tolist()]
