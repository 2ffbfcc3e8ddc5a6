"""One table of the OpenCL kernels and their numpy twins.

Each compute step that has an OpenCL kernel registers the pair here under a name, with
one signature for both. Callers ask for ``implementation(name, backend)`` once; the
backend is resolved by :func:`~invrad_wb.core.accel.device.check_backend` (``'auto'``:
OpenCL when a device is usable and ``INVRAD_OPENCL`` is not ``0``, else numpy, with one
warning saying why; ``'opencl'`` without a device raises :class:`DeviceError`), so no call
site writes the if/else out. ``tests/test_accel.py`` runs a parity test for every
registered pair and fails for a pair that has no test case.
"""
from dataclasses import dataclass

from invrad_wb.core.accel.device import check_backend

_PAIRS = {}
#: modules that register pairs when imported
_MODULES = ("invrad_wb.core.forward.direct", "invrad_wb.core.forward.occlusion",
            "invrad_wb.core.forward.radiosity", "invrad_wb.core.inverse.votes",
            "invrad_wb.core.inverse.votes_ellipse")


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


def pairs():
    """Every registered pair, by name."""
    import importlib
    for m in _MODULES:
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
