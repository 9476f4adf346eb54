"""Where ``package://NAME/...`` mesh references in a URDF point to.

ROS tools resolve a package name to its folder through an index; cadpipe
does it without ROS, looking in the places a robot description is found in
practice, in this order:

1. the folders the caller names (``package_dirs``: a mapping of name to
   folder, or folders that either are the package or hold it);
2. ``ROS_PACKAGE_PATH`` (folders that are or hold packages) and
   ``AMENT_PREFIX_PATH`` (install prefixes with ``share/NAME``);
3. the URDF's own package, found by walking up from the URDF to a folder
   whose ``package.xml`` names it (or that is called NAME);
4. ``share/NAME`` under the Python environment's prefixes, which is where
   wheels of robot packages put them (``example-robot-data`` installs
   ``site-packages/cmeel.prefix/share/example-robot-data``).

``package:///NAME/rest`` (an empty host, as some exporters write) means the
same as ``package://NAME/rest``; ``file://`` paths are absolute.
"""

import os
import re
import site
import sys
from pathlib import Path as FilePath

from cadpipe.errors import InputError

_NAME = re.compile(r"<name>\s*([^<\s]+)\s*</name>")


def resolve(reference, urdf, package_dirs=None):
    """The file a URDF mesh ``reference`` names, as a path.

    Parameters
    ----------
    reference : str
        ``package://NAME/rest``, ``package:///NAME/rest``, ``file:///abs`` or a
        path relative to the URDF's folder.
    urdf : path
        The URDF file the reference comes from.
    package_dirs : mapping or sequence of paths, optional
        See the module docstring.

    Raises
    ------
    InputError
        For a package that is in none of the searched folders (they are listed).
    """
    urdf = FilePath(urdf)
    if reference.startswith("file://"):
        return FilePath(reference[len("file://"):])
    if not reference.startswith("package://"):
        return urdf.parent / reference
    name, _, rest = reference[len("package://"):].lstrip("/").partition("/")
    searched = []
    for folder in _candidates(name, urdf, package_dirs):
        searched.append(str(folder))
        if folder.is_dir():
            return folder / rest
    raise InputError(f"package {name!r} (for {reference}) not found; searched "
                     + (", ".join(dict.fromkeys(searched)) or "nothing")
                     + ". Pass package_dirs={'" + name + "': folder} or set ROS_PACKAGE_PATH",
                     key="package_dirs", file=urdf)


def _candidates(name, urdf, package_dirs):
    """Folders that may be package ``name``, in search order (existing or not)."""
    if hasattr(package_dirs, "items"):
        if name in package_dirs:
            yield FilePath(package_dirs[name])
        package_dirs = ()
    elif isinstance(package_dirs, (str, os.PathLike)):
        package_dirs = [package_dirs]
    for folder in map(FilePath, package_dirs or ()):
        yield from _package_or_parent(folder, name)
    for folder in _env_paths("ROS_PACKAGE_PATH"):
        yield from _package_or_parent(folder, name)
    for prefix in _env_paths("AMENT_PREFIX_PATH"):
        yield prefix / "share" / name
    for folder in urdf.resolve().parents:
        if folder.name == name or _manifest_name(folder) == name:
            yield folder
            break
    for prefix in _python_prefixes():
        yield prefix / "share" / name


def _package_or_parent(folder, name):
    if folder.name == name or _manifest_name(folder) == name:
        yield folder
    yield folder / name
    yield folder / "share" / name


def _env_paths(variable):
    return [FilePath(p) for p in os.environ.get(variable, "").split(os.pathsep) if p]


def _manifest_name(folder):
    try:
        found = _NAME.search((folder / "package.xml").read_text(errors="replace"))
    except OSError:
        return None
    return found.group(1) if found else None


def _python_prefixes():
    """``sys.prefix`` and each site-packages folder's ``cmeel.prefix`` (the layout
    of the cmeel wheels robot packages ship as)."""
    roots = [FilePath(sys.prefix)]
    for folder in [*site.getsitepackages(), site.getusersitepackages(), *sys.path]:
        if folder:
            roots.append(FilePath(folder) / "cmeel.prefix")
    return list(dict.fromkeys(roots))
