"""OpenCL device policy and program cache: the one place that talks to pyopencl set-up.

* ``INVRAD_OPENCL=0`` switches OpenCL off: ``backend='auto'`` then runs every step with
  its numpy twin, ``backend='opencl'`` raises, and the OpenCL tests are skipped.
* ``PYOPENCL_CTX`` is honoured (as pyopencl does: ``"0"``, ``"0:1"``, ...).
* Otherwise a GPU is preferred, then a CPU device (PoCL), then anything else.
* A missing pyopencl, ICD loader or device gives one clear :class:`DeviceError`
  (never an import-time crash): callers may then use the numpy backend.
* Kernels are loaded by name from ``kernels/`` and built with ``-I kernels/`` and
  per-run ``-D`` options; built programs are cached per (context, name, options), so a
  process builds each variant once. Across processes the binaries are reused: pyopencl
  keeps a binary cache, except for drivers that cache builds themselves (PoCL's kcache,
  NVIDIA's compute cache), where it leaves it to them. On the 2-core PoCL machine the
  six programs of a locate run take 1.2 s CPU to build the first time, 0.15 s after.
* The compiler's messages never reach the terminal: they are logged to
  ``invrad_wb.opencl`` (INFO) and kept in :data:`builds`.
"""
import contextlib
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

    @property
    def description(self):
        return f"{self.device.platform.name.strip()} / {self.device.name.strip()}"

    def program(self, name, options=()):
        """Build (once) and return the program ``kernels/<name>.cl``."""
        key = (id(self.ctx), name, tuple(options))
        with _lock:
            prg = _programs.get(key)
            if prg is None:
                path = os.path.join(C.KERNELS_DIR, name + ".cl")
                try:
                    with open(path, "r", encoding="utf-8") as fh:
                        src = fh.read()
                except OSError as exc:
                    raise DeviceError(f"kernel source {path} is missing: {exc.strerror}")
                opts = ["-I", C.KERNELS_DIR, "-cl-fast-relaxed-math"] + list(options)
                t0 = time.perf_counter()
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
                seconds = time.perf_counter() - t0
                try:
                    log = prg.get_build_info(self.device,
                                             self.cl.program_build_info.LOG).strip()
                except Exception:       # a driver that keeps no log
                    log = ""
                log = "\n".join(t for t in (log, said.text.strip()) if t)
                how = getattr(prg, "_build_duration_info", None)
                builds.append({"kernel": name, "options": list(options), "seconds": seconds,
                               "how": how[0] if how else "", "log": log})
                _log.info("built kernels/%s.cl %s in %.2f s (%s)%s", name,
                          " ".join(options), seconds, how[0] if how else "build",
                          f":\n{log}" if log else "")
                _programs[key] = prg
        return prg

    def kernel(self, program, name, options=()):
        """A cached ``cl.Kernel`` ``name`` of ``kernels/<program>.cl`` built with options."""
        key = (id(self.ctx), program, tuple(options), name)
        with _lock:
            k = _kernels.get(key)
        if k is None:
            k = self.cl.Kernel(self.program(program, options), name)
            with _lock:
                _kernels[key] = k
        return k


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
