"""BLAS threads of the command line's own process (no numpy import here: this runs
before numpy loads)."""
import os
import sys


def one_blas_thread_at_start():
    """In a process that has not loaded numpy yet (the command line's own), BLAS on one
    thread from the start: ``OPENBLAS_NUM_THREADS`` and ``MKL_NUM_THREADS`` set to 1 unless
    the user set a BLAS thread count (those two, ``GOTO_NUM_THREADS``, ``OMP_NUM_THREADS``).

    Rooms run BLAS on one thread anyway (:func:`~invrad_wb.core.accel.workers.
    room_threads`), but OpenBLAS starts its other threads when numpy loads and they
    busy-wait (``sched_yield``) for about 0.1 s before sleeping: sampled with perf in the
    office example's locate run, numpy's second BLAS thread took 0.11 CPU s right after the
    import and scipy's 0.03 s after the radiosity's LU, 5 % of the run. Numbers made before
    a room (reading the scene) then do not depend on the cores either. A process that
    imported numpy before this module (FreeCAD, tests, a user's script) is left alone."""
    if "numpy" in sys.modules:
        return
    if any(os.environ.get(k) for k in ("OPENBLAS_NUM_THREADS", "GOTO_NUM_THREADS",
                                       "OMP_NUM_THREADS", "MKL_NUM_THREADS")):
        return
    for k in BLAS_SET_BY_CLI:
        os.environ[k] = "1"
    _blas_set.append(True)


#: the BLAS thread variables the command line sets for itself (not for its children:
#: :func:`child_blas_environment` takes them out again)
BLAS_SET_BY_CLI = ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
_blas_set = []


def child_blas_environment(env):
    """``env`` (a copy of this process's environment, for a child process such as
    freecadcmd) less the BLAS thread variables the command line set for itself: a child
    gets the user's own settings, not ours."""
    if _blas_set:
        for k in BLAS_SET_BY_CLI:
            if env.get(k) == "1":
                env.pop(k)
    return env


