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

The budget is the smallest of what the process may really use (:func:`budget`), as
cgroup-aware runtimes do (the JVM and Go read the container's limit, not the machine's RAM):

* half of the machine's physical memory;
* the room left under the address-space and data-segment limits (``ulimit -v``, ``ulimit
  -d``: ``RLIMIT_AS``/``RLIMIT_DATA``), past what the process has mapped already;
* the room left under the memory limit of the process's cgroup (v2 ``memory.max``, v1
  ``memory.limit_in_bytes``, its own and its ancestors'), past what the group uses;
* ``INVRAD_MEMORY_LIMIT``: a size (``"6G"``, ``"800M"``, ``"2.5GB"``, a number of bytes) or a
  fraction of the physical memory (``"0.8"``).

A refusal names the bound that decided, so that the message says which setting to change.
"""
import functools
import os
import re

from invrad_wb.errors import InvradError

#: Fraction of the physical memory one run may plan to use.
DEFAULT_FRACTION = 0.5
#: Physical memory assumed where the system does not say (bytes).
FALLBACK_PHYSICAL = 8 << 30
ENV = "INVRAD_MEMORY_LIMIT"
#: Share of the room left under a hard limit (rlimit, cgroup) one run may plan to use: the
#: estimates are peaks, but the interpreter, libraries and page tables need some too
HARD_FRACTION = 0.9
#: A limit at or above this is "no limit" (cgroup v1 writes 2^63 rounded to a page)
UNLIMITED = 1 << 60

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
    """The budget in bytes: the smallest of the bounds in :func:`budget`."""
    return budget()[0]


def budget():
    """``(bytes, why)``: the memory one run may plan to use, and the bound that decided it
    (words naming the setting that changes it)."""
    physical = physical_memory()
    bounds = [(int(DEFAULT_FRACTION * physical),
               f"half the physical memory; {ENV} to change it")]
    env = os.environ.get(ENV, "").strip()
    if env:
        try:
            bounds.append((parse_size(env, physical), f"{ENV}={env}"))
        except ValueError as exc:
            raise MemoryLimitError(f"{ENV}={env!r}: {exc}") from None
    bounds += rlimit_bounds()
    bounds += cgroup_bounds()
    return min(bounds, key=lambda b: b[0])


def _statm():
    """(virtual size, data segment) of this process in bytes, or None."""
    try:
        with open("/proc/self/statm") as fh:
            f = fh.read().split()
        page = os.sysconf("SC_PAGE_SIZE")
        return int(f[0]) * page, int(f[5]) * page
    except (OSError, ValueError, IndexError, AttributeError):
        return None


def rlimit_bounds(limits=None, used=None):
    """Bounds from ``RLIMIT_AS`` (``ulimit -v``) and ``RLIMIT_DATA`` (``ulimit -d``): the room
    left under each soft limit past what this process has mapped, times
    :data:`HARD_FRACTION`.

    ``limits`` (``{"AS": bytes, "DATA": bytes}``) and ``used`` (``(virtual, data)`` bytes)
    replace the system's answers in tests."""
    if limits is None:
        limits = {}
        try:
            import resource
        except ImportError:             # not on Windows
            return []
        for name in ("AS", "DATA"):
            lim = getattr(resource, "RLIMIT_" + name, None)
            if lim is not None:
                soft = resource.getrlimit(lim)[0]
                if soft != resource.RLIM_INFINITY and soft >= 0:
                    limits[name] = soft
    if not limits:
        return []
    if used is None:
        used = _statm() or (0, 0)
    out = []
    for name, flag, now in (("AS", "-v", used[0]), ("DATA", "-d", used[1])):
        if name in limits and limits[name] < UNLIMITED:
            room = max(0, limits[name] - now)
            out.append((int(HARD_FRACTION * room),
                        f"{HARD_FRACTION:.0%} of what the address-space limit of"
                        f" {human(limits[name])} leaves (ulimit {flag}; {human(now)} in use)"
                        if name == "AS" else
                        f"{HARD_FRACTION:.0%} of what the data-segment limit of"
                        f" {human(limits[name])} leaves (ulimit {flag}; {human(now)} in use)"))
    return out


def _read_int(path):
    try:
        with open(path) as fh:
            text = fh.read().strip()
    except OSError:
        return None
    if text == "max":
        return None
    try:
        return int(text)
    except ValueError:
        return None


def _read_stat(path, key):
    try:
        with open(path) as fh:
            for line in fh:
                k, _, v = line.partition(" ")
                if k == key:
                    return int(v)
    except (OSError, ValueError):
        pass
    return None


def cgroup_limit(proc_cgroup="/proc/self/cgroup", mountinfo="/proc/self/mountinfo"):
    """``(limit bytes, used bytes, file)`` of the tightest memory limit of this process's
    cgroup and its ancestors (cgroup v2 ``memory.max`` or v1 ``memory.limit_in_bytes``), or
    None where there is none (or no cgroup file system). ``used`` is what the group uses
    that cannot be dropped (anonymous memory; else the whole usage)."""
    found = []
    for limit_file, usage_file, stat_file, stat_key in _cgroup_files(proc_cgroup, mountinfo):
        lim = _read_int(limit_file)
        if lim is not None and 0 < lim < UNLIMITED:
            used = _read_stat(stat_file, stat_key)
            if used is None:
                used = _read_int(usage_file) or 0
            found.append((lim, used, limit_file))
    if not found:
        return None
    return min(found, key=lambda f: f[0] - f[1])


@functools.lru_cache(maxsize=8)
def _cgroup_files(proc_cgroup, mountinfo):
    """The files of the memory limits that apply to this process (its cgroup's and its
    ancestors'): ``(limit file, usage file, stat file, stat key)`` each. Found once per
    process (which cgroup and mounts do not change during a run); their numbers are read
    at each call."""
    try:
        with open(proc_cgroup) as fh:
            lines = fh.read().splitlines()
        with open(mountinfo) as fh:
            mounts = fh.read().splitlines()
    except OSError:
        return ()
    v2_path = v1_path = None
    for line in lines:
        parts = line.split(":", 2)
        if len(parts) != 3:
            continue
        if parts[0] == "0" and parts[1] == "":
            v2_path = parts[2]
        elif "memory" in parts[1].split(","):
            v1_path = parts[2]
    v2_mount = v1_mount = None
    for m in mounts:
        left, _, right = m.partition(" - ")
        f, r = left.split(), right.split()
        if len(f) < 5 or len(r) < 1:
            continue
        if r[0] == "cgroup2" and v2_mount is None:
            v2_mount = (f[3], f[4])
        elif r[0] == "cgroup" and len(r) >= 3 and "memory" in r[2].split(","):
            v1_mount = (f[3], f[4])
    files = []
    for path, mount, limit_file, usage_file, stat_key in (
            (v2_path, v2_mount, "memory.max", "memory.current", "anon"),
            (v1_path, v1_mount, "memory.limit_in_bytes", "memory.usage_in_bytes",
             "total_rss")):
        if path is None or mount is None:
            continue
        root, point = mount
        rel = path
        if root != "/" and (rel == root or rel.startswith(root.rstrip("/") + "/")):
            rel = rel[len(root.rstrip("/")):]          # the mount shows a subtree
        folder = os.path.join(point, rel.lstrip("/"))
        if not os.path.isdir(folder):                  # a namespace hides the path
            folder = point
        own = folder
        while True:
            if os.path.exists(os.path.join(folder, limit_file)):
                files.append((os.path.join(folder, limit_file),
                              os.path.join(own, usage_file),
                              os.path.join(own, "memory.stat"), stat_key))
            if os.path.normpath(folder) == os.path.normpath(point):
                break
            folder = os.path.dirname(folder)
    return tuple(files)


def cgroup_bounds(**paths):
    """The cgroup bound (see :func:`cgroup_limit`): :data:`HARD_FRACTION` of what the
    group's limit leaves."""
    c = cgroup_limit(**paths)
    if c is None:
        return []
    lim, used, path = c
    return [(int(HARD_FRACTION * max(0, lim - used)),
             f"{HARD_FRACTION:.0%} of what the cgroup memory limit of {human(lim)} leaves"
             f" ({path}; {human(used)} in use): the container's memory setting")]


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
    limit, why = budget()
    if not nbytes <= limit:          # also refuses NaN
        tail = f"; {change}" if change else ""
        raise MemoryLimitError(
            f"{what} would need about {human(nbytes)} of memory, over the limit of"
            f" {human(limit)} ({why}){tail}")
    return nbytes
