"""Edges and connected pieces of a triangle mesh, in compiled passes.

``np.unique`` over a mesh's 3F edge keys sorts them through a permutation with
copies beside it, and scipy's connected components build a sparse matrix of the
links: together about 200 bytes a triangle, the peak of ``cadpipe build``'s
summary (8x the mesh's arrays). Here the edges are grouped by their lower vertex
(a counting sort: a group is one vertex's fan) and sorted within each group,
which is ``np.unique``'s order; pieces come from a union-find over the links
(C kernels, ``csrc/topology.c``).
"""

import numpy as np

from cadpipe.core.kernels import native


def edge_table(faces, count):
    """The undirected edges of ``faces``: ``np.unique`` of their keys, with the inverse
    and the counts.

    Parameters
    ----------
    faces : (F, 3) int array
        Vertex indices in ``[0, count)``.
    count : int
        Number of vertices.

    Returns
    -------
    keys : (E,) int64
        ``low * count + high`` of each edge, ascending.
    inverse : (3F,) int64
        Row of ``keys`` of directed edge ``3f + k`` (corner k of face f to corner k + 1).
    counts : (E,) int64
        Directed edges on each undirected one: faces around it.
    """
    (high, edge), start = _grouped(faces, count, track=True)
    return native.edge_rows(start, high, edge)


def closed(faces, count):
    """Whether every undirected edge of ``faces`` (parameters as :func:`edge_table`) has
    exactly two of them (watertight), found without the edge table: 4 bytes a directed
    edge beside the faces."""
    (high, _), start = _grouped(faces, count, track=False)
    return len(high) > 0 and native.edge_pairs(start, high)


def _grouped(faces, count, track):
    """``((high, edge), start)``: the directed edges grouped by their low end (group v
    is ``start[v]:start[v + 1]``) and sorted by their high end within it; with
    ``track``, the directed edge each came from (else ``edge`` is empty)."""
    faces, count = np.ascontiguousarray(faces, np.int64), max(int(count), 1)
    m = 3 * len(faces)
    # int32 where they fit: these two are most of the memory this takes
    high = np.empty(m, np.int32 if count < 2**31 else np.int64)
    edge = np.empty(m if track else 0, np.int32 if m < 2**31 else np.int64)
    start = native.edge_group(faces, count, high, edge)
    return (high, edge), start


def connected_labels(count, a, b):
    """Connected-component label of each of ``count`` nodes linked by the pairs ``(a, b)``.

    Parameters
    ----------
    count : int
        Number of nodes.
    a, b : 1-D or 2-D int arrays of one shape (any strides: views and broadcasts are
        not copied)
        The links' ends: each element of ``a`` is linked with that of ``b``.

    Returns
    -------
    labels : (count,) int32
        Equal labels for nodes joined by a chain of links, numbered in the order of
        each piece's lowest node (as scipy's ``connected_components`` numbers them).
    """
    a, b = np.asarray(a), np.asarray(b)
    if a.shape != b.shape:
        raise ValueError(f"link ends of shapes {a.shape} and {b.shape}")
    a, b = (np.atleast_2d(e if e.dtype in _READ else e.astype(np.int64)) for e in (a, b))
    return native.connected_labels(int(count), a, b)


#: the index types the kernels read as they are (any other is copied to int64)
_READ = (np.dtype(np.int32), np.dtype(np.int64))
