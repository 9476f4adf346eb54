"""What files of float32 coordinates can hold: the one rule for "too close to tell apart".

STL, 3MF, GLB, USD, OBJ and PLY store coordinates as float32 (or their 9-digit decimals),
whose steps at a coordinate ``x`` are about ``EPS * |x|``. Two points closer than a step
at the largest coordinate of a solid may become one point in the file, which turns a
valid solid into one with edges of more than two faces. Everything that makes or checks
a solid for files measures "close" in these steps: at the largest coordinate of the
solid in its own units (a solid is written in the unit it is in, a step scales with it).
"""

import numpy as np

#: one float32 step per unit of magnitude: float32's machine epsilon, 2**-23
EPS = float(np.finfo(np.float32).eps)
#: vertices closer than this many steps may round to one float32 point
CLOSE = 2
#: features (a ring edge) shorter than this many steps are refused where they are made
FINEST = 1
#: the weld of a union's vertex clusters first tries this many steps
WELD = 16
#: a boolean's edges shorter than this many steps are collapsed (a file would merge them)
COLLAPSE = 4


def step(bounds, steps=1):
    """``steps`` float32 steps at the largest coordinate of ``bounds``: any numbers (two
    corners, a point set) whose largest magnitude is the solid's."""
    largest = float(np.abs(np.asarray(bounds, dtype=np.float64)).max(initial=0.0))
    return steps * EPS * largest


def coordinates(points):
    """Are ``points`` float32 values, or their decimals printed with 9 significant digits
    (as cadpipe writes 3MF and OBJ: each within a twelfth of a float32 step of its value)?
    Every one within a quarter step of a float32 counts; coordinates computed in float64
    lie anywhere within half a step, so many of them never pass."""
    rounded = points.astype(np.float32)
    return bool((np.abs(points - rounded) <= 0.25 * np.spacing(np.abs(rounded))).all())
