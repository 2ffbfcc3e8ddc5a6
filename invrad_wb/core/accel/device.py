"""OpenCL device policy and program cache: the one place that talks to pyopencl set-up.

* ``INVRAD_OPENCL=0`` switches OpenCL off: ``backend='auto'`` then runs every step with
  its numpy twin, ``backend='opencl'`` raises, and the OpenCL tests are skipped.
* ``PYOPENCL_CTX`` is honoured (as pyopencl does: ``"0"``, ``"0:1"``, ...).
* Otherwise a GPU is preferred, then a CPU device (PoCL), then anything else.
* A missing pyopencl, ICD loader or device gives one clear :class:`DeviceError`
  (never an import-time crash): callers may then use the numpy backend.
* Kernels are loaded by name from ``kernels/`` and built with ``-I kernels/`` and
  per-run ``-D`` options; built programs are cached per (context, name, options), so a
  process builds each variant once. Across processes the binaries are reused: invrad
  keeps each built program's binary in ``$INVRAD_KERNEL_CACHE`` (default
  ``$XDG_CACHE_HOME/invrad/kernels``, i.e. ``~/.cache/invrad/kernels``; ``0`` switches it
  off), keyed by the kernel's source, every header of ``kernels/``, the options, the
  device, its driver and pyopencl, and loads it instead of compiling; a binary that does
  not load is rebuilt from source. (pyopencl keeps no cache for drivers that cache builds
  themselves, PoCL and NVIDIA; PoCL's kcache still runs clang's preprocessor on each
  build to find its entry.) Measured on the 2-core PoCL machine, the three programs of a
  locate with interreflection: from source with PoCL's cache warm 0.35-0.48 s wall,
  0.15-0.2 s CPU per process; from invrad's binaries 0.05 s wall, 0.02 s CPU
  (``bench/bench_cli.py``, stage "kernel builds").
* The compiler's messages never reach the terminal: they are logged to
  ``invrad_wb.opencl`` (INFO) and kept in :data:`builds`.
"""
import contextlib
import hashlib
import logging
import os
import sys
import tempfile
import threading
import time
import warnings

from invrad_wb import constants as C
from invrad_wb.errors import DeviceError

_lock = threading.Lock()
_env = None
_programs = {}
_kernels = {}
_log = logging.getLogger("invrad_wb.opencl")
#: every program this process built: kernel, options, seconds, how (pyopencl's words:
#: a source build, a binary cache retrieval, or a build the driver caches itself) and
#: the compiler's log
builds = []

BACKENDS = ("opencl", "numpy")
#: set INVRAD_OPENCL=0 to run every step with its numpy twin (and skip OpenCL tests)
ENV_SWITCH = "INVRAD_OPENCL"


def _import_cl():
    try:
        import pyopencl as cl  # noqa: F401
    except Exception as exc:  # ImportError, or OSError from a broken ICD loader
        raise DeviceError(
            f"OpenCL is not available: cannot import pyopencl ({exc}). Install the 'pyopencl'"
            " package and an OpenCL driver (on Debian: pocl-opencl-icd), or use the numpy"
            " backend (--backend numpy)") from exc
    return cl


class CLEnv:
    """An OpenCL context and in-order queue on one device."""

    def __init__(self, ctx, device):
        cl = _import_cl()
        self.cl = cl
        self.ctx = ctx
        self.device = device
        self.queue = cl.CommandQueue(ctx)
        self.is_cpu = bool(device.type & cl.device_type.CPU)
        from invrad_wb.core.accel import probe
        #: build options every program gets: -D INVRAD_SPLIT16=1 where 16-lane built-in
        #: calls are split in halves (kernels/vec16.h, :func:`probe.split16`)
        self.base_options = ["-D INVRAD_SPLIT16=1"] if probe.split16(device) else []

    @property
    def description(self):
        return f"{self.device.platform.name.strip()} / {self.device.name.strip()}"

    def program(self, name, options=()):
        """Build (once) and return the program ``kernels/<name>.cl``."""
        key = (id(self.ctx), name, tuple(self.base_options), tuple(options))
        with _lock:
            prg = _programs.get(key)
            if prg is None:
                path = os.path.join(C.KERNELS_DIR, name + ".cl")
                try:
                    with open(path, "r", encoding="utf-8") as fh:
                        src = fh.read()
                except OSError as exc:
                    raise DeviceError(f"kernel source {path} is missing: {exc.strerror}")
                opts = (["-I", C.KERNELS_DIR, "-cl-fast-relaxed-math"] + self.base_options
                        + list(options))
                t0 = time.perf_counter()
                cached = _binary_path(self, src, opts)
                prg = self._from_binary(cached, opts)
                if prg is not None:
                    how, log = [f"binary from {cached}"], ""
                else:
                    prg, log = self._from_source(name, src, opts)
                    how = getattr(prg, "_build_duration_info", None)
                    _save_binary(self, prg, cached)
                seconds = time.perf_counter() - t0
                builds.append({"kernel": name, "options": list(options), "seconds": seconds,
                               "how": how[0] if how else "", "log": log})
                _log.info("built kernels/%s.cl %s in %.2f s (%s)%s", name,
                          " ".join(options), seconds, how[0] if how else "build",
                          f":\n{log}" if log else "")
                _programs[key] = prg
        return prg

    def _from_source(self, name, src, opts):
        """(program built from ``src``, the compiler's messages)."""
        try:
            # the compiler's messages ("12 warnings generated", which pyopencl
            # turns into warnings) are not for a user's terminal: they go to the
            # 'invrad_wb.opencl' logger (the CLI shows them with -v)
            with warnings.catch_warnings(), _stderr_captured() as said:
                warnings.simplefilter("ignore")
                prg = self.cl.Program(self.ctx, src).build(options=opts)
        except self.cl.RuntimeError as exc:
            raise DeviceError(f"kernel {name}.cl failed to build on"
                              f" {self.description}: {exc}") from exc
        try:
            log = prg.get_build_info(self.device, self.cl.program_build_info.LOG).strip()
        except Exception:       # a driver that keeps no log
            log = ""
        return prg, "\n".join(t for t in (log, said.text.strip()) if t)

    def _from_binary(self, path, opts):
        """The program of a cached binary, or None (none cached, or it does not load)."""
        if path is None:
            return None
        try:
            with open(path, "rb") as fh:
                binary = fh.read()
            if not binary:
                return None
            with warnings.catch_warnings(), _stderr_captured():
                warnings.simplefilter("ignore")
                prg = self.cl.Program(self.ctx, [self.device], [binary]).build(options=opts)
            prg.all_kernels()               # a binary without its kernels fails here
            with contextlib.suppress(OSError):
                os.utime(path)              # recently used: the last to be pruned
            return prg
        except Exception:       # missing, unreadable, another driver's: build from source
            return None

    def kernel(self, program, name, options=()):
        """A cached ``cl.Kernel`` ``name`` of ``kernels/<program>.cl`` built with options."""
        key = (id(self.ctx), program, tuple(self.base_options), tuple(options), name)
        with _lock:
            k = _kernels.get(key)
        if k is None:
            k = self.cl.Kernel(self.program(program, options), name)
            with _lock:
                _kernels[key] = k
        return k


#: switch the kernel binary cache off (``0``) or name its folder
ENV_KERNEL_CACHE = "INVRAD_KERNEL_CACHE"
#: binaries kept in the cache; the oldest go beyond it (kernels built with changing
#: options, e.g. by tests, would otherwise pile up)
KERNEL_CACHE_MAX_FILES = 64


def kernel_cache_dir():
    """Where built kernels' binaries are kept: ``$INVRAD_KERNEL_CACHE``, else
    ``$XDG_CACHE_HOME/invrad/kernels`` (``~/.cache/invrad/kernels``); None when
    ``INVRAD_KERNEL_CACHE=0``."""
    v = os.environ.get(ENV_KERNEL_CACHE, "").strip()
    if v.lower() in ("0", "false", "no", "off"):
        return None
    if v:
        return v
    cache = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(cache, "invrad", "kernels")


def _binary_path(env, src, opts):
    """The cache file of a program: a hash of everything its binary depends on (the
    source, every header of ``kernels/``, options, device, driver, pyopencl), or None."""
    folder = kernel_cache_dir()
    if folder is None:
        return None
    try:
        d = env.device
        h = hashlib.sha256()
        for part in (env.cl.VERSION_TEXT, d.platform.name, d.platform.version, d.name,
                     d.version, d.driver_version, " ".join(opts), src):
            h.update(str(part).encode("utf-8", "replace") + b"\0")
        for f in sorted(os.listdir(C.KERNELS_DIR)):
            if f.endswith(".h"):
                with open(os.path.join(C.KERNELS_DIR, f), "rb") as fh:
                    h.update(f.encode() + b"\0" + fh.read() + b"\0")
    except Exception:           # a header unreadable, a driver that says nothing
        return None
    return os.path.join(folder, h.hexdigest()[:40] + ".bin")


def _save_binary(env, prg, path):
    """Keep ``prg``'s binary at ``path`` (written whole or not at all); never fails."""
    if path is None:
        return
    try:
        binary = prg.get_info(env.cl.program_info.BINARIES)[0]
        if not binary:
            return
        folder = os.path.dirname(path)
        os.makedirs(folder, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=folder, suffix=".tmp")
        try:
            with os.fdopen(fd, "wb") as fh:
                fh.write(binary)
            os.replace(tmp, path)
        except BaseException:
            with contextlib.suppress(OSError):
                os.remove(tmp)
            raise
        files = [os.path.join(folder, f) for f in os.listdir(folder) if f.endswith(".bin")]
        if len(files) > KERNEL_CACHE_MAX_FILES:
            files.sort(key=lambda f: os.stat(f).st_mtime)
            for f in files[:len(files) - KERNEL_CACHE_MAX_FILES]:
                with contextlib.suppress(OSError):
                    os.remove(f)
    except Exception:           # a read-only home, a full disk: no cache, no harm
        pass


class _Said:
    text = ""


@contextlib.contextmanager
def _stderr_captured():
    """What the driver's compiler writes to file descriptor 2 (PoCL's clang prints
    "1 warning generated." there, past Python), captured instead of shown."""
    said = _Said()
    try:
        sys.stderr.flush()
        tmp = tempfile.TemporaryFile()
    except (OSError, ValueError, AttributeError):      # nowhere to put it: as it is
        yield said
        return
    try:
        saved = os.dup(2)
    except OSError:                                     # no fd 2 (embedded): as it is
        tmp.close()
        yield said
        return
    with tmp:
        try:
            os.dup2(tmp.fileno(), 2)
            yield said
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            tmp.seek(0)
            said.text = tmp.read(1 << 16).decode("utf-8", "replace")


def _pick_device(cl):
    try:
        platforms = cl.get_platforms()
    except Exception as exc:
        raise DeviceError(
            f"no OpenCL platform found ({exc}). Install an OpenCL driver (on Debian:"
            " 'apt-get install pocl-opencl-icd'), or use the numpy backend (--backend numpy)")
    spec = os.environ.get("PYOPENCL_CTX", "").strip()
    if spec:
        parts = spec.split(":")
        try:
            plat = platforms[int(parts[0])] if parts[0] else platforms[0]
            devs = plat.get_devices()
            dev = devs[int(parts[1])] if len(parts) > 1 and parts[1] else devs[0]
        except (ValueError, IndexError) as exc:
            raise DeviceError(f"PYOPENCL_CTX={spec!r} names no OpenCL device ({exc}); there"
                              f" are {len(platforms)} platform(s)")
        return dev
    candidates = []
    for p in platforms:
        try:
            candidates.extend(p.get_devices())
        except Exception:
            continue
    if not candidates:
        raise DeviceError("OpenCL platforms found but no device. Install a driver (on Debian:"
                          " pocl-opencl-icd), or use the numpy backend (--backend numpy)")

    def rank(d):
        if d.type & cl.device_type.GPU:
            return 0
        if d.type & cl.device_type.CPU:
            return 1
        return 2
    return sorted(candidates, key=rank)[0]


def opencl_disabled():
    """True when the user switched OpenCL off (``INVRAD_OPENCL=0``, ``false``, ``no``, ``off``)."""
    return os.environ.get(ENV_SWITCH, "").strip().lower() in ("0", "false", "no", "off")


def get_env():
    """The process-wide :class:`CLEnv` (created on first use).

    Raises
    ------
    DeviceError
        If OpenCL cannot be used; the message says what to install.
    """
    if opencl_disabled():
        raise DeviceError(f"OpenCL is switched off ({ENV_SWITCH}=0)")
    global _env
    with _lock:
        if _env is None:
            cl = _import_cl()
            dev = _pick_device(cl)
            from invrad_wb.core.accel import probe
            if probe.needs_probe(dev):
                why = probe.verdict(cl, dev, kernel_cache_dir())
                if why:
                    raise DeviceError(f"{why}; use the numpy backend, or another OpenCL"
                                      " driver (on Debian: pocl-opencl-icd)")
            try:
                ctx = cl.Context([dev])
            except Exception as exc:
                raise DeviceError(f"cannot create an OpenCL context on {dev.name}: {exc}")
            _env = CLEnv(ctx, dev)
        return _env


def opencl_unavailable_reason():
    """Why OpenCL cannot be used here (the :class:`DeviceError` message), or None if it can."""
    try:
        get_env()
        return None
    except DeviceError as exc:
        return str(exc)


def opencl_available():
    """True if :func:`get_env` would succeed."""
    return opencl_unavailable_reason() is None


_warned = False


def check_backend(backend):
    """Resolve a backend name to 'opencl' or 'numpy', once per call site.

    Parameters
    ----------
    backend : {'auto', 'opencl', 'numpy'}
        'auto' means OpenCL if a device is usable (and ``INVRAD_OPENCL`` is not 0), else
        numpy with a ``RuntimeWarning`` that says why (once per process).

    Raises
    ------
    DeviceError
        'opencl' where no device is usable; the message says what to install.
    SettingsError
        Any other name.
    """
    global _warned
    if backend == "auto":
        try:
            get_env()
            return "opencl"
        except DeviceError as exc:
            if not _warned:
                warnings.warn(f"{exc}. Using the numpy backend (much slower).", RuntimeWarning,
                              stacklevel=2)
                _warned = True
            return "numpy"
    if backend not in BACKENDS:
        from invrad_wb.errors import SettingsError
        raise SettingsError(f"backend must be one of {BACKENDS + ('auto',)}, got {backend!r}")
    if backend == "opencl":
        get_env()
    return backend
