"""Fail-fast safety limits: refuse work that would exhaust memory or time, before it starts.

A spec from someone else, a typo (``step = 1e-12``) or a hostile file (a zip bomb
inside a 3MF) must end in a clear :class:`~cadpipe.errors.LimitError` within
moments, not in an allocation of terabytes or a run killed after minutes. Each
check compares a size estimated from the inputs (triangles from sides x rings,
samples from length / step, bytes an archive expands to) with a budget.

The budgets are one frozen :class:`Limits` value held in a context variable, so
every layer reads the same numbers without passing them down: the API sets them
with :func:`using` (``with cadpipe.limits.using(max_triangles=10**8): ...``), a
spec with a top-level key of the same name (``max_triangles = 100_000_000``), the
CLI with one flag each (``--max-triangles 100000000``), as slicers and compilers
take one option per setting. The limits on the spec file itself
(:data:`READ_LIMITS`) are checked before its keys are read, so only the API and
the CLI set them. A message names the limit and the ways to raise it.
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
    max_swept_segments : int
        Path segments of one pipe merged into its swept solid where it comes back
        within its own reach, and pairs of its segments within reach of each other
        that the search for them tests (each pair costs about 25 us and the memory
        of two convex units; a coil whose turns are closer than its diameter has a
        hundred pairs per segment).
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
    max_jobs : int
        Jobs in one batch, grids and rows expanded (counted before they are).
    """

    max_triangles: int = 5_000_000
    max_samples: int = 1_000_000
    max_swept_segments: int = 200_000
    max_parts: int = 10_000
    max_spec_bytes: int = 64 << 20
    max_depth: int = 64
    max_number_chars: int = 100
    max_expansion: float = 200.0
    max_unpacked_bytes: int = 4 << 30
    max_jobs: int = 100_000


_CURRENT = contextvars.ContextVar("cadpipe_limits", default=Limits())  # noqa: B039 (frozen)

#: what each budget counts, as the messages say it
_UNITS = {"max_triangles": "triangles", "max_samples": "path samples", "max_parts": "parts",
          "max_swept_segments": "segments or segment pairs",
          "max_spec_bytes": "bytes",
          "max_depth": "levels of nesting", "max_number_chars": "digits",
          "max_expansion": "times expansion", "max_unpacked_bytes": "bytes unpacked",
          "max_jobs": "jobs"}



def _names():
    return tuple(f.name for f in dataclasses.fields(Limits))


#: budgets on reading the spec file itself: checked before its keys can say anything
READ_LIMITS = ("max_spec_bytes", "max_depth", "max_number_chars")
#: what each budget bounds, for the CLI's help and the docs
_HELP = {"max_triangles": "refuse work that would make more triangles than N",
         "max_samples": "refuse a path sampled at more than N points",
         "max_swept_segments": "refuse a pipe whose swept solid merges more than N path "
                               "segments, or whose search for them tests more than N "
                               "pairs (where it comes back within its own reach)",
         "max_parts": "refuse a spec of more than N parts",
         "max_spec_bytes": "refuse a spec file larger than N bytes",
         "max_depth": "refuse a spec nesting tables and lists deeper than N",
         "max_number_chars": "refuse a number in a spec longer than N characters",
         "max_expansion": "refuse an archive (3MF, USDZ, GLB) expanding more than N times",
         "max_unpacked_bytes": "refuse an archive or binary file expanding to more than N "
                               "bytes",
         "max_jobs": "refuse a batch of more than N jobs (grids and rows expanded)"}

#: the budgets a JOBS file sets with a top-level key of the same name (a spec has no jobs)
JOBS_KEYS = ("max_jobs",)
#: the budgets a spec sets with a top-level key of the same name
SPEC_KEYS = tuple(n for n in _names() if n not in READ_LIMITS + JOBS_KEYS)
#: the budgets the CLI sets with a flag each (``--max-triangles N``): all of them
CLI_FLAGS = _names()


def flag(name: str) -> str:
    """The command-line flag of budget ``name``: ``--max-triangles``."""
    return "--" + name.replace("_", "-")


def describe(name: str) -> str:
    """What budget ``name`` bounds and its default, in a sentence (CLI help, docs)."""
    default = getattr(Limits(), name)
    return f"{_HELP[name]} (default {default:,})"


def current() -> Limits:
    """The budgets in force here (see :func:`using`)."""
    return _CURRENT.get()


@contextmanager
def using(**budgets):
    """Run a block with some budgets changed, e.g. ``using(max_triangles=50_000_000)``.

    Values of None keep the budget in force; an unknown name is an error.
    """
    now = current()
    changes = {name: value for name, value in checked(budgets).items() if value is not None}
    token = _CURRENT.set(dataclasses.replace(now, **changes))
    try:
        yield current()
    finally:
        _CURRENT.reset(token)


def checked(budgets: dict) -> dict:
    """``budgets`` ({name: value or None}) validated: known names, positive numbers
    (whole for counts; ``max_expansion`` may be fractional). Raises
    :class:`~cadpipe.errors.InputError` with ``key=`` the name."""
    from cadpipe._validate import as_int, as_positive
    from cadpipe.errors import InputError

    known = _names()
    out = {}
    for name, value in budgets.items():
        if name not in known:
            raise InputError(f"unknown limit; known: {', '.join(known)}", key=name)
        if value is None:
            out[name] = None
        elif isinstance(getattr(Limits(), name), float):
            out[name] = float(as_positive(value, name))
        else:
            out[name] = as_int(value, name, low=1, high=2 ** 62)
    return out


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
        ways += [f"the JOBS key {name}"] if name in JOBS_KEYS else []
        ways += [flag(name)] if name in CLI_FLAGS else []
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
