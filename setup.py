"""cadpipe's compiled kernels: one C extension, built when cadpipe is installed.

The metadata is in pyproject.toml; this file only adds the extension, whose
sources are every file of cadpipe/core/csrc (compiled as one translation unit,
module.c). Their hash is compiled in, so cadpipe.core.kernels can refuse an
extension built from other sources than the tree holds (a C file edited since the
last build can never run stale).
"""

import hashlib
import platform
from pathlib import Path

import numpy
from setuptools import Extension, setup

SOURCES = Path(__file__).parent / "cadpipe" / "core" / "csrc"


def source_hash():
    """sha256 over the kernel sources' names and bytes (cadpipe.core.kernels computes the
    same)."""
    digest = hashlib.sha256()
    for path in sorted(SOURCES.iterdir()):
        if path.suffix in (".c", ".h"):
            digest.update(path.name.encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()


# IEEE arithmetic as written (no fused multiply-adds: the kernels' bounds assume each
# product rounded on its own), no errno from libm
FLAGS = ["-O3", "-std=c11", "-ffp-contract=off", "-fno-math-errno", "-Wall",
         "-Wno-unused-function"]
if platform.machine() in ("x86_64", "AMD64"):
    FLAGS.append("-march=x86-64-v2")        # SSE4.2 and POPCNT: every x86-64 CPU since 2009

setup(ext_modules=[Extension(
    "cadpipe.core._kernels", [str((SOURCES / "module.c").relative_to(Path(__file__).parent))],
    include_dirs=[numpy.get_include()], depends=[str(p.relative_to(Path(__file__).parent)) for p in sorted(SOURCES.iterdir())],
    define_macros=[("CP_SOURCE_HASH", f'"{source_hash()}"')], extra_compile_args=FLAGS)])
