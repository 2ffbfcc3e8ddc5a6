"""Where independent rooms run: in this process, on local worker processes, or on Dask.

Rooms do not share light (each room's faces carry their own room id), so a building is a
list of independent tasks. :func:`map_rooms` runs ``fn(*task)`` for each task and returns
the results in task order, whatever the number of workers, so a parallel run gives the
same answer as a serial one.

* ``workers=1`` (default): in this process, one room after another; ``fn`` gets the
  caller's fine-grained progress (``report=``).
* ``workers=N`` or ``"auto"`` (all usable cores): a pool of ``N`` local worker processes,
  started with ``spawn`` (a fork would copy an OpenCL context and its threads). Each
  worker computes one room with its next one queued (at most ``2 N`` in flight), and
  tasks are built only then, so memory is bounded by the largest rooms, not the
  building.
* ``dask="tcp://host:8786"``: the rooms go to that Dask scheduler's workers
  (``dask.distributed``); ``dask="local"``: a local Dask cluster of ``N`` worker processes.

Progress is reported per finished room (``progress(fraction, "3/7 rooms: Office")``);
when it returns False the pending and running rooms are stopped (the pool is terminated,
the Dask futures cancelled) and :class:`~invrad_wb.errors.Cancelled` is raised, before
anything is returned to be written.

Worker processes run this package's Python (:func:`worker_python`; inside FreeCAD the
Python it embeds); when there is none, rooms run in this process.
"""
import contextlib
import os
import sys
import time

from invrad_wb.errors import Cancelled, InvradError, SettingsError

#: longest wait between two looks at the progress callback (cancel) and at the workers
#: (one that died); a finished room is taken at once
POLL_S = 0.05
#: rooms handed to the local pool per worker (one running, the others queued): the
#: parent builds and pickles the next room while the workers compute
QUEUED_PER_WORKER = 2


def usable_cores():
    """CPUs this process may run on."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


def check_workers(workers):
    """``workers`` as a positive int (``"auto"`` or None: all usable cores)."""
    if workers is None or (isinstance(workers, str) and workers.strip().lower() == "auto"):
        return usable_cores()
    bad = SettingsError(f"workers must be a positive whole number or 'auto', got {workers!r}")
    if isinstance(workers, bool):
        raise bad
    try:
        n = int(str(workers).strip()) if isinstance(workers, str) else int(workers)
    except (TypeError, ValueError):
        raise bad from None
    if n < 1 or (not isinstance(workers, str) and n != workers):
        raise bad
    return n


def worker_python():
    """The Python interpreter for worker processes, or None when there is none.

    ``$INVRAD_PYTHON``; else ``sys.executable`` when it is a Python; else (Python embedded
    in FreeCAD, whose executable is FreeCAD) the interpreter of the same version in the
    Python installation FreeCAD embeds (``<base prefix>/bin/pythonX.Y``): workers get the
    parent's ``sys.path``, so they import the very same modules.
    """
    exe = os.environ.get("INVRAD_PYTHON")
    if exe:
        return exe if os.path.isfile(exe) else None
    exe = sys.executable or ""
    if os.path.basename(exe).lower().startswith("python") and os.path.isfile(exe):
        return exe
    version = "%d.%d" % sys.version_info[:2]
    for prefix in dict.fromkeys((sys.base_prefix, sys.base_exec_prefix, sys.prefix)):
        for cand in (os.path.join(prefix, "bin", "python" + version),
                     os.path.join(prefix, "python.exe")):
            if os.path.isfile(cand) and os.access(cand, os.X_OK):
                return cand
    return None


@contextlib.contextmanager
def _plain_main(embedded):
    """Workers started from an embedding program (FreeCAD) must not re-run its
    ``__main__`` (a FreeCAD script) as spawn does: hide it while they start."""
    main = sys.modules.get("__main__")
    if not embedded or main is None:
        yield
        return
    saved = {k: main.__dict__[k] for k in ("__file__", "__spec__") if k in main.__dict__}
    try:
        main.__dict__.pop("__file__", None)
        main.__spec__ = None
        yield
    finally:
        main.__dict__.pop("__spec__", None)
        main.__dict__.update(saved)


def worker_environ(nw):
    """Environment for ``nw`` workers sharing this machine: each gets ``1/nw`` of the memory
    budget (:mod:`invrad_wb.core.model.memory`: ``nw`` rooms at their limit must not take
    ``nw`` times the budget) and ``cores/nw`` PoCL threads (not every worker all cores).
    Neither changes a result: PoCL's thread count does not change what a work-item
    computes."""
    from invrad_wb.core.model import memory
    env = {memory.ENV: str(max(1, memory.limit_bytes() // nw))}
    if "POCL_MAX_PTHREAD_COUNT" not in os.environ:
        env["POCL_MAX_PTHREAD_COUNT"] = str(max(1, usable_cores() // nw))
    return env


@contextlib.contextmanager
def _environ(values):
    """``os.environ`` with ``values`` while workers start (they inherit it)."""
    old = {k: os.environ.get(k) for k in values}
    try:
        os.environ.update(values)
        yield
    finally:
        for k, v in old.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


@contextlib.contextmanager
def room_threads():
    """BLAS (OpenBLAS, MKL: numpy's and scipy's) on one thread while a room runs.

    A room's BLAS work is small: the refinement solves systems of a few unknowns and
    multiplies (k x n) Jacobians of a few columns, the radiosity a matrix by a vector.
    Several BLAS threads only wait on each other there, and with PoCL's threads, other
    rooms' workers or other programs on the cores, each small call waits for a time slice:
    the office example's refinement took 14-15 s with OpenBLAS's 2 threads on a busy
    2-core machine, 6-9 s with one (CPU time 2.1-2.5 -> 1.3-1.5 s). One thread everywhere
    also keeps results independent of the number of workers (a thread count can change
    float rounding). Uses threadpoolctl; without it BLAS keeps its threads.
    """
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:
        yield
        return
    with threadpool_limits(limits=1, user_api="blas"):
        yield


def _call(fn, task):
    with room_threads():
        return fn(*task)


def map_rooms(fn, tasks, labels=None, workers=1, dask=None, progress=None, report=None):
    """``[fn(*task) for task in tasks]``, on ``workers`` processes or a Dask cluster.

    Parameters
    ----------
    fn : picklable callable (a module-level function)
    tasks : sequence of argument tuples, or of zero-argument callables building them (called
        only when a worker takes the room, so at most ``workers`` are alive at a time)
    labels : sequence of str, optional
        Names for progress messages (a room's name).
    workers : int or 'auto'
    dask : None, 'local' or a scheduler address ('tcp://host:8786')
    progress : callable(fraction, message) -> bool, optional
        Called as rooms finish (in process: also within rooms, through ``report``);
        returning False cancels.
    report : callable(task index, n) -> callable(fraction, message), optional
        In-process runs only: ``fn`` is then called with ``report=report(i, n)`` for its
        fine-grained progress.

    Returns
    -------
    list of results, in task order.
    """
    tasks = list(tasks)
    n = len(tasks)
    labels = list(labels) if labels is not None else [f"room {i + 1}" for i in range(n)]
    nw = check_workers(workers)
    if dask:
        return _map_dask(fn, tasks, labels, nw, dask, progress)
    if nw > 1 and n > 1 and worker_python() is not None:
        return _map_pool(fn, tasks, labels, min(nw, n), progress)
    out = []
    for i, task in enumerate(tasks):
        args = task() if callable(task) else task
        if report is not None:
            with room_threads():
                out.append(fn(*args, report=report(i, n)))
        else:
            _tell(progress, i / n, f"{i}/{n} rooms: {labels[i]}")
            out.append(_call(fn, args))
    return out


def _tell(progress, frac, msg):
    if progress is not None and progress(frac, msg) is False:
        raise Cancelled(f"cancelled: {msg}")


def _map_pool(fn, tasks, labels, nw, progress):
    import multiprocessing as mp
    ctx = mp.get_context("spawn")
    exe = worker_python()
    ctx.set_executable(exe)
    n = len(tasks)
    out = [None] * n
    # BLAS runs rooms on one thread here as in the workers (room_threads): a thread
    # count can change float rounding, and the result must not depend on the workers
    embedded = os.path.realpath(exe) != os.path.realpath(sys.executable or "")
    with _plain_main(embedded), _environ(worker_environ(nw)):
        pool = ctx.Pool(nw)
    started = _worker_pids(pool)
    import threading
    woken = threading.Event()                       # a room finished (or failed)

    def wake(_):
        woken.set()
    try:
        pending, nxt, done = {}, 0, 0
        while done < n:
            # each worker has its next room queued (2 N in flight, N running): a worker
            # that finishes starts the next room at once instead of idling until this
            # loop has noticed and built it (up to POLL_S a room)
            while nxt < n and len(pending) < QUEUED_PER_WORKER * nw:
                task = tasks[nxt]
                args = task() if callable(task) else task
                pending[nxt] = pool.apply_async(_call, (fn, args), callback=wake,
                                                error_callback=wake)
                tasks[nxt] = None                   # the parent keeps no copy
                nxt += 1
            woken.clear()
            finished = [i for i, r in pending.items() if r.ready()]
            for i in finished:
                out[i] = pending.pop(i).get()       # re-raises a worker's exception
                done += 1
                _tell(progress, done / n, f"{done}/{n} rooms: {labels[i]} done")
            if not finished:
                if started and _worker_pids(pool) - started:
                    # the pool replaced a worker that died: its room would never finish
                    raise InvradError(
                        "a worker process stopped unexpectedly (killed, out of memory or"
                        " crashed) while it ran " + ", ".join(labels[i] for i in
                                                               sorted(pending)[:nw])
                        + "; run with one worker (--workers 1) to see the room's own error")
                _tell(progress, done / n, f"{done}/{n} rooms: "
                      + ", ".join(labels[i] for i in sorted(pending)[:nw]))
                woken.wait(POLL_S)
        pool.close()
        pool.join()
    finally:
        pool.terminate()                            # cancel or error: stop every worker
    return out


def _worker_pids(pool):
    """The pool's worker process ids (empty if this Python's Pool hides them)."""
    return {p.pid for p in getattr(pool, "_pool", ()) or ()}


def _map_dask(fn, tasks, labels, nw, address, progress):
    try:
        from distributed import Client, LocalCluster
    except ImportError as exc:
        raise SettingsError(f"--dask needs the 'distributed' package ({exc}); install it"
                            " with: pip install 'dask[distributed]'") from exc
    n = len(tasks)
    cluster = None
    try:
        if address == "local":
            import dask
            # Dask's nanny sets OMP/MKL/OPENBLAS_NUM_THREADS=1 in its workers; keep this
            # process's BLAS threads instead, or float rounding differs from a run here
            environ = {k: v for k, v in
                       dask.config.get("distributed.nanny.pre-spawn-environ", {}).items()
                       if not k.endswith("_NUM_THREADS")}
            environ.update({k: v for k, v in os.environ.items() if k.endswith("_NUM_THREADS")})
            environ.update(worker_environ(nw))
            with dask.config.set({"distributed.nanny.pre-spawn-environ": environ}):
                cluster = LocalCluster(n_workers=nw, threads_per_worker=1, processes=True,
                                       dashboard_address=None, host="127.0.0.1")
            client = Client(cluster)
        else:
            try:
                client = Client(address, timeout=10)
            except OSError as exc:
                raise SettingsError(f"cannot reach the Dask scheduler {address!r}: {exc}") \
                    from exc
    except BaseException:
        if cluster is not None:
            cluster.close()
        raise
    out = [None] * n
    try:
        futures = {}
        for i, task in enumerate(tasks):
            args = task() if callable(task) else task
            futures[client.submit(_call, fn, args, pure=False, key=f"invrad-room-{i}-"
                                  f"{os.getpid()}-{time.time_ns()}")] = i
            tasks[i] = None
        done = 0
        try:
            while futures:
                finished = [f for f in futures if f.done()]
                for f in finished:
                    i = futures.pop(f)
                    out[i] = f.result()             # re-raises a worker's exception
                    done += 1
                    _tell(progress, done / n, f"{done}/{n} rooms: {labels[i]} done")
                if not finished:
                    _tell(progress, done / n, f"{done}/{n} rooms on Dask")
                    time.sleep(POLL_S)
        except BaseException:
            client.cancel(list(futures))
            raise
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    return out
