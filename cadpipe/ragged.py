"""Many variable-length items (paths, tubes) in one set of numpy arrays.

A batch of G items is stored as their rows concatenated plus offsets, as shapely 2
and awkward arrays do: item g owns rows ``starts[g]:starts[g + 1]``. The helpers
here shift, sum and accumulate within items without a Python loop over them, so a
batch of a thousand pipes costs the same handful of numpy calls as one pipe. A
single path or pipe is a batch of one; there is no separate single-item code.
"""

from functools import cached_property

import numpy as np


class Groups:
    """Row ranges of G items, each open or closed (its last row leads back to its first).

    Parameters
    ----------
    counts : (G,) array_like of int
        Rows per item, each at least 2.
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
        """One value (or row) per item repeated over that item's rows."""
        return np.repeat(per_item, self.counts, axis=0)

    def local(self):
        """(N,) position of each row within its item."""
        return np.arange(self.size) - self.spread(self.first)

    def wrap(self, rows):
        """The row after each of ``rows`` (item-local last rows): the item's first row if
        it is closed, else the row itself (an open item has nothing after its end)."""
        return np.where(self.closed, self.first, rows)

    def following(self, values):
        """Each row's successor within its item; a last row takes its item's first row
        (closed) or keeps its own value (open)."""
        out = np.empty_like(values)
        out[:-1] = values[1:]
        last = self.last
        out[last] = values[self.wrap(last)]
        return out

    def preceding(self, values):
        """Each row's predecessor within its item; a first row takes its item's last
        row (closed) or keeps its own value (open)."""
        out = np.empty_like(values)
        out[1:] = values[:-1]
        first = self.first
        out[first] = values[np.where(self.closed, self.last, first)]
        return out

    def sums(self, values):
        """(G,) sum of ``values`` over each item's rows."""
        return np.add.reduceat(values, self.first)

    def exclusive_cumsum(self, values):
        """Running sum within each item of the rows before each row (0 at each first row)."""
        out = np.empty(self.size)
        out[0] = 0.0
        np.cumsum(values[:-1], out=out[1:])
        out -= self.spread(out[self.first])
        return out
