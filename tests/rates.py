"""Test-only: the build rate of a hypothesis strategy of valid inputs.

A strategy of valid inputs must mostly build (the rest refused only by the documented
self-intersection checks); a sea of rejected inputs would test nothing.
"""

from collections import Counter

from hypothesis import settings

#: valid inputs that must build, at least
MIN_BUILD_RATE = 0.9


def assert_builds_mostly(run, examples, label, base):
    """Run the hypothesis test ``run(outcomes)`` under ``base`` settings for ``examples``
    examples and assert that most built (``outcomes["built"]``); the counts are printed,
    shown with ``pytest -s``."""
    outcomes = Counter()
    settings(base, max_examples=examples)(run)(outcomes)
    total = sum(outcomes.values())
    print(f"{label}: {dict(outcomes)}")
    assert total >= examples // 2, outcomes
    assert outcomes["built"] / total >= MIN_BUILD_RATE, outcomes
