"""The primitives every other package builds on: vectors, transforms, the float32 rule
and the weld, the box tree, distances, the compiled kernels, the file-format registry.

Nothing here imports any other cadpipe package (errors and limits aside), so every
layer above -- geometry, solids, io, collision, spec, batch, cli -- can use it.
"""
