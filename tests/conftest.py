"""Shared pytest options."""

import sys
from pathlib import Path

# test-only helpers (tests/oracle.py) import by name
sys.path.insert(0, str(Path(__file__).parent))


def pytest_addoption(parser):
    parser.addoption("--fuzz-long", action="store_true",
                     help="run the seeded fuzz of tests/test_hostile_fuzz.py ten times longer")

