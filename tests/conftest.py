"""Shared fixtures: skip OpenCL tests when no device exists (CI machines have PoCL)."""
import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from invrad_wb.core import clenv  # noqa: E402

HAVE_OPENCL = clenv.opencl_available()
requires_opencl = pytest.mark.skipif(not HAVE_OPENCL, reason="no OpenCL device")


@pytest.fixture
def rng():
    return np.random.default_rng(1234)
