"""Shared pytest set-up for the core tests.

``@pytest.mark.opencl`` marks tests that need an OpenCL device; they are skipped (with the
reason) where none exists. FreeCAD's tests live in tests/freecad and run under freecadcmd.
"""
import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def pytest_configure(config):
    config.addinivalue_line("markers", "opencl: needs an OpenCL device")


def pytest_collection_modifyitems(config, items):
    from invrad_wb.core.accel import clenv
    if clenv.opencl_available():
        return
    skip = pytest.mark.skip(reason="no OpenCL device")
    for item in items:
        if "opencl" in item.keywords:
            item.add_marker(skip)


@pytest.fixture
def rng():
    return np.random.default_rng(1234)
