"""One table of the OpenCL kernels and their numpy twins.

Each compute step that has an OpenCL kernel registers the pair here under a name, with
one signature for both. Callers ask for ``implementation(name, backend)`` once; the
backend is resolved by :func:`~invrad_wb.core.accel.device.check_backend` (``'auto'``:
OpenCL when a device is usable and ``INVRAD_OPENCL`` is not ``0``, else numpy, with one
warning saying why; ``'opencl'`` without a device raises :class:`DeviceError`), so no call
site writes the if/else out. ``tests/core/accel/test_accel.py`` runs a parity test for every
registered pair and fails for a pair that has no test case.
"""
from dataclasses import dataclass
import functools
import os
import re

from invrad_wb.core.accel.device import check_backend

_PAIRS = {}
#: a module-level ``register(...)`` call: how a kernel family's module is found
_REGISTERS = re.compile(r"^register\(", re.M)


@dataclass(frozen=True)
class Pair:
    """An OpenCL wrapper and its numpy twin; both take the same arguments, give the same
    result (to float32 rounding)."""
    name: str
    opencl: object
    numpy: object
    what: str = ""


def register(name, opencl, numpy, what=""):
    """Register an OpenCL implementation and its numpy twin (same signature)."""
    _PAIRS[name] = Pair(name, opencl, numpy, what)
    return _PAIRS[name]


@functools.lru_cache(maxsize=None)
def kernel_modules():
    """The core's modules that register pairs (a module-level ``register(...)`` call),
    found in their source: a new kernel family's module needs no list kept by hand."""
    core = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    out = []
    for folder, dirs, files in os.walk(core):
        dirs[:] = sorted(d for d in dirs if not d.startswith(("_", ".")))
        for f in sorted(files):
            if f.endswith(".py"):
                path = os.path.join(folder, f)
                with open(path, "r", encoding="utf-8") as fh:
                    if _REGISTERS.search(fh.read()):
                        rel = os.path.relpath(path[:-3], os.path.dirname(core))
                        out.append("invrad_wb." + rel.replace(os.sep, "."))
    return tuple(out)


def pairs():
    """Every registered pair, by name (importing the modules that register them)."""
    import importlib
    for m in kernel_modules():
        importlib.import_module(m)
    return dict(_PAIRS)


def implementation(name, backend):
    """The function registered as ``name`` for ``backend`` ('auto', 'opencl' or 'numpy').

    Raises
    ------
    KeyError
        No pair is registered under ``name``.
    DeviceError, SettingsError
        As :func:`~invrad_wb.core.accel.device.check_backend`.
    """
    pair = _PAIRS.get(name) or pairs().get(name)
    if pair is None:
        raise KeyError(f"no OpenCL/numpy pair named {name!r}; registered: {sorted(_PAIRS)}")
    return pair.opencl if check_backend(backend) == "opencl" else pair.numpy
