"""USD scenes (.usda text, .usdc binary, .usdz package) through usd-core.

Layout of the stage (``defaultPrim`` is the root, so the file can be referenced)::

    /<scene>                     Xform, kind=assembly
        /Materials               Scope
            /<name>              Material -> PreviewSurface (UsdPreviewSurface shader)
        /<part>                  Xform, kind=component, xformOp:transform,
                                 custom attributes cadpipe:<parameter>
            /Mesh                Mesh (triangles, no subdivision, normals, displayColor),
                                 material bound through MaterialBindingAPI
                /<label>         GeomSubset per source part of a unioned mesh
                                 (familyName materialBind), bound to that part's material

Stage metadata: ``upAxis`` and ``metersPerUnit`` from the scene. Points, normals
and colours are float32 (USD's ``point3f``); arrays go in through
``Vt.*.FromNumpy``, never as Python lists. Normals follow a crease angle
(:mod:`cadpipe.io.normals`): smooth round tubes, hard caps and edges. A
mesh without creases gets per-vertex ``normals``; one with creases an indexed
``primvars:normals`` (faceVarying), which stores one normal per vertex plus one
per crease group instead of one per face corner.
"""

import numbers
import tempfile
from pathlib import Path as FilePath

import numpy as np

from cadpipe._validate import as_choice
from cadpipe.errors import ExportError, MeshError
from cadpipe.io.scene import as_scene
from cadpipe.io.files import atomic_path, suffix_of, unique_name
from cadpipe.io.flatten import labelled
from cadpipe.io.normals import DEFAULT_CREASE_ANGLE, shading_normals


def write_usd(obj, path, *, crease_angle=DEFAULT_CREASE_ANGLE):
    """Write ``obj`` (Mesh, Pipe, Assembly or Scene) as .usda, .usdc or .usdz, atomically.

    Parameters
    ----------
    crease_angle : float
        Degrees: faces meeting at a sharper angle shade with a hard edge
        (0 faceted, 180 smooth).
    """
    save_stage(build_stage(as_scene(obj), crease_angle=crease_angle), path)


def save_stage(stage, path):
    """Write an in-memory stage to ``path`` (.usda, .usdc or .usdz), atomically."""
    from pxr import Sdf, UsdUtils

    kind = suffix_of(path)
    with atomic_path(path) as tmp:
        if kind != "usdz":
            if not stage.GetRootLayer().Export(str(tmp)):
                raise ExportError(f"{path}: usd-core could not write the layer")
            return
        # a .usdz is a zip of a root layer: write that as .usdc, then let usd-core package it
        with tempfile.TemporaryDirectory(prefix="cadpipe-usdz-") as folder:
            root = FilePath(folder) / (FilePath(path).stem + ".usdc")
            if not stage.GetRootLayer().Export(str(root)):
                raise ExportError(f"{path}: usd-core could not write the layer to package")
            if not UsdUtils.CreateNewARKitUsdzPackage(Sdf.AssetPath(str(root)), str(tmp)):
                raise ExportError(f"{path}: usd-core could not package the .usdz")


def build_stage(scene, *, crease_angle=DEFAULT_CREASE_ANGLE):
    """An in-memory :class:`pxr.Usd.Stage` holding ``scene`` (see the module docstring)."""
    from pxr import Kind, Usd, UsdGeom

    up = as_choice(str(scene.up_axis).upper(), "up_axis", ("Y", "Z"))
    stage = Usd.Stage.CreateInMemory()
    stage.GetRootLayer().documentation = "written by cadpipe"
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z if up == "Z" else UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, scene.meters_per_unit)
    root = UsdGeom.Xform.Define(stage, "/" + _valid_name(scene.name, set()))
    Usd.ModelAPI(root).SetKind(Kind.Tokens.assembly)
    stage.SetDefaultPrim(root.GetPrim())

    children = set()
    scope = UsdGeom.Scope.Define(stage, root.GetPath().AppendChild(_valid_name("Materials",
                                                                              children)))
    materials = _Materials(stage, scope.GetPath())
    for part in scene.parts:
        xform = UsdGeom.Xform.Define(stage, root.GetPath().AppendChild(_valid_name(part.name,
                                                                                  children)))
        Usd.ModelAPI(xform).SetKind(Kind.Tokens.component)
        if part.transform is not None:
            xform.AddTransformOp().Set(_matrix(part.transform))
        _set_custom_attributes(xform.GetPrim(), part.attributes)
        painted = labelled(scene, part)
        geom = _define_mesh(stage, xform.GetPath().AppendChild("Mesh"), painted, crease_angle)
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


def _define_mesh(stage, prim_path, painted, crease_angle):
    from pxr import Sdf, UsdGeom, Vt

    mesh, colors = painted.mesh, painted.colors
    points = np.ascontiguousarray(mesh.vertices, dtype=np.float32)
    counts = Vt.IntArray.FromNumpy(np.full(len(mesh.faces), 3, np.int32))
    indices = Vt.IntArray.FromNumpy(mesh.faces.astype(np.int32).ravel())
    valid, why = UsdGeom.Mesh.ValidateTopology(indices, counts, len(points))
    if not valid:
        raise MeshError(f"{prim_path}: invalid mesh topology for USD ({why})")
    geom = UsdGeom.Mesh.Define(stage, prim_path)
    geom.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(points))
    geom.CreateFaceVertexCountsAttr(counts)
    geom.CreateFaceVertexIndicesAttr(indices)
    geom.CreateExtentAttr(Vt.Vec3fArray.FromNumpy(np.stack([points.min(0), points.max(0)])))
    geom.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    geom.CreateOrientationAttr(UsdGeom.Tokens.rightHanded)
    geom.CreateDoubleSidedAttr(False)
    shading = shading_normals(mesh, crease_angle)
    normals = Vt.Vec3fArray.FromNumpy(shading.normals.astype(np.float32))
    if shading.per_vertex:
        geom.CreateNormalsAttr(normals)
        geom.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    else:   # creases: an indexed primvar (one normal per vertex plus a few, not per corner)
        primvar = UsdGeom.PrimvarsAPI(geom).CreatePrimvar(
            "normals", Sdf.ValueTypeNames.Normal3fArray, UsdGeom.Tokens.faceVarying)
        primvar.Set(normals)
        primvar.SetIndices(Vt.IntArray.FromNumpy(shading.corner_index.astype(np.int32)))
    if len(colors) == 1:
        display = geom.CreateDisplayColorPrimvar(UsdGeom.Tokens.constant)
        display.Set(Vt.Vec3fArray.FromNumpy(colors.astype(np.float32)))
    else:
        display = geom.CreateDisplayColorPrimvar(UsdGeom.Tokens.uniform)
        display.Set(Vt.Vec3fArray.FromNumpy(colors[painted.labels].astype(np.float32)))
    return geom


def _bind_materials(geom, painted, materials):
    """Bind the part's material, or one per source part through GeomSubsets."""
    from pxr import UsdGeom, UsdShade, Vt

    binding = UsdShade.MaterialBindingAPI.Apply(geom.GetPrim())
    if len(painted.names) == 1:
        binding.Bind(materials.get(painted.names[0], painted.colors[0]))
        return
    subset_names = set()
    for label, (name, rgb) in enumerate(zip(painted.names, painted.colors)):
        faces = np.flatnonzero(painted.labels == label).astype(np.int32)
        if len(faces) == 0:
            continue
        subset = binding.CreateMaterialBindSubset(_valid_name(name, subset_names),
                                                  Vt.IntArray.FromNumpy(faces),
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
            kind = Sdf.ValueTypeNames.String
        else:
            array = np.asarray(value)
            if array.ndim == 1 and np.issubdtype(array.dtype, np.number):
                kind = Sdf.ValueTypeNames.DoubleArray
                value = Vt.DoubleArray.FromNumpy(array.astype(np.float64))
            else:
                kind, value = Sdf.ValueTypeNames.String, str(value)
        name = "cadpipe:" + Tf.MakeValidIdentifier(str(key))
        prim.CreateAttribute(name, kind, custom=True).Set(value)
