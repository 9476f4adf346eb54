"""Edges and connected pieces of a triangle mesh, in compiled passes.

``np.unique`` over a mesh's 3F edge keys sorts them through a permutation with
copies beside it, and scipy's connected components build a sparse matrix of the
links: together about 200 bytes a triangle, the peak of ``cadpipe build``'s
summary (8x the mesh's arrays). Here the edges are grouped by their lower vertex
(a counting sort: a group is one vertex's fan) and sorted within each group,
which is ``np.unique``'s order; pieces come from a union-find over the links.
"""

import numba
import numpy as np

#: a group longer than this is sorted by numpy's sort, shorter ones by insertion
_SHORT = 32


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
    rows, start = _grouped(faces, count, track=True)
    return _table(start, *rows)


def closed(faces, count):
    """Whether every undirected edge of ``faces`` (parameters as :func:`edge_table`) has
    exactly two of them (watertight), found without the edge table: 4 bytes a directed
    edge beside the faces."""
    (high, _), start = _grouped(faces, count, track=False)
    return len(high) > 0 and bool(_all_pairs(start, high))


def _grouped(faces, count, track):
    """``((high, edge), start)``: the directed edges grouped by their low end (group v
    is ``start[v]:start[v + 1]``) and sorted by their high end within it; with
    ``track``, the directed edge each came from (else ``edge`` is empty)."""
    faces, count = np.asarray(faces, np.int64), max(int(count), 1)
    m = 3 * len(faces)
    # int32 where they fit: these two are most of the memory this takes
    high = np.empty(m, np.int32 if count < 2**31 else np.int64)
    edge = np.empty(m if track else 0, np.int32 if m < 2**31 else np.int64)
    start = _group(faces, count, high, edge)
    return (high, edge), start


@numba.njit(cache=True, nogil=True)
def _group(faces, count, high, edge):
    track = len(edge) > 0
    start = np.zeros(count + 1, np.int64)
    for f in range(len(faces)):
        for c in range(3):
            start[min(faces[f, c], faces[f, (c + 1) % 3]) + 1] += 1
    for v in range(count):
        start[v + 1] += start[v]
    fill = start[:-1].copy()
    for f in range(len(faces)):
        for c in range(3):
            a, b = faces[f, c], faces[f, (c + 1) % 3]
            low = min(a, b)
            slot = fill[low]
            fill[low] = slot + 1
            high[slot] = max(a, b)
            if track:
                edge[slot] = 3 * f + c
    for v in range(count):
        s, e = start[v], start[v + 1]
        if e - s > _SHORT:
            order = np.argsort(high[s:e])
            high[s:e] = high[s:e][order]
            if track:
                edge[s:e] = edge[s:e][order]
        else:                                  # insertion sort: a vertex's fan is small
            for i in range(s + 1, e):
                h, j = high[i], i - 1
                d = edge[i] if track else 0
                while j >= s and high[j] > h:
                    high[j + 1] = high[j]
                    if track:
                        edge[j + 1] = edge[j]
                    j -= 1
                high[j + 1] = h
                if track:
                    edge[j + 1] = d
    return start


@numba.njit(cache=True, nogil=True)
def _table(start, high, edge):
    count = len(start) - 1
    unique = 0
    for v in range(count):
        for i in range(start[v], start[v + 1]):
            if i == start[v] or high[i] != high[i - 1]:
                unique += 1
    keys = np.empty(unique, np.int64)
    counts = np.zeros(unique, np.int64)
    inverse = np.empty(len(high), np.int64)
    row = -1
    for v in range(count):
        for i in range(start[v], start[v + 1]):
            if i == start[v] or high[i] != high[i - 1]:
                row += 1
                keys[row] = v * count + high[i]
            counts[row] += 1
            inverse[edge[i]] = row
    return keys, inverse, counts


@numba.njit(cache=True, nogil=True)
def _all_pairs(start, high):
    """Whether every run of equal high ends within a group is two long."""
    for v in range(len(start) - 1):
        s, e = start[v], start[v + 1]
        i = s
        while i < e:
            if i + 1 >= e or high[i + 1] != high[i] or (i + 2 < e and high[i + 2] == high[i]):
                return False
            i += 2
    return True


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
    a, b = np.atleast_2d(a), np.atleast_2d(b)
    parent = np.arange(count, dtype=np.int64)
    _join(parent, a, b)
    return _labels(parent)


@numba.njit(cache=True, nogil=True)
def _root(parent, x):
    while parent[x] != x:                  # path halving
        parent[x] = parent[parent[x]]
        x = parent[x]
    return x


@numba.njit(cache=True, nogil=True)
def _join(parent, a, b):
    """Union of every ``a[i, j]`` with ``b[i, j]``; each piece's root its lowest node."""
    for i in range(a.shape[0]):
        for j in range(a.shape[1]):
            x, y = _root(parent, a[i, j]), _root(parent, b[i, j])
            if x < y:
                parent[y] = x
            elif y < x:
                parent[x] = y


@numba.njit(cache=True, nogil=True)
def _labels(parent):
    labels = np.empty(len(parent), np.int32)
    pieces = 0
    for v in range(len(parent)):
        root = _root(parent, v)
        if root == v:
            labels[v] = pieces
            pieces += 1
        else:
            labels[v] = labels[root]       # root < v: labelled already
    return labels
