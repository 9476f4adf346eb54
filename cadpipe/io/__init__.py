"""File formats: the writers and readers of every format, registered by suffix in
:mod:`cadpipe.core.formats` when this package is imported, and previews.

Spec files are not a file format but a way of building objects: :mod:`cadpipe.spec`.
"""

from cadpipe.io import gltf, stl, threemf, trimesh_formats, usd  # noqa: F401  (register)
