"""Many variable-length items (paths, tubes) in one set of numpy arrays.

A batch of G items is stored as their rows concatenated plus offsets, as shapely 2
and awkward arrays do: item g owns rows ``starts[g]:starts[g + 1]``. The helpers
here shift, sum and accumulate within items without a Python loop over them, so a
batch of a thousand pipes costs the same handful of numpy calls as one pipe. A
single path or pipe is a batch of one; there is no separate single-item code.
"""

from functools import cached_property

import numpy as np

#: rows per block for per-point work done block by block (see :func:`blocks`)
BLOCK = 16384


def blocks(size):
    """Slices covering ``range(size)`` in steps of :data:`BLOCK` rows.

    Per-point arithmetic done block by block keeps its temporaries small: they stay
    in cache and are recycled by the allocator, where whole-batch temporaries would
    each be fresh memory (a page fault every 4 KiB).
    """
    return [slice(a, min(a + BLOCK, size)) for a in range(0, size, BLOCK)]


class Groups:
    """Row ranges of G items, each open or closed (its last row leads back to its first).

    Parameters
    ----------
    counts : (G,) array_like of int
        Rows per item (at least 1 where rows are shifted within items).
    closed : bool or (G,) array_like of bool
    """

    __slots__ = ("starts", "closed", "__dict__")

    def __init__(self, counts, closed=False):
        counts = np.asarray(counts, dtype=np.int64).reshape(-1)
        self.starts = np.concatenate([[0], np.cumsum(counts)])
        self.closed = np.broadcast_to(np.asarray(closed, dtype=bool), counts.shape)

    def __len__(self):
        return len(self.starts) - 1

    @property
    def size(self):
        """Total number of rows."""
        return int(self.starts[-1])

    @property
    def counts(self):
        return np.diff(self.starts)

    @property
    def first(self):
        """(G,) row of each item's first element."""
        return self.starts[:-1]

    @property
    def last(self):
        """(G,) row of each item's last element."""
        return self.starts[1:] - 1

    @cached_property
    def index(self):
        """(N,) item of each row."""
        return np.repeat(np.arange(len(self)), self.counts)

    def spread(self, per_item):
        """One value per item repeated over that item's rows (along the last axis, so
        component-first ``(3, G)`` vectors spread to ``(3, N)``)."""
        return np.repeat(per_item, self.counts, axis=-1)

    def local(self):
        """(N,) position of each row within its item."""
        return np.arange(self.size) - self.spread(self.first)

    def _bounds(self, start, stop):
        """``stop`` (None: the end) and the first rows, last rows and closed flags of the
        items that overlap rows ``start:stop``."""
        stop = self.size if stop is None else stop
        lo, hi = np.searchsorted(self.last, start), np.searchsorted(self.first, stop)
        return stop, self.first[lo:hi], self.last[lo:hi], self.closed[lo:hi]

    def following(self, values, start=0, stop=None):
        """Each row's successor within its item (rows along the last axis), for rows
        ``start:stop``; a last row takes its item's first row (closed) or keeps its own
        value (open)."""
        stop, first, last, closed = self._bounds(start, stop)
        out = np.empty(values.shape[:-1] + (stop - start,), values.dtype)
        out[..., :-1] = values[..., start + 1:stop]
        if stop < self.size:
            out[..., -1] = values[..., stop]
        inside = (last >= start) & (last < stop)
        out[..., last[inside] - start] = values[..., np.where(closed, first, last)[inside]]
        return out

    def preceding(self, values, start=0, stop=None):
        """Each row's predecessor within its item, for rows ``start:stop``; a first row
        takes its item's last row (closed) or keeps its own value (open)."""
        stop, first, last, closed = self._bounds(start, stop)
        out = np.empty(values.shape[:-1] + (stop - start,), values.dtype)
        out[..., 1:] = values[..., start:stop - 1]
        if start > 0:
            out[..., 0] = values[..., start - 1]
        inside = (first >= start) & (first < stop)
        out[..., first[inside] - start] = values[..., np.where(closed, last, first)[inside]]
        return out

    def sums(self, values):
        """(G,) sum of ``values`` over each item's rows."""
        return np.add.reduceat(values, self.first)

    def exclusive_cumsum(self, values, out=None):
        """Running sum within each item of the rows before each row (0 at each first row)."""
        out = np.empty(self.size) if out is None else out
        out[0] = 0.0
        np.cumsum(values[:-1], out=out[1:])
        out -= self.spread(out[self.first])
        return out
