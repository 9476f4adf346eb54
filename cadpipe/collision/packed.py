"""A world's arrays as one compiled record, so one state is one kernel call.

``native.refresh`` (:mod:`cadpipe.collision.funnel`) decides one state where
the objects stand: it places the objects that moved, tries every pair whose
answer is older than its objects' poses, settles the pairs of pipes and other
chains exactly, and writes the report's arrays. It reads some fifty arrays
(the objects' bounds and convex pieces, the pair table, the capsule and
triangle trees, each pair's last answer). Checked as separate arguments on
every call, they would cost more than a pipe's whole yes/no walk; a
:class:`Packed` record (a C object, ``csrc/packed.c``) holds a reference to
each array and its data pointer, checked once when the record is made, so a
per-state call checks one argument with one pointer comparison.

The record holds the arrays themselves, not copies: the scene's poses and
pose versions, the checker's placed bounds and stored answers are the same
memory the Python side reads, so a record stays valid for as long as the
layout it was made for (:class:`cadpipe.collision.checker.Checker` makes a new
one when the layout changes). It also holds the last call's scratch (the pairs
left to Python, the hits), so one world takes one check at a time, as its
stored answers already required.
"""

from cadpipe.core.kernels import native

#: the record's fields, in the order :func:`pack` hands them to the kernel: ``(name,
#: dtype, ndim)``, N objects and P pairs (``np.triu_indices`` order); the one list is
#: ``csrc/packed.c``'s, which also says what each holds and checks the extents that tie
#: them together
FIELDS = native.packed_fields()

#: a world's arrays for ``native.refresh`` and ``native.collide_pose``; made by :func:`pack`
Packed = native.Packed


def pack(certify=False, **arrays):
    """A :class:`Packed` record of ``arrays`` (one per name of :data:`FIELDS`, each
    already of the field's dtype and dimensions, C-ordered and writeable: the record
    shares them, it does not copy) and ``certify`` (no hull stage, and every exact
    pair is left to Python, for the certificate).

    Raises
    ------
    TypeError
        A field missing, unknown, or not an array of its kind.
    ValueError
        Fields whose extents or offsets do not fit together.
    """
    missing = [name for name, _, _ in FIELDS if name not in arrays]
    unknown = set(arrays) - {name for name, _, _ in FIELDS}
    if missing or unknown:
        raise TypeError(f"packed fields missing: {', '.join(missing) or '-'}; "
                        f"not packed fields: {', '.join(sorted(unknown)) or '-'}")
    return native.pack(*(arrays[name] for name, _, _ in FIELDS), bool(certify))
