"""USD scenes (.usda text, .usdc binary, .usdz package) through usd-core.

Layout of the stage (``defaultPrim`` is the root, so the file can be referenced)::

    /<scene>                     Xform, kind=assembly (for a Y-up stage of a Z-up
                                 scene: xformOp:transform turning it upright)
        /Materials               Scope
            /<name>              Material -> PreviewSurface (UsdPreviewSurface shader)
        /<part>                  Xform, kind=component, xformOp:transform,
                                 custom attributes cadpipe:<parameter>
            /<part>              Mesh (triangles, no subdivision, normals, displayColor),
                                 material bound through MaterialBindingAPI; named
                                 after its part, as DCC tools name objects by it
                /<label>         GeomSubset per source part of a unioned mesh
                                 (familyName materialBind), bound to that part's material

Stage metadata: ``metersPerUnit`` from the scene (or ``units``), ``upAxis``
the scene's, except a ``.usdz``, which is Y-up (AR Quick Look shows Z-up files
lying on their side). Points, normals and colours are float32 (USD's
``point3f``); numpy writes the large arrays straight into usd-core's
(:func:`vt_vec3f`), never through Python lists. Normals follow a crease angle
(:mod:`cadpipe.io.normals`): smooth round tubes, hard caps and edges. A
mesh without creases gets per-vertex ``normals``; one with creases an indexed
``primvars:normals`` (faceVarying), which stores one normal per vertex plus one
per crease group instead of one per face corner.
"""

import ctypes
import numbers
import tempfile
from pathlib import Path as FilePath
from types import MappingProxyType

import numpy as np

from cadpipe import limits
from cadpipe._validate import as_choice
from cadpipe.errors import ExportError, MeshError
from cadpipe.core import formats
from cadpipe.core.formats import suffix_of
from cadpipe.core.transform import placed_points
from cadpipe.core.units import UNITS
from cadpipe.io.files import atomic_path, file_mesh
from cadpipe.io.flatten import labelled
from cadpipe.io.normals import DEFAULT_CREASE_ANGLE, shading_normals
from cadpipe.solids.scene import TO_Y_UP, Scene, ScenePart, as_scene, printable, unique_name


@formats.writer("usda", "usdc", "usdz")
def write_usd(obj, path, *, crease_angle=DEFAULT_CREASE_ANGLE, units=None, up_axis=None,
              normals=True, layout="scene"):
    """Write ``obj`` (Mesh, Pipe, Assembly or Scene) as .usda, .usdc or .usdz, atomically.

    Parameters
    ----------
    crease_angle : float
        Degrees: faces meeting at a sharper angle shade with a hard edge
        (0 faceted, 180 smooth).
    units : str, optional
        Length unit of the stage (``metersPerUnit``); default: the scene's own.
    up_axis : {"Y", "Z"}, optional
        The stage's up axis; default "Y" for .usdz (AR), else the scene's.
    normals : bool
        Write shading normals; without them a renderer shades the (unsubdivided)
        mesh by its faces.
    layout : {"scene", "print"}
        See :func:`~cadpipe.solids.scene.as_scene`.
    """
    scene = as_scene(obj, layout=layout).in_units(units)
    up = up_axis or ("Y" if suffix_of(path) == "usdz" else scene.up_axis)
    streamed = Streamed() if suffix_of(path) == "usda" else None
    save_stage(build_stage(scene, crease_angle=crease_angle, up_axis=up, normals=normals,
                           streamed=streamed), path, streamed)


class Streamed:
    """The large arrays of a .usda, written by cadpipe a block at a time.

    usd-core formats each array of a text layer as one string (at 250,000 path points a
    .usda write peaked at 4x the mesh's arrays where a .usdc write took 2x:
    ``benchmarks/bench_build.py --memory``), so the stage holds a one-element
    placeholder instead, unique in the layer's text, and :meth:`write` puts the array's
    text in its place: the layer holds no copy of them either.
    """

    def __init__(self):
        self.arrays = {}                 # placeholder text -> ("int" | "vec3", array)

    def ints(self, array):
        """A placeholder ``Vt.IntArray`` for the (N,) or (N, k) whole numbers ``array``."""
        from pxr import Vt

        key = -1_000_000_000 - len(self.arrays)
        self.arrays[f"[{key}]"] = ("int", array)
        return Vt.IntArray([key])

    def vec3(self, array):
        """A placeholder ``Vt.Vec3fArray`` for the (N, 3) numbers ``array`` (float32 in the
        file)."""
        from pxr import Gf, Vt

        key = len(self.arrays) + 1
        self.arrays[f"[({key}, -7777, 0)]"] = ("vec3", array)
        return Vt.Vec3fArray([Gf.Vec3f(key, -7777, 0)])

    def write(self, text, fh):
        """Write ``text`` (the layer's) to ``fh`` with each placeholder replaced by its
        array, a block of rows at a time."""
        at = 0
        for where, key in sorted((text.index(key), key) for key in self.arrays):
            kind, array = self.arrays[key]
            fh.write(text[at:where] + "[")
            rows = array.reshape(len(array), -1) if kind == "vec3" else array.reshape(-1)
            convert = vt_vec3f if kind == "vec3" else vt_ints
            for start in range(0, len(rows), _STREAM_ROWS):
                # usd-core's own text of the block (float32's shortest form), brackets off
                fh.write(("" if start == 0 else ", ") +
                         str(convert(rows[start:start + _STREAM_ROWS]))[1:-1])
            fh.write("]")
            at = where + len(key)
        fh.write(text[at:])


#: rows of an array formatted at once by :meth:`Streamed.write`
_STREAM_ROWS = 1 << 16


def save_stage(stage, path, streamed=None):
    """Write an in-memory stage to ``path`` (.usda, .usdc or .usdz), atomically; a .usda's
    ``streamed`` arrays (:class:`Streamed`) written in place of their placeholders. A
    .usdz empties the stage's root layer once it is written, before it is packaged."""
    from pxr import Sdf, UsdUtils

    kind = suffix_of(path)
    with atomic_path(path) as tmp:
        if streamed is not None:
            with open(tmp, "w", encoding="utf-8") as fh:
                streamed.write(stage.GetRootLayer().ExportToString(), fh)
            return
        if kind != "usdz":
            if not stage.GetRootLayer().Export(str(tmp)):
                raise ExportError("usd-core could not write the layer", file=path)
            return
        # a .usdz is a zip of a root layer: write that as .usdc, then let usd-core package it
        with tempfile.TemporaryDirectory(prefix="cadpipe-usdz-") as folder:
            root = FilePath(folder) / (FilePath(path).stem + ".usdc")
            if not stage.GetRootLayer().Export(str(root)):
                raise ExportError("usd-core could not write the layer to package", file=path)
            # packaging opens the .usdc again: the in-memory copy of its arrays (1.1x the
            # mesh) goes first (2M points: 1.93x the mesh above it while writing, 1.67x after)
            stage.GetRootLayer().Clear()
            if not UsdUtils.CreateNewARKitUsdzPackage(Sdf.AssetPath(str(root)), str(tmp)):
                raise ExportError("usd-core could not package the .usdz", file=path)


def build_stage(scene, *, crease_angle=DEFAULT_CREASE_ANGLE, up_axis=None, normals=True,
                streamed=None):
    """An in-memory :class:`pxr.Usd.Stage` holding ``scene`` (see the module docstring).

    ``up_axis`` ("Y" or "Z", default the scene's) is the stage's; a Z-up scene on
    a Y-up stage is turned upright by its root prim's transform. ``normals=False``
    leaves shading normals out. With ``streamed`` (a :class:`Streamed`) the large
    arrays are placeholders, kept there for a .usda written by :func:`save_stage`.
    """
    from pxr import Kind, Usd, UsdGeom

    own = as_choice(str(scene.up_axis).upper(), "up_axis", ("Y", "Z"))
    up = as_choice(str(up_axis or own).upper(), "up_axis", ("Y", "Z"))
    stage = Usd.Stage.CreateInMemory()
    stage.GetRootLayer().documentation = "written by cadpipe"
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z if up == "Z" else UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, scene.meters_per_unit)
    root = UsdGeom.Xform.Define(stage, "/" + _valid_name(scene.name, set()))
    Usd.ModelAPI(root).SetKind(Kind.Tokens.assembly)
    stage.SetDefaultPrim(root.GetPrim())
    if up != own:
        turn = np.eye(4)
        turn[:3, :3] = TO_Y_UP[own] if up == "Y" else TO_Y_UP["Z"].T
        root.AddTransformOp().Set(_matrix(turn))

    children = set()
    scope = UsdGeom.Scope.Define(stage, root.GetPath().AppendChild(_valid_name("Materials",
                                                                              children)))
    materials = _Materials(stage, scope.GetPath())
    for part in scene.parts:
        prim_name = _valid_name(part.name, children)
        xform = UsdGeom.Xform.Define(stage, root.GetPath().AppendChild(prim_name))
        Usd.ModelAPI(xform).SetKind(Kind.Tokens.component)
        if part.transform is not None:
            xform.AddTransformOp().Set(_matrix(part.transform))
        _set_custom_attributes(xform.GetPrim(), part.attributes)
        painted = labelled(scene, part)
        geom = _define_mesh(stage, xform.GetPath().AppendChild(prim_name), painted,
                            crease_angle if normals else None, streamed)
        _bind_materials(geom, painted, materials)
    return stage


def _valid_name(name, taken):
    """A valid prim name for ``name``, unique among ``taken`` (which it joins)."""
    from pxr import Tf

    return unique_name(Tf.MakeValidIdentifier(str(name)) or "part", taken)


def _matrix(transform):
    """A column-vector 4x4 matrix as USD's row-vector ``Gf.Matrix4d``."""
    from pxr import Gf

    return Gf.Matrix4d(np.asarray(transform, dtype=np.float64).T.tolist())


def _define_mesh(stage, prim_path, painted, crease_angle, streamed=None):
    """The Mesh prim of ``painted``.

    Memory: usd-core's layer holds its own copy of every array, so cadpipe makes
    no second one. numpy converts float64 points and int64 faces straight into
    usd-core's arrays (:func:`vt_vec3f`, :func:`vt_ints`: no float32/int32 numpy
    copy), the face counts are one ``Vt.IntArray(F, 3)``, and the normals' corner
    index is written into its usd-core array too. With ``streamed`` the layer holds
    placeholders instead (see :class:`Streamed`).
    """
    from pxr import UsdGeom, Vt

    mesh, colors = painted.mesh, painted.colors
    vec3, ints = _converters(streamed)
    geom = UsdGeom.Mesh.Define(stage, prim_path)
    if crease_angle is not None:
        _set_normals(geom, shading_normals(mesh, crease_angle), streamed)
    points = vec3(mesh.vertices)
    counts = Vt.IntArray(len(mesh.faces), 3) if streamed is None else \
        ints(np.broadcast_to(np.int8(3), len(mesh.faces)))
    indices = ints(mesh.faces)
    if streamed is None:                 # placeholders: a cadpipe Mesh's indices are in range
        valid, why = UsdGeom.Mesh.ValidateTopology(indices, counts, len(points))
        if not valid:
            raise MeshError(f"{prim_path}: invalid mesh topology for USD ({why})")
    geom.CreatePointsAttr(points)
    geom.CreateFaceVertexCountsAttr(counts)
    geom.CreateFaceVertexIndicesAttr(indices)
    del points, counts, indices
    geom.CreateExtentAttr(Vt.Vec3fArray.FromNumpy(mesh.bounds))
    geom.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    geom.CreateOrientationAttr(UsdGeom.Tokens.rightHanded)
    geom.CreateDoubleSidedAttr(False)
    if len(colors) == 1:
        display = geom.CreateDisplayColorPrimvar(UsdGeom.Tokens.constant)
        display.Set(Vt.Vec3fArray.FromNumpy(colors))
    else:               # indexed: a colour per label and a label per face, not a colour per face
        display = geom.CreateDisplayColorPrimvar(UsdGeom.Tokens.uniform)
        display.Set(Vt.Vec3fArray.FromNumpy(colors))
        display.SetIndices(ints(painted.labels))
    return geom


def _converters(streamed):
    """``(vec3, ints)``: what turns (N, 3) numbers and whole numbers into the layer's
    arrays: usd-core's own (:func:`vt_vec3f`, :func:`vt_ints`), or ``streamed``'s
    placeholders (:class:`Streamed`)."""
    if streamed is None:
        return vt_vec3f, vt_ints
    return streamed.vec3, streamed.ints


def vt_vec3f(array):
    """(N, 3) numbers as a ``Vt.Vec3fArray`` (float32), converted at memory speed."""
    from pxr import Vt

    out = _vt_array(Vt.Vec3fArray, len(array), np.float32, 3)
    if out is None:
        return Vt.Vec3fArray.FromNumpy(array)
    np.copyto(out[1], array, casting="unsafe")
    return _checked(*out, array, Vt.Vec3fArray)


def vt_ints(array):
    """Whole numbers (any shape, flattened) as a ``Vt.IntArray`` (int32), converted at
    memory speed."""
    from pxr import Vt

    flat = np.asarray(array).ravel()
    out = _vt_array(Vt.IntArray, len(flat), np.int32)
    if out is None:
        return Vt.IntArray.FromNumpy(flat)
    np.copyto(out[1], flat, casting="unsafe")
    return _checked(*out, flat, Vt.IntArray)


def _vt_array(vt_type, count, dtype, width=None):
    """``(array, view, address)``: a new usd-core array of ``count`` elements, a writeable
    numpy view of its storage and where that is; None where usd-core does not show it.

    ``Vt.*.FromNumpy`` converts a number at a time through a call per number (3-4 ns
    each: 10 ms of a million triangles' indices, a fifth of a whole ``.usdc`` write). A
    new VtArray is the sole owner of its storage and shows it through the buffer
    protocol, read-only; numpy writes it before usd-core ever shares it, the way C++
    code fills ``VtArray::data()``. :func:`_checked` confirms it took.
    """
    if count == 0:
        return None
    made = vt_type(count)
    try:
        shown = np.asarray(made)
    except (TypeError, ValueError, BufferError):      # a usd-core without the buffer
        return None
    shape = (count,) if width is None else (count, width)
    if shown.shape != shape or shown.dtype != dtype:
        return None
    address = shown.__array_interface__["data"][0]
    raw = (ctypes.c_char * shown.nbytes).from_address(address)
    return made, np.frombuffer(raw, dtype).reshape(shape), address


def _checked(made, view, address, source, vt_type):
    """``made``, once it reads back (through usd-core) what ``view`` holds, from the same
    storage; else ``source`` converted by usd-core itself."""
    again = np.asarray(made)
    if (again.__array_interface__["data"][0] == address
            and np.array_equal(np.asarray(made[len(view) - 1]), view[-1])
            and np.array_equal(np.asarray(made[0]), view[0])):
        return made
    return vt_type.FromNumpy(source)


def _set_normals(geom, shading, streamed=None):
    """Shading normals: per vertex without creases; else an indexed faceVarying primvar
    (a normal per vertex plus a few per crease); placeholders with ``streamed``."""
    from pxr import Sdf, UsdGeom

    vec3, ints = _converters(streamed)
    if shading.per_vertex:
        geom.CreateNormalsAttr(vec3(shading.normals))
        geom.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
        return
    primvar = UsdGeom.PrimvarsAPI(geom).CreatePrimvar(
        "normals", Sdf.ValueTypeNames.Normal3fArray, UsdGeom.Tokens.faceVarying)
    primvar.SetIndices(ints(shading.corner_index) if streamed is not None else
                       _corner_index(shading))
    primvar.Set(vec3(shading.normals))


def _corner_index(shading):
    """``shading.corner_index`` as a ``Vt.IntArray``, written into usd-core's own array
    (no numpy copy of it)."""
    from pxr import Vt

    out = _vt_array(Vt.IntArray, shading.faces.size, np.int32)
    if out is None or len(shading.normals) >= 2**31:
        return vt_ints(shading.corner_index)
    made, view, address = out
    np.copyto(view, shading.faces.ravel(), casting="unsafe")
    view[shading.corners] = shading.rows
    return _checked(made, view, address, shading.corner_index, Vt.IntArray)


def _bind_materials(geom, painted, materials):
    """Bind the part's material, or one per source part through GeomSubsets."""
    from pxr import UsdGeom, UsdShade

    binding = UsdShade.MaterialBindingAPI.Apply(geom.GetPrim())
    if len(painted.names) == 1:
        binding.Bind(materials.get(painted.names[0], painted.colors[0]))
        return
    subset_names = set()
    for label, (name, rgb) in enumerate(zip(painted.names, painted.colors)):
        faces = np.flatnonzero(painted.labels == label)
        if len(faces) == 0:
            continue
        subset = binding.CreateMaterialBindSubset(_valid_name(name, subset_names),
                                                  vt_ints(faces),
                                                  UsdGeom.Tokens.face)
        UsdShade.MaterialBindingAPI.Apply(subset.GetPrim()).Bind(materials.get(name, rgb))
    binding.SetMaterialBindSubsetsFamilyType(UsdGeom.Tokens.partition)


class _Materials:
    """One UsdPreviewSurface material per (name, colour), created on first use."""

    def __init__(self, stage, scope_path):
        self.stage = stage
        self.scope_path = scope_path
        self.names = set()
        self.made = {}

    def get(self, name, rgb):
        from pxr import Gf, Sdf, UsdShade

        key = (name, tuple(np.round(rgb, 6)))
        if key not in self.made:
            path = self.scope_path.AppendChild(_valid_name(name, self.names))
            material = UsdShade.Material.Define(self.stage, path)
            shader = UsdShade.Shader.Define(self.stage, path.AppendChild("PreviewSurface"))
            shader.CreateIdAttr("UsdPreviewSurface")
            shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(
                Gf.Vec3f(*map(float, rgb)))
            shader.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(0.5)
            shader.CreateInput("metallic", Sdf.ValueTypeNames.Float).Set(0.0)
            material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
            self.made[key] = material
        return self.made[key]


def _set_custom_attributes(prim, attributes):
    """Write the parameters that made a part as ``cadpipe:<name>`` attributes.

    Booleans, whole numbers, reals, text and flat number sequences keep their
    type; anything else is written as its text form.
    """
    from pxr import Sdf, Tf, Vt

    for key, value in attributes.items():
        if isinstance(value, (bool, np.bool_)):
            kind, value = Sdf.ValueTypeNames.Bool, bool(value)
        elif isinstance(value, numbers.Integral):
            kind, value = Sdf.ValueTypeNames.Int64, int(value)
        elif isinstance(value, numbers.Real):
            kind, value = Sdf.ValueTypeNames.Double, float(value)
        elif isinstance(value, str):
            kind, value = Sdf.ValueTypeNames.String, printable(value)
        else:
            array = np.asarray(value)
            if array.ndim == 1 and np.issubdtype(array.dtype, np.number):
                kind = Sdf.ValueTypeNames.DoubleArray
                value = Vt.DoubleArray.FromNumpy(array.astype(np.float64))
            else:
                kind, value = Sdf.ValueTypeNames.String, printable(value)
        name = "cadpipe:" + Tf.MakeValidIdentifier(str(key))
        prim.CreateAttribute(name, kind, custom=True).Set(value)


# -- reading ---------------------------------------------------------------------
@formats.reader("usd", "usda", "usdc", "usdz")
def read_usd(path):
    """The meshes of a .usda/.usdc/.usdz file as a Z-up :class:`~cadpipe.solids.scene.Scene`.

    Each Mesh prim is a part named after the prim, in world coordinates
    (polygons fanned into triangles), in the stage's units (``metersPerUnit``;
    metres if it is none of cadpipe's units). Faces are labelled by their
    ``materialBind`` GeomSubsets and coloured by ``displayColor``. A Y-up stage
    is turned back to Z up. Raises :class:`MeshError` for an unreadable file
    or one without triangles.
    """
    from pxr import Tf, Usd, UsdGeom


    try:
        stage = Usd.Stage.Open(str(path))
    except Tf.ErrorException as exc:
        raise MeshError(f"usd-core cannot open it ({str(exc).strip().splitlines()[-1]})",
                        file=path) from None
    if stage is None:
        raise MeshError("usd-core cannot open it", file=path)
    mpu = UsdGeom.GetStageMetersPerUnit(stage)
    units = next((k for k, v in UNITS.items() if np.isclose(v, mpu)), None)
    scale = 1.0 if units else mpu
    turn = TO_Y_UP["Z"].T if UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.y else np.eye(3)
    parts, colors, taken, triangles = [], {}, set(), 0
    for prim in stage.Traverse():
        if not prim.IsA(UsdGeom.Mesh):
            continue
        geom = UsdGeom.Mesh(prim)
        points = np.asarray(geom.GetPointsAttr().Get() or [], dtype=np.float64).reshape(-1, 3)
        counts = np.asarray(geom.GetFaceVertexCountsAttr().Get() or [], dtype=np.int64)
        indices = np.asarray(geom.GetFaceVertexIndicesAttr().Get() or [], dtype=np.int64)
        if len(counts) == 0 or counts.sum() != len(indices) or (counts < 3).any():
            continue
        triangles += int((counts - 2).sum())      # checked before the fans are made
        limits.check("max_triangles", triangles, "reading this USD file", file=path)
        faces, polygon = fan_triangles(counts, indices)
        world = np.array(geom.ComputeLocalToWorldTransform(Usd.TimeCode.Default())).T
        placement = np.eye(4)
        placement[:3] = (turn * scale) @ world[:3]
        vertices = placed_points(points, placement)
        if np.linalg.det(world[:3, :3]) < 0:
            faces = faces[:, ::-1]
        if geom.GetOrientationAttr().Get() == UsdGeom.Tokens.leftHanded:
            faces = faces[:, ::-1]
        name = unique_name(prim.GetName(), taken)
        labels, names = _subset_labels(geom, len(counts), name)
        face_colors = _display_colors(geom, len(counts))
        for label, label_name in enumerate(names):
            if face_colors is not None and (labels == label).any():
                colors.setdefault(label_name, tuple(map(float, face_colors[labels == label][0])))
        mesh = file_mesh(vertices, faces, path, name, face_part=labels[polygon],
                         part_names=names, attributes={"source": str(path),
                                                       "units": units or "m"})
        parts.append(ScenePart(name, mesh))
    if not parts:
        raise MeshError("the file holds no triangle meshes", file=path)
    return Scene(name=FilePath(path).stem, parts=tuple(parts), units=units or "m",
                 colors=MappingProxyType(colors))


def fan_triangles(counts, indices):
    """Polygons as fans of triangles.

    Parameters
    ----------
    counts : (P,) int array
        Corners of each polygon (at least 3).
    indices : (sum(counts),) int array
        The polygons' corners, one polygon after the other.

    Returns
    -------
    triangles : (T, 3) int array
        Corner indices, ``counts - 2`` triangles per polygon.
    polygon : (T,) int array
        The polygon each triangle came from.
    """
    polygon = np.repeat(np.arange(len(counts)), counts - 2)
    first = np.concatenate([[0], np.cumsum(counts)[:-1]])[polygon]
    k = np.arange(len(polygon)) - np.repeat(np.cumsum(counts - 2) - (counts - 2), counts - 2)
    corners = np.stack([first, first + k + 1, first + k + 2], axis=1)
    return indices[corners], polygon


def _subset_labels(geom, n_faces, name):
    """(F,) label of each polygon from ``materialBind`` GeomSubsets, and the label names."""
    from pxr import UsdGeom, UsdShade

    subsets = UsdShade.MaterialBindingAPI(geom.GetPrim()).GetMaterialBindSubsets()
    labels = np.zeros(n_faces, np.int32)
    names = [name]
    for subset in subsets:
        if subset.GetElementTypeAttr().Get() != UsdGeom.Tokens.face:
            continue
        faces = np.asarray(subset.GetIndicesAttr().Get() or [], dtype=np.int64)
        faces = faces[(faces >= 0) & (faces < n_faces)]
        names.append(subset.GetPrim().GetName())
        labels[faces] = len(names) - 1
    if len(names) > 1 and not (labels == 0).any():
        return labels - 1, tuple(names[1:])       # subsets cover every face
    return labels, tuple(names)


def _display_colors(geom, n_faces):
    """(F, 3) displayColor per polygon, or None when the mesh has none per face or constant."""
    primvar = geom.GetDisplayColorPrimvar()
    if not primvar or not primvar.HasValue():
        return None
    values = np.asarray(primvar.ComputeFlattened() or [], dtype=np.float64).reshape(-1, 3)
    interpolation = primvar.GetInterpolation()
    if len(values) == 1 or interpolation == "constant":
        return np.repeat(values[:1], n_faces, axis=0) if len(values) else None
    if interpolation == "uniform" and len(values) == n_faces:
        return values
    return None
