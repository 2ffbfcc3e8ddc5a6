"""The kernel binary cache (:mod:`invrad_wb.core.accel.device`): a program built once is
loaded from its binary in a later process, computes the same, and a binary that does not
load (corrupt, another driver's) is rebuilt from source without a word."""
import os

import numpy as np
import pytest

from invrad_wb import constants as C
from invrad_wb.core.accel import device

SRC = ("__kernel void scale(__global const float *a, __global float *o, const float k)\n"
       "{\n    int i = get_global_id(0);\n    o[i] = k * a[i] + HALF;\n}\n")


def _fresh(name, options):
    """Forget this process's build of ``name`` (as a new process would start)."""
    for key in [k for k in device._programs if k[1] == name]:
        del device._programs[key]
    for key in [k for k in device._kernels if k[1] == name]:
        del device._kernels[key]
    return device.get_env().program(name, options), device.builds[-1]["how"]


def _run(prg):
    env = device.get_env()
    cl = env.cl
    a = np.arange(64, dtype=np.float32)
    o = np.empty_like(a)
    mf = cl.mem_flags
    da = cl.Buffer(env.ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=a)
    do = cl.Buffer(env.ctx, mf.WRITE_ONLY, o.nbytes)
    prg.scale(env.queue, a.shape, None, da, do, np.float32(3.0))
    cl.enqueue_copy(env.queue, o, do)
    return o


@pytest.mark.opencl
def test_a_built_kernel_is_loaded_from_its_binary_and_computes_the_same(tmp_path,
                                                                          monkeypatch):
    kernels, cache = tmp_path / "kernels", tmp_path / "cache"
    kernels.mkdir()
    (kernels / "scale.cl").write_text(SRC)
    monkeypatch.setattr(C, "KERNELS_DIR", str(kernels))
    monkeypatch.setenv(device.ENV_KERNEL_CACHE, str(cache))
    opts = ("-D HALF=0.5f",)
    prg, how = _fresh("scale", opts)
    assert not how.startswith("binary")                      # the first: from source
    want = np.arange(64, dtype=np.float32) * 3.0 + 0.5
    np.testing.assert_array_equal(_run(prg), want)
    (binary,) = list(cache.iterdir())
    prg, how = _fresh("scale", opts)
    assert how.startswith("binary")                          # a later one: the binary
    np.testing.assert_array_equal(_run(prg), want)
    # other options, another program: not the cached binary
    prg, how = _fresh("scale", ("-D HALF=1.5f",))
    assert not how.startswith("binary")
    np.testing.assert_array_equal(_run(prg), want + 1.0)
    # a header of kernels/ changed: every binary is stale
    (kernels / "extra.h").write_text("#define UNUSED 1\n")
    prg, how = _fresh("scale", opts)
    assert not how.startswith("binary")
    # a corrupt binary: rebuilt from source, same answer, the binary replaced
    for f in cache.iterdir():
        f.write_bytes(b"not a program")
    prg, how = _fresh("scale", opts)
    assert not how.startswith("binary")
    np.testing.assert_array_equal(_run(prg), want)
    assert binary.exists() or len(list(cache.iterdir())) >= 1
    prg, how = _fresh("scale", opts)
    assert how.startswith("binary")


@pytest.mark.opencl
def test_the_cache_can_be_switched_off(tmp_path, monkeypatch):
    kernels = tmp_path / "kernels"
    kernels.mkdir()
    (kernels / "scale.cl").write_text(SRC)
    monkeypatch.setattr(C, "KERNELS_DIR", str(kernels))
    monkeypatch.setenv(device.ENV_KERNEL_CACHE, "0")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert device.kernel_cache_dir() is None
    for _ in range(2):
        prg, how = _fresh("scale", ("-D HALF=0.5f",))
        assert not how.startswith("binary")
    assert not os.path.exists(tmp_path / "xdg")
