"""A memory budget: allocations that grow with a user's number are estimated first.

What grows with a user's number, and where it is estimated:

* vote maps with 1/resolution^2 and the dummy layers
  (:func:`invrad_wb.core.inverse.votemaps.canvas_memory`);
* voting points with the votes per m^2 (:mod:`invrad_wb.core.inverse.sampling`);
* a texture with its declared pixel count, before its pixels are read
  (:mod:`invrad_wb.core.model.oiio`); a PLY's element counts against its bytes
  (:mod:`invrad_wb.core.io.ply`);
* emitter samples with the luminaire count
  (:func:`invrad_wb.core.forward.direct.emitter_memory`; direct light never makes a
  luminaire x receiver array);
* the radiosity model with the room count (:func:`invrad_wb.core.forward.render.
  radiosity_memory`): above half the budget, rooms are solved one at a time (same light).

Each is estimated before it is made and refused, with the estimate, the limit and the
setting to change, when it exceeds the budget (or computed in pieces that fit): a laptop
then gets a one-line error instead of swapping or a MemoryError traceback after minutes.
``bench/bench_memory.py`` measures the peaks against these estimates.

The budget is half of the machine's physical memory by default; ``INVRAD_MEMORY_LIMIT``
overrides it with a size (``"6G"``, ``"800M"``, ``"2.5GB"``, a number of bytes) or a
fraction of the physical memory (``"0.8"``).
"""
import os
import re

from invrad_wb.errors import InvradError

#: Fraction of the physical memory one run may plan to use.
DEFAULT_FRACTION = 0.5
#: Physical memory assumed where the system does not say (bytes).
FALLBACK_PHYSICAL = 8 << 30
ENV = "INVRAD_MEMORY_LIMIT"

_UNITS = {"": 1, "B": 1, "K": 1 << 10, "KB": 1 << 10, "KIB": 1 << 10, "M": 1 << 20,
          "MB": 1 << 20, "MIB": 1 << 20, "G": 1 << 30, "GB": 1 << 30, "GIB": 1 << 30,
          "T": 1 << 40, "TB": 1 << 40, "TIB": 1 << 40}


class MemoryLimitError(InvradError, ValueError):
    """A planned allocation exceeds the memory budget."""


def physical_memory():
    """Bytes of physical memory (FALLBACK_PHYSICAL where the system does not say)."""
    try:
        n = os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        if n > 0:
            return int(n)
    except (AttributeError, ValueError, OSError):
        pass
    return FALLBACK_PHYSICAL


def parse_size(text, physical=None):
    """Bytes of a size such as ``"6G"``, ``"800 MB"``, ``"1e9"`` or a fraction ``"0.5"``
    (of ``physical``); ValueError for anything else."""
    s = str(text).strip().upper()
    m = re.fullmatch(r"([0-9]*\.?[0-9]+(?:E[+-]?[0-9]+)?)\s*([KMGT]?I?B?)", s)
    if not m:
        raise ValueError(f"not a size: {text!r} (e.g. 6G, 800M or 0.5 of the memory)")
    value, unit = float(m.group(1)), m.group(2)
    if not unit and 0 < value <= 1:
        return int(value * (physical if physical is not None else physical_memory()))
    n = value * _UNITS[unit]
    if n < 1:
        raise ValueError(f"not a size: {text!r} (must be positive)")
    return int(n)


def limit_bytes():
    """The budget in bytes (``INVRAD_MEMORY_LIMIT`` or half the physical memory)."""
    env = os.environ.get(ENV, "").strip()
    if env:
        try:
            return parse_size(env)
        except ValueError as exc:
            raise MemoryLimitError(f"{ENV}={env!r}: {exc}") from None
    return int(DEFAULT_FRACTION * physical_memory())


def human(n):
    """``1.5 GB``-style text for a byte count."""
    n = float(n)
    for unit in ("B", "KB", "MB", "GB", "TB"):
        if abs(n) < 1024 or unit == "TB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1024
    return f"{n:.1f} PB"


def require(nbytes, what, change=""):
    """Raise :class:`MemoryLimitError` if ``nbytes`` exceeds the budget.

    Parameters
    ----------
    nbytes : float, the estimated peak of the allocation
    what : str, what it is for, naming the value that makes it large
    change : str, what the user can change (appended to the message)
    """
    limit = limit_bytes()
    if not nbytes <= limit:          # also refuses NaN
        tail = f"; {change}" if change else ""
        raise MemoryLimitError(
            f"{what} would need about {human(nbytes)} of memory, over the limit of"
            f" {human(limit)} ({ENV} to change it){tail}")
    return nbytes
