"""Shared fixtures and hypothesis settings.

Profiles: "default" (what CI runs) and "thorough" (HYPOTHESIS_PROFILE=thorough, 10x examples).

With BATECHO_FORBID_SKIPS=1 (set by .ci/run) a run with any skipped test fails: everything a
test needs is in the repository or installed by the test extra.
"""

from __future__ import annotations

import os

import numpy as np
import pytest
from hypothesis import HealthCheck, settings

settings.register_profile(
    "default",
    max_examples=60,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
    derandomize=True,
    print_blob=True,
)
settings.register_profile(
    "thorough",
    max_examples=600,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
    print_blob=True,
)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "default"))


def pytest_sessionfinish(session, exitstatus):
    if os.environ.get("BATECHO_FORBID_SKIPS") != "1" or exitstatus != 0:
        return
    reporter = session.config.pluginmanager.get_plugin("terminalreporter")
    skipped = reporter.stats.get("skipped", []) if reporter else []
    if skipped:
        for rep in skipped:
            reporter.write_line(f"SKIPPED (forbidden by BATECHO_FORBID_SKIPS): {rep.nodeid}")
        session.exitstatus = pytest.ExitCode.TESTS_FAILED


@pytest.fixture(scope="session")
def canonical_leaves():
    """Ming's canonical leaf box (a smaller copy for tests): 25 leaves/m^3 in
    x in [1, 10], y, z in [-2, 2]; radius N(2 cm, 0.2 cm); normals at N(85, 5) deg from x."""
    from batecho.echoes.canonical import canonical_leaf_box

    return canonical_leaf_box(np.random.default_rng(2017))
