"""One table of the OpenCL kernels and their numpy twins.

Each compute step that has an OpenCL kernel registers the pair here under a name, with
one signature for both. Callers ask for ``implementation(name, backend)`` once; the
backend is resolved by :func:`~invrad_wb.core.accel.clenv.check_backend` (``'auto'``: OpenCL
when a device is usable and ``INVRAD_OPENCL`` is not ``0``, else numpy, with one warning
saying why). ``tests/test_accel.py`` runs a parity test for every registered pair.
"""
from dataclasses import dataclass

from invrad_wb.core.accel.clenv import check_backend

_PAIRS = {}
#: modules that register pairs when imported
_MODULES = ("invrad_wb.core.forward.direct", "invrad_wb.core.forward.occlusion",
            "invrad_wb.core.forward.radiosity", "invrad_wb.core.inverse.votes",
            "invrad_wb.core.inverse.votes_ellipse")


@dataclass(frozen=True)
class Pair:
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
    """The function of ``name`` for ``backend`` ('auto', 'opencl' or 'numpy')."""
    pair = _PAIRS.get(name) or pairs()[name]
    return pair.opencl if check_backend(backend) == "opencl" else pair.numpy
