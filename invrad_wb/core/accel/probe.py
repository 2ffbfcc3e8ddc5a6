"""A first-use self-test of an OpenCL driver known to abort on some CPUs, in a child
process, so that a driver that crashes while compiling invrad's kernels costs a numpy run,
not the user's FreeCAD session.

PoCL from PyPI (``pyopencl[pocl]``: ``pocl-binary-distribution`` 3.0, the driver
``dependencies.install()`` gives an architect) aborted the whole process when its LLVM
compiled invrad's kernels on an AMD Zen 4 (EPYC, family 25 model 17, AVX-512): "LLVM ERROR:
Do not know how to scalarize this operator's operand!" (SIGABRT), or SIGSEGV, and its own
kernel cache then answered INVALID_KERNEL_NAME in later runs. Measured 2026-11-26 on this
project's machine; Debian's PoCL on the same CPU runs every kernel. An
abort cannot be caught in the process that compiles, so for that driver (only: every other
driver is used as before, at no cost) the first use runs a self-test in a child process,
with the same interpreter and ``sys.path``
(:func:`workers.worker_python`); the verdict is kept in the kernel cache's folder, keyed by
everything the driver's answer depends on (driver, device, pyopencl, the kernels' sources),
so the test runs once per machine and version.

The cause on that CPU was found (see ``kernels/vec16.h``): the driver builds kernels without
AVX-512 but links AVX-512 built-ins, and any OpenCL built-in called on a 16-lane vector
aborts LLVM; for that driver (:func:`split16`) invrad's kernels call them on 8-lane halves,
and the self-test passes there.
The child builds and launches every kernel in every variant that has code of its own
(:data:`KERNEL_VARIANTS`, :func:`launch_every_kernel`: where a driver's compiler fails, it
fails at the first launch), then runs a small locate (votes, direct light, shadows,
radiosity): 13.6 s on this 2-core machine under load with cold caches, once.
"""
import hashlib
import json
import os
import subprocess
import sys
import tempfile

from invrad_wb import constants as C

#: set in the child: it must not test itself again
ENV_CHILD = "INVRAD_OPENCL_PROBE_CHILD"
#: tests: a child that aborts as the faulty driver does
ENV_FAKE_ABORT = "INVRAD_OPENCL_PROBE_ABORT"
#: ``1``: call built-ins on 16-lane vectors' halves on any driver (``0``: never); tests
ENV_SPLIT16 = "INVRAD_OPENCL_SPLIT16"
#: seconds the child may take (a small room; kernels compiled once)
TIMEOUT_S = 300

_CHILD = r"""
import json, os, sys
sys.path[:0] = json.loads(sys.argv[1])
if os.environ.get("INVRAD_OPENCL_PROBE_ABORT"):
    os.abort()
from invrad_wb import cli
from invrad_wb.core.accel import probe
from invrad_wb.core.accel.device import get_env
probe.launch_every_kernel(get_env())
out = sys.argv[2]
cli.main(["example", "one_ceiling", "-o", os.path.join(out, "probe.ply"), "--cell", "0.25",
          "--truth", os.path.join(out, "truth.json"), "--backend", "opencl"])
cli.main(["locate", os.path.join(out, "probe.ply"), "--backend", "opencl", "-o",
          os.path.join(out, "found.json")])
"""

#: every program of ``kernels/`` with the -D options that together compile each line of it
#: once (each ``#if`` branch; the values the kernel modules pass: inverse/votes.py's
#: PROFILE_STEP_DEG, tests/core/accel/test_kernel_builds.py checks they agree)
KERNEL_VARIANTS = (
    ("votes_exact", ("-D OCCLUSION=1", "-D SHADE=1", "-D PROFILE=0", "-D PROFILE_STEP=0.25f")),
    ("votes_exact", ("-D OCCLUSION=1", "-D SHADE=1", "-D PROFILE=1", "-D PROFILE_STEP=0.25f")),
    ("votes_ellipse", ("-D OCCLUSION=1",)),
    ("direct", ("-D OCCLUSION=1",)),
    ("photometric", ("-D OCCLUSION=1",)),
    ("radiosity", ("-D VIS=1",)),
    ("occlusion", ()),
)


def launch_every_kernel(env, variants=KERNEL_VARIANTS):
    """Build each program of ``variants`` as invrad does (:meth:`CLEnv.program`) and launch
    each of its kernels once over 16 work-items with count 0 and zeroed buffers: nothing is
    computed, but a driver compiles a kernel's machine code at its first launch (PoCL), so a
    compiler that fails on a kernel fails here. Returns the (program, options, kernel)
    launched."""
    import numpy as np
    cl = env.cl
    zeros = np.zeros(4096, np.float32)
    buf = cl.Buffer(env.ctx, cl.mem_flags.READ_WRITE | cl.mem_flags.COPY_HOST_PTR,
                    hostbuf=zeros)
    done = []
    for name, options in variants:
        for knl in env.program(name, list(options)).all_kernels():
            # every by-value argument of invrad's kernels is a 4-byte int or float (a count
            # first): 0; a pointer refuses 4 bytes (CL_INVALID_ARG_SIZE) and gets the buffer
            for i in range(knl.num_args):
                try:
                    knl.set_arg(i, np.int32(0))
                except cl.Error:
                    knl.set_arg(i, buf)
            cl.enqueue_nd_range_kernel(env.queue, knl, (16,), None)
            env.queue.finish()
            done.append((name, options, knl.function_name))
    return done


def is_pypi_pocl(device):
    """True for PoCL from PyPI (``pocl-binary-distribution``), the driver that aborted."""
    try:
        name = device.platform.name
    except Exception:                                        # noqa: BLE001
        return False
    if "Portable Computing Language" not in name and "pocl" not in name.lower():
        return False
    import importlib.util
    try:
        return importlib.util.find_spec("pocl_binary_distribution") is not None
    except (ImportError, ValueError):
        return False


def needs_probe(device):
    """True for the driver that may abort (:func:`is_pypi_pocl`) unless this is the
    probe's own child."""
    return not os.environ.get(ENV_CHILD) and is_pypi_pocl(device)


def split16(device):
    """Whether kernels call OpenCL built-ins on the 8-lane halves of 16-lane vectors
    (``-D INVRAD_SPLIT16=1``, kernels/vec16.h): ``$INVRAD_OPENCL_SPLIT16`` (``1``/``0``)
    if set, else for PoCL from PyPI only. That driver aborts on whole 16-lane calls on an
    AMD Zen 4; other drivers run them, and on an AVX-512 CPU faster (Debian's PoCL 3.1,
    this Zen 4: the vote kernel on a 8 x 6 m room at 5 cm pixels 3.2 s whole, 5.1 s split)."""
    v = os.environ.get(ENV_SPLIT16, "").strip().lower()
    if v in ("0", "1", "false", "true", "no", "yes", "off", "on"):
        return v in ("1", "true", "yes", "on")
    return is_pypi_pocl(device)


def _key(cl, device):
    h = hashlib.sha256()
    d = device
    for part in (cl.VERSION_TEXT, d.platform.name, d.platform.version, d.name, d.version,
                 d.driver_version, sys.version):
        h.update(str(part).encode("utf-8", "replace") + b"\0")
    for f in sorted(os.listdir(C.KERNELS_DIR)):
        with open(os.path.join(C.KERNELS_DIR, f), "rb") as fh:
            h.update(f.encode() + b"\0" + fh.read() + b"\0")
    return h.hexdigest()[:32]


def verdict(cl, device, cache_dir):
    """None where the device runs invrad's kernels, else why not (one line). Runs the child
    once per key; the verdict is kept in ``cache_dir`` (None: not kept)."""
    from invrad_wb.core.accel.workers import worker_python
    path = None
    try:
        key = _key(cl, device)
        if cache_dir:
            path = os.path.join(cache_dir, f"opencl-probe-{key}.json")
            if os.path.isfile(path):
                with open(path) as fh:
                    return json.load(fh).get("why")
    except (OSError, ValueError):
        path = None
    exe = worker_python()
    if exe is None:
        return None               # no interpreter to test with: used as before
    env = dict(os.environ, **{ENV_CHILD: "1", "INVRAD_KERNEL_CACHE": "0"})
    with tempfile.TemporaryDirectory(prefix="invrad-opencl-probe-") as tmp:
        try:
            p = subprocess.run([exe, "-c", _CHILD, json.dumps(sys.path), tmp], env=env,
                               stdin=subprocess.DEVNULL, capture_output=True, text=True,
                               timeout=TIMEOUT_S)
            rc, text = p.returncode, (p.stderr or "") + (p.stdout or "")
        except subprocess.TimeoutExpired:
            rc, text = None, f"no answer in {TIMEOUT_S} s"
        except OSError:           # no interpreter to start: used as before
            return None
    why = None
    if rc != 0:
        lines = [ln.strip() for ln in text.splitlines() if ln.strip()]
        said = next((ln for ln in lines if "ERROR" in ln or "rror" in ln), lines[-1] if
                    lines else "")
        how = (f"signal {-rc}" if rc is not None and rc < 0 else
               f"exit status {rc}" if rc is not None else "timeout")
        why = (f"the OpenCL driver {device.platform.name} on {device.name.strip()} failed"
               f" invrad's self-test ({how}: {said[:160]})")
    if path:
        try:
            os.makedirs(os.path.dirname(path), exist_ok=True)
            tmp = path + f".{os.getpid()}.tmp"
            with open(tmp, "w") as fh:
                json.dump({"why": why}, fh)
            os.replace(tmp, path)
        except OSError:
            pass
    return why
