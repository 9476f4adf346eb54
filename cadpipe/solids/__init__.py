"""Solids from meshes: validity, booleans through manifold3d, primitives, hollow parts,
assemblies."""
