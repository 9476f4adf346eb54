"""Shared pytest options and fixtures."""

import sys
from pathlib import Path

import numpy as np
import pytest

# test-only helpers (tests/oracle.py) import by name
sys.path.insert(0, str(Path(__file__).parent))


def pytest_addoption(parser):
    parser.addoption("--fuzz-long", action="store_true",
                     help="run the seeded fuzz of tests/test_hostile_fuzz.py ten times longer")



@pytest.fixture(scope="module")
def two_part_scene():
    """A millimetre scene of two coloured parts, one moved by its transform."""
    import cadpipe
    from cadpipe.solids.scene import Scene, ScenePart

    duct = cadpipe.Pipe(cadpipe.Path.spline([[0, 0, 0], [40, 0, 10], [60, 30, 20]], step=2),
                        4, sides=16).mesh()
    rod = cadpipe.Pipe([[0, 30, 0], [0, 30, 50]], 3, sides=8).mesh()
    move = np.eye(4)
    move[:3, 3] = [10, 0, 5]
    return Scene("cell", (ScenePart("duct", duct, color=(1.0, 0.0, 0.0), transform=move),
                          ScenePart("rod", rod, color=(0.0, 0.0, 1.0))), units="mm")
