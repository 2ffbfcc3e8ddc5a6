"""Shared pytest set-up for the core tests.

``@pytest.mark.opencl`` is the one way a test says it needs an OpenCL device (also as
``pytest.param(..., marks=pytest.mark.opencl)``). Such tests are skipped, with the reason
(no pyopencl, no driver, or ``INVRAD_OPENCL=0``), where no device is usable. Tests that
merely want the fastest backend pass ``backend="auto"``. FreeCAD's tests live in
tests/freecad and run under freecadcmd.
"""
import os
import sys

import numpy as np
import pytest

# The checkout first (invrad_wb), then tests/ (repo_paths: where the checkout is, for tests at
# any depth). The folders mirror invrad_wb's subpackages: tests/core/<subpackage>, tests/cli,
# tests/app; tests/core/io/scene_file_helpers.py is what the scene-file tests share.
_TESTS = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, _TESTS)
sys.path.insert(0, os.path.dirname(_TESTS))


def pytest_configure(config):
    config.addinivalue_line("markers", "opencl: needs an OpenCL device")
    config.addinivalue_line(
        "markers", "slow: a long end-to-end run; the host's suite runs it, the FreeCAD 1.0"
        " root's Python 3.13 / numpy 2 pass leaves it out (make test-freecad1)")


def pytest_collection_modifyitems(config, items):
    needs = [item for item in items if item.get_closest_marker("opencl") is not None]
    if not needs:
        return                                    # no device set-up for numpy-only runs
    from invrad_wb.core.accel.device import opencl_unavailable_reason
    reason = opencl_unavailable_reason()
    if reason is None:
        return
    skip = pytest.mark.skip(reason=f"needs OpenCL: {reason}")
    for item in needs:
        item.add_marker(skip)


@pytest.fixture
def rng():
    return np.random.default_rng(1234)
