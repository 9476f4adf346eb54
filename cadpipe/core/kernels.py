"""cadpipe's compiled kernels: the C extension ``cadpipe.core._kernels``, checked fresh.

The kernels are C (``cadpipe/core/csrc``), compiled when cadpipe is installed, so no
process compiles anything at start-up. The extension carries the hash of the sources
it was built from; where those sources are present (a source checkout, an editable
install) they must hash the same, so an edited kernel can never run stale: the import
fails and says how to rebuild. Use the kernels as ``native.name(...)`` after
``from cadpipe.core.kernels import native``; their arguments are exactly typed arrays
(see csrc/native.h), which the Python functions around them prepare.
"""

import hashlib
from pathlib import Path

SOURCES = Path(__file__).with_name("csrc")
REBUILD = ("rebuild them with `make` or `pip install -e .` in the cadpipe checkout "
           "(a C compiler and the Python headers are needed)")


def source_hash(folder=SOURCES):
    """sha256 over the kernel sources' names and bytes, as setup.py computes it."""
    digest = hashlib.sha256()
    for path in sorted(folder.iterdir()):
        if path.suffix in (".c", ".h"):
            digest.update(path.name.encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()


try:
    import cadpipe.core._kernels as native
except ImportError as exc:               # a source tree whose extension was never built
    raise ImportError(f"cadpipe's compiled kernels are missing ({exc}); {REBUILD}") from None

if SOURCES.is_dir() and native.SOURCE_HASH != source_hash():
    raise ImportError(f"cadpipe's compiled kernels were built from other sources than "
                      f"{SOURCES} holds now; {REBUILD}")

__all__ = ["native", "source_hash"]
