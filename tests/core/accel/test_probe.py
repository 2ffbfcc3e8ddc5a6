"""The OpenCL self-test of a driver that may abort (core/accel/probe.py): a child that dies
as PoCL 3.0 from PyPI does on an AMD Zen 4 (SIGABRT while compiling) gives a one-line
reason, kept so that the next run does not test again; other drivers are not tested."""
import os
import signal
from types import SimpleNamespace

import pytest

from invrad_wb.core.accel import probe


def _device(platform="Portable Computing Language"):
    return SimpleNamespace(platform=SimpleNamespace(name=platform, version="OpenCL 3.0 PoCL"),
                           name="pthread-test CPU", version="OpenCL 3.0",
                           driver_version="3.0")


CL = SimpleNamespace(VERSION_TEXT="2026.1.4")


def test_a_child_that_aborts_gives_a_reason_kept_for_the_next_run(tmp_path, monkeypatch):
    monkeypatch.setenv(probe.ENV_FAKE_ABORT, "1")
    why = probe.verdict(CL, _device(), str(tmp_path))
    assert why is not None and "failed invrad's self-test" in why
    assert f"signal {int(signal.SIGABRT)}" in why and "\n" not in why
    kept = [f for f in os.listdir(tmp_path) if f.startswith("opencl-probe-")]
    assert len(kept) == 1
    # the next run reads the verdict: no child
    def no_child(*a, **k):
        raise AssertionError("the self-test ran again")
    monkeypatch.setattr(probe.subprocess, "run", no_child)
    assert probe.verdict(CL, _device(), str(tmp_path)) == why


def test_only_pypi_pocl_is_tested_and_never_in_the_child(monkeypatch):
    import importlib.util
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda n, *a: object() if n == "pocl_binary_distribution"
                        else real(n, *a))
    monkeypatch.delenv(probe.ENV_CHILD, raising=False)
    assert probe.needs_probe(_device())
    assert not probe.needs_probe(_device("NVIDIA CUDA"))
    monkeypatch.setenv(probe.ENV_CHILD, "1")
    assert not probe.needs_probe(_device())
    monkeypatch.delenv(probe.ENV_CHILD)
    monkeypatch.setattr(importlib.util, "find_spec", lambda n, *a: None)
    assert not probe.needs_probe(_device())       # Debian's PoCL: used as before


@pytest.mark.slow
def test_a_working_driver_passes_the_self_test(tmp_path):
    """The child's real run (example scene, locate) on this machine's OpenCL device."""
    from invrad_wb.core.accel.device import get_env, opencl_available
    if not opencl_available():
        pytest.skip("no OpenCL device here")
    env = get_env()
    assert probe.verdict(env.cl, env.device, str(tmp_path)) is None
