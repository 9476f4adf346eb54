"""Output memory that cadpipe recycles: a small cache of large, already-touched blocks.

A pipe's or splice's output arrays are large (a 100,000-point, 16-sided pipe writes 115 MB),
and memory that large is fresh from the kernel on every call: glibc maps it anew and unmaps
it on free, numpy asks for transparent huge pages on it, and in a process that does other
work the kernel may compact memory to find them. Interleaved with trimesh in one process, a
pipe that takes 0.06 s alone took 0.06 to 0.53 s, nearly all of it kernel time on those
pages (``docs/performance.md``).

:func:`empty` hands out arrays carved from blocks this module keeps. A block is handed out
again only once nothing refers to it any more (every array made from it is a view whose
``base`` is the block, so its reference count says whether a mesh still uses it): a mesh a
user keeps is never overwritten, and a dropped mesh's memory serves the next one with no
page faults, as PyTorch's caching allocator does for GPU memory. Tracked blocks total at most
:data:`RETAIN_BYTES` (beyond it arrays come from numpy as before), so that is the most memory
kept once unused; :func:`release` hands unused blocks back to the system.
"""

import os
import sys
import threading

import numpy as np

#: arrays smaller than this come from numpy directly (glibc's heap recycles them already;
#: numpy asks for huge pages from 4 MiB up)
MIN_BYTES = 1 << 22
#: block sizes are whole multiples of this (a huge page)
GRAIN = 1 << 21
#: a free block serves a request up to this fraction larger than itself
SLACK = 0.125
#: most bytes in tracked blocks (so at most this stays behind once unused): a sixteenth of
#: physical memory; 0 turns recycling off
RETAIN_BYTES = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") // 16
#: most blocks tracked at once (in use or not); beyond it arrays come from numpy directly
MAX_BLOCKS = 64

_lock = threading.Lock()
_blocks: list[np.ndarray] = []         # (bytes,) uint8, oldest first


def _idle(blocks, refs=None):
    """The blocks that no array uses: referred to only by the list and this function
    (``refs``: that count, measured once on a probe, so it holds on any interpreter)."""
    refs = _IDLE_REFS if refs is None else refs
    return [b for b in blocks if sys.getrefcount(b) == refs]


def _idle_refs():
    """The reference count :func:`_idle` sees on a block only a list holds."""
    probe = [np.empty(1, np.uint8)]
    return next(refs for refs in range(1, 16) if _idle(probe, refs))


_IDLE_REFS = _idle_refs()


def empty(shape, dtype=np.float64) -> np.ndarray:
    """An uninitialized, writeable, C-contiguous array, from a recycled block when large.

    Parameters
    ----------
    shape : int or tuple of int
    dtype : numpy dtype, default float64

    Returns
    -------
    out : ndarray of ``shape``
        A view of a block no live array uses (its ``base``), or a fresh array. The
        caller writes every element before handing it on.
    """
    dtype = np.dtype(dtype)
    shape = (shape,) if isinstance(shape, (int, np.integer)) else tuple(shape)
    count = int(np.prod(shape, dtype=np.int64))
    nbytes = count * dtype.itemsize
    if nbytes < MIN_BYTES:
        return np.empty(shape, dtype)
    with _lock:
        block = _idle_block(nbytes)
        if block is None:
            block = _new_block(nbytes)
    return block[:nbytes].view(dtype).reshape(shape)


def _idle_block(nbytes):
    """The smallest unused block that holds ``nbytes`` with at most :data:`SLACK` to spare."""
    fits = [b for b in _idle(_blocks) if nbytes <= b.size <= nbytes * (1 + SLACK) + GRAIN]
    return min(fits, key=len, default=None)


def _new_block(nbytes):
    """A fresh block of ``nbytes`` rounded up to :data:`GRAIN`, tracked if the tracked
    blocks (in use or not) stay within :data:`RETAIN_BYTES` and :data:`MAX_BLOCKS` once
    the oldest unused ones are dropped: so however many meshes a user keeps and later
    drops, at most that much memory stays behind."""
    block = np.empty(-(-nbytes // GRAIN) * GRAIN, np.uint8)
    tracked = sum(b.size for b in _blocks) + block.size

    def room():
        return tracked <= RETAIN_BYTES and len(_blocks) < MAX_BLOCKS

    for old in _idle(_blocks):
        if room():
            break
        _forget([old])
        tracked -= old.size
    if room():
        _blocks.append(block)
    return block


def retained_bytes() -> int:
    """Bytes held in blocks that no array uses (kept for reuse)."""
    with _lock:
        return sum(b.size for b in _idle(_blocks))


def release() -> int:
    """Hand every unused block back to the system (blocks still in use stay tracked).

    Returns
    -------
    freed : int
        Bytes released.
    """
    with _lock:
        idle = _idle(_blocks)
        _forget(idle)
        return sum(b.size for b in idle)


def _forget(blocks):
    """Stop tracking ``blocks`` (by identity: ``==`` on arrays compares their elements)."""
    gone = {id(b) for b in blocks}
    _blocks[:] = [b for b in _blocks if id(b) not in gone]
