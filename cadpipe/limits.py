"""Fail-fast safety limits: refuse work that would exhaust memory or time, before it starts.

A spec from someone else, a typo (``step = 1e-12``) or a hostile file (a zip bomb
inside a 3MF) must end in a clear :class:`~cadpipe.errors.LimitError` within
moments, not in an allocation of terabytes or a run killed after minutes. Each
check compares a size estimated from the inputs (triangles from sides x rings,
samples from length / step, bytes an archive expands to) with a budget.

The budgets are one frozen :class:`Limits` value held in a context variable, so
every layer reads the same numbers without passing them down: the API sets them
with :func:`using` (``with cadpipe.limits.using(max_triangles=10**8): ...``), a
spec with its ``max_triangles`` key, the CLI with ``--max-triangles``. A message
names the limit and these three ways to raise it.
"""

from __future__ import annotations

import contextvars
import dataclasses
import zipfile
from contextlib import contextmanager
from dataclasses import dataclass

from cadpipe.errors import LimitError


@dataclass(frozen=True)
class Limits:
    """The budgets every check reads.

    Parameters
    ----------
    max_triangles : int
        Triangles in any one mesh or assembly about to be built (5 M: a 250 MB STL;
        a ``segments = 4096`` sphere has 8.4 M).
    max_samples : int
        Points sampled along one path (a fitted spline's ``step``/``tolerance``).
    max_parts : int
        Parts in one spec.
    max_spec_bytes : int
        Size of a spec file (a spec of the most parts allowed is a few MB).
    max_depth : int
        Nesting of tables and lists in a spec file.
    max_number_chars : int
        Characters of one number in a spec file.
    max_expansion : float
        Uncompressed over compressed size of an archive read (3MF, USDZ are zips).
    max_unpacked_bytes : int
        Bytes an archive read may expand to in all.
    """

    max_triangles: int = 5_000_000
    max_samples: int = 1_000_000
    max_parts: int = 10_000
    max_spec_bytes: int = 64 << 20
    max_depth: int = 64
    max_number_chars: int = 100
    max_expansion: float = 200.0
    max_unpacked_bytes: int = 4 << 30


_CURRENT = contextvars.ContextVar("cadpipe_limits", default=Limits())  # noqa: B039 (frozen)

#: what each budget counts, as the messages say it
_UNITS = {"max_triangles": "triangles", "max_samples": "path samples", "max_parts": "parts",
          "max_spec_bytes": "bytes",
          "max_depth": "levels of nesting", "max_number_chars": "digits",
          "max_expansion": "times expansion", "max_unpacked_bytes": "bytes unpacked"}

#: the budgets a spec sets with a key of the same name, and those the CLI sets with a flag
SPEC_KEYS = ("max_triangles", "max_samples", "max_parts")
CLI_FLAGS = ("max_triangles",)


def current() -> Limits:
    """The budgets in force here (see :func:`using`)."""
    return _CURRENT.get()


@contextmanager
def using(**budgets):
    """Run a block with some budgets changed, e.g. ``using(max_triangles=50_000_000)``.

    Values of None keep the budget in force; an unknown name is an error.
    """
    from cadpipe._validate import as_int

    now = current()
    changes = {}
    for name, value in budgets.items():
        if not hasattr(now, name):
            raise LimitError(f"unknown limit; known: {', '.join(_names())}", key=name)
        if value is not None:
            changes[name] = as_int(value, name, low=1, high=2 ** 62)
    token = _CURRENT.set(dataclasses.replace(now, **changes))
    try:
        yield current()
    finally:
        _CURRENT.reset(token)


def _names():
    return [f.name for f in dataclasses.fields(Limits)]


def check(name: str, needed: float, what: str, *, at_least: bool = False, **where) -> None:
    """Raise :class:`LimitError` when ``needed`` exceeds the budget ``name``.

    ``what`` says what was measured ("a sphere of segments = 4096"); ``where``
    (``key=``, ``part=``, ``file=``) locates the input that asked for it;
    ``at_least`` says ``needed`` is a lower bound (counting stopped there).
    """
    limit = getattr(current(), name)
    if not needed <= limit:                       # NaN and inf are over any limit
        ways = [f"cadpipe.limits.using({name}=...)"]
        ways += [f"the spec key {name}"] if name in SPEC_KEYS else []
        ways += [f"--{name.replace('_', '-')}"] if name in CLI_FLAGS else []
        amount = "more than can be counted" if not needed < 1e30 else \
            f"{'at least' if at_least else 'about'} {needed:,.0f}"
        raise LimitError(f"{what} needs {amount} {_UNITS[name]}, more than the limit of "
                         f"{limit:,}; raise it with {' or '.join(ways)}", **where)


def estimated_triangles(obj) -> int:
    """Triangles ``obj.mesh()`` will have, estimated without building it.

    A pipe has two triangles per ring vertex and segment, plus its caps; hollow
    parts have an outer and an inner tube per pipe; a :class:`~cadpipe.Mesh` has its
    faces. Anything else counts as 0 (it is measured once built).
    """
    pipes = getattr(obj, "pipes", None)
    if pipes is not None:                               # a junction or a hollow chain
        return sum(2 * estimated_triangles(p) for p in pipes)
    inner = getattr(obj, "pipe", None)
    if inner is not None:                               # a hollow pipe: outer + bore
        return 2 * estimated_triangles(inner)
    sides, path = getattr(obj, "sides", None), getattr(obj, "path", None)
    if isinstance(sides, int) and path is not None:
        caps = 2 * sides * (getattr(obj, "cap_segments", None) or 1)
        return 2 * sides * len(path) + caps
    faces = getattr(obj, "faces", None)
    return 0 if faces is None else len(faces)


def check_archive(path, **where) -> None:
    """Refuse a zip archive (3MF, USDZ) that would expand past the budgets.

    Reads only the archive's directory: the sizes it declares, compared with the
    archive's size (expansion ratio) and with :attr:`Limits.max_unpacked_bytes`.
    Not a zip: nothing to check.
    """
    try:
        with zipfile.ZipFile(path) as archive:
            members = archive.infolist()
    except (zipfile.BadZipFile, OSError, ValueError):
        return
    unpacked = sum(m.file_size for m in members)
    packed = max(1, sum(m.compress_size for m in members))
    where = {"file": path, **where}
    check("max_unpacked_bytes", unpacked, "unpacking this archive", **where)
    if unpacked > (1 << 20):                           # small files may compress very well
        check("max_expansion", unpacked / packed, "this archive (a zip bomb?)", **where)
