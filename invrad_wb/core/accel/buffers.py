"""Host <-> device data for the kernel wrappers: one way to make a buffer, one way to launch.

Every OpenCL wrapper (``forward/direct.py``, ``forward/occlusion.py`` with the BVH's
buffers, ``forward/form_factors.py``, ``inverse/votes.py``, ``inverse/votes_ellipse.py``)
builds its device buffers with :func:`device_buffer` and, for ``float4`` kernel arguments,
packs (k, 3) arrays with :func:`float4`.
"""
import numpy as np

_ACCESS = ("read", "write", "readwrite")


def float4(a, w=None):
    """(k, 3) values -> (k, 4) float32 for ``float4`` kernel arguments.

    Parameters
    ----------
    a : (k, 3) array_like
        Positions (metres), directions or any three components.
    w : scalar or (k,) array_like, optional
        Fills the fourth column (0 if None).
    """
    a = np.asarray(a, dtype=np.float64).reshape(-1, 3)
    out = np.zeros((len(a), 4), np.float32)
    out[:, :3] = a
    if w is not None:
        out[:, 3] = w
    return out


def device_buffer(env, array, access="read"):
    """A device buffer for a host array (an empty array gets a 4-element stand-in).

    Parameters
    ----------
    env : CLEnv
        From :func:`invrad_wb.core.accel.device.get_env`.
    array : ndarray
        Host data; its dtype is the kernel's element type (copied as a C-contiguous array).
    access : {'read', 'write', 'readwrite'}
        'read': the kernel reads a copy of ``array``. 'write': the kernel only writes; the
        buffer has ``array``'s size and nothing is copied (read it back with
        ``cl.enqueue_copy(env.queue, array, buf)``). 'readwrite': the kernel reads a copy of
        ``array`` (e.g. zeros it accumulates into) and writes to it.
    """
    if access not in _ACCESS:
        raise ValueError(f"access must be one of {_ACCESS}, got {access!r}")
    a = np.ascontiguousarray(array)
    if a.size == 0:
        a = np.zeros(4, a.dtype)
    mf = env.cl.mem_flags
    if access == "write":
        return env.cl.Buffer(env.ctx, mf.WRITE_ONLY, a.nbytes)
    flags = mf.READ_ONLY if access == "read" else mf.READ_WRITE
    return env.cl.Buffer(env.ctx, flags | mf.COPY_HOST_PTR, hostbuf=a)


def round_up(n, m):
    """The least multiple of ``m`` that is >= ``n``."""
    return ((int(n) + m - 1) // m) * m


def launch_chunked(env, kernel, n, args_before, args_after, chunk, local=64):
    """Run ``kernel(n, first, *args)`` over ``n`` work-items in launches of ``chunk``.

    Long single launches can hit a GPU driver's watchdog (the thesis' CUDA kernels had a
    5 s limit) and huge global sizes can exceed device limits; each launch covers
    ``first .. first + chunk`` and the kernel adds ``first`` to its global id.
    """
    chunk = max(local, round_up(chunk, local))
    for first in range(0, max(int(n), 0), chunk):
        size = round_up(min(chunk, n - first), local)
        kernel(env.queue, (size,), None, np.int32(n), np.int32(first), *args_before,
               *args_after)
        env.queue.finish()
