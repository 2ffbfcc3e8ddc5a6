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


#: memory a worker process needs before its room (Python, numpy, an OpenCL context:
#: 120 MB resident measured) and a small room's work: the budget's share per worker
WORKER_BASE_BYTES = 256 << 20


def bound_workers(nw, rooms):
    """The worker processes to start for ``rooms`` rooms when ``nw`` were asked for: at
    most one per room, per usable core and per :data:`WORKER_BASE_BYTES` of the memory
    budget. Fewer than asked for (other than by the room count) is said in a warning."""
    from invrad_wb.core.model import memory
    n = max(1, min(nw, rooms))
    cores = usable_cores()
    budget, why = memory.budget()
    by_memory = max(1, int(budget // WORKER_BASE_BYTES))
    if n > cores or n > by_memory:
        limit = min(cores, by_memory)
        reason = (f"{cores} usable core(s)" if cores <= by_memory else
                  f"a memory budget of {memory.human(budget)} ({why}) at"
                  f" {memory.human(WORKER_BASE_BYTES)} per worker")
        import warnings
        warnings.warn(f"{nw} workers asked for, {limit} started: {reason}", stacklevel=3)
        n = limit
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


def blas_one_thread_limiter():
    """A callable giving a context in which every BLAS library loaded *now* runs on one
    thread (threadpoolctl's controller, made once here: entering a context then costs
    0.1 ms instead of the 1 ms of a fresh :func:`room_threads`).

    For a library loaded after :func:`room_threads` was entered, which that one does not
    know: scipy's BLAS, which Debian's and some wheels' scipy bring (another OpenBLAS than
    numpy's) when the radiosity's LU factors are first needed. Left with its own threads
    (2 on the 2-core machine) ``lu_factor`` of the office example's 1180 x 1180 matrix gave
    other last bits than on one thread, so a result would depend on the machine's cores
    and on whether the room ran in this process or in a worker (Dask's and the spawned
    workers start with one BLAS thread). Without threadpoolctl: no limit."""
    try:
        from threadpoolctl import ThreadpoolController
    except ImportError:
        return contextlib.nullcontext
    controller = ThreadpoolController()
    return lambda: controller.limit(limits=1, user_api="blas")


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
    if dask and dask != "local":
        return _map_dask(fn, tasks, labels, nw, dask, progress)
    nw = bound_workers(nw, n)
    if dask:
        return _map_dask(fn, tasks, labels, nw, dask, progress)
    if nw > 1 and n > 1 and worker_python() is not None:
        return _map_pool(fn, tasks, labels, nw, progress)
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
    _start_resource_tracker()
    import threading
    woken = threading.Event()                       # a room finished (or failed)

    def wake(_):
        woken.set()
    pool = None
    try:
        # a stop signal (Ctrl-C, SIGTERM) waits while the workers start: one spawned but
        # not yet told what to run would print an EOFError traceback; it comes right after
        with _stop_signals_deferred():
            with _plain_main(embedded), _environ(worker_environ(nw)):
                pool = ctx.Pool(nw, initializer=worker_init, initargs=(os.getpid(),))
        started = _worker_pids(pool)
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
        if pool is not None:
            pool.terminate()                        # cancel or error: stop every worker
    return out


def _start_resource_tracker():
    """Start multiprocessing's resource tracker with SIGHUP blocked, as Python blocks
    SIGINT and SIGTERM for it: a closed terminal (SIGHUP to the process group) would kill
    it, and it would be relaunched with KeyError tracebacks while the run stops."""
    import signal
    try:
        from multiprocessing import resource_tracker
    except ImportError:
        return
    hup = getattr(signal, "SIGHUP", None)
    if hup is None or not hasattr(signal, "pthread_sigmask"):
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {hup})
    try:
        resource_tracker.ensure_running()
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def _stop_signals():
    import signal
    return {getattr(signal, n) for n in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, n)}


@contextlib.contextmanager
def _stop_signals_deferred():
    """SIGINT, SIGTERM and SIGHUP held back while the block runs, then delivered again
    (to whatever handler was there). Main thread only (elsewhere: no-op). Each is held by
    a handler that notes it (whichever thread the kernel delivers it to), and:

    SIGINT and SIGHUP are blocked in the signal mask, which the workers started meanwhile
    inherit through fork and exec: Ctrl-C or a hang-up reaches the whole process group, and
    a worker still importing ``site`` died of it with "Fatal Python error:
    init_import_site"; :func:`worker_init` ignores them, then unblocks them (a pending one
    is dropped). SIGTERM is held by a handler instead: a blocked SIGTERM inherited by a
    worker that is still starting would keep ``pool.terminate`` from stopping it."""
    import signal
    import threading
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught, saved = [], {}

    def hold(signum, frame):
        caught.append(signum)
    masked = {sig for sig in _stop_signals() if sig != signal.SIGTERM
              and signal.getsignal(sig) not in (signal.SIG_IGN, None)}
    can_mask = hasattr(signal, "pthread_sigmask")
    old_mask = signal.pthread_sigmask(signal.SIG_BLOCK, masked) if can_mask else None
    try:
        # every stop signal is also held by a handler: a signal for the process reaches
        # any thread that does not block it (an OpenCL runtime's, the pool's), and Python
        # then runs the handler in the main thread all the same; a KeyboardInterrupt
        # raised there inside the pool's constructor left a worker spawned but not told
        # what to run (EOFError traceback) or started with nobody to stop it
        # (FileNotFoundError on the pool's semaphore, the parent gone)
        for sig in _stop_signals():
            saved[sig] = signal.getsignal(sig)
            if saved[sig] is signal.SIG_IGN or saved[sig] is None:
                del saved[sig]
                continue
            signal.signal(sig, hold)
        yield
    finally:
        for sig, old in saved.items():
            signal.signal(sig, old)
        if old_mask is not None:
            signal.pthread_sigmask(signal.SIG_SETMASK, old_mask)   # pending ones arrive
        for sig in dict.fromkeys(caught):
            os.kill(os.getpid(), sig)           # now to the real handler


def worker_init(parent=None):
    """Set-up of a local worker process: the parent alone decides when to stop.

    Ctrl-C reaches every process of the terminal's group: a worker ignores SIGINT (no
    KeyboardInterrupt traceback of its own); the parent stops it (``pool.terminate``:
    SIGTERM, which ends it at once). Linux: a worker is killed when the parent dies,
    whatever the way (SIGKILL, out of memory), instead of computing on for nobody and
    printing BrokenPipeError tracebacks when it hands its result in."""
    import signal
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if hasattr(signal, "SIGHUP"):
        signal.signal(signal.SIGHUP, signal.SIG_IGN)     # the parent stops it, as for SIGINT
    if hasattr(signal, "pthread_sigmask"):
        # blocked by the parent while it started this worker (_stop_signals_deferred):
        # ignored now, a pending one is dropped
        signal.pthread_sigmask(signal.SIG_UNBLOCK, _stop_signals() - {signal.SIGTERM})
    if sys.platform.startswith("linux"):
        try:
            import ctypes
            libc = ctypes.CDLL(None, use_errno=True)
            PR_SET_PDEATHSIG = 1
            libc.prctl(PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
            if parent is not None and os.getppid() != parent:   # it died before this line
                os._exit(1)
        except (OSError, AttributeError):
            pass


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
    before = _clusters()
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
            timeout = dask_timeout()
            probe_scheduler(address, timeout)
            try:
                client = Client(address, timeout=timeout)
            except OSError as exc:
                raise SettingsError(f"cannot reach the Dask scheduler {address!r}: {exc}") \
                    from exc
    except BaseException as exc:
        if isinstance(exc, KeyboardInterrupt):          # Ctrl-C, SIGTERM while starting
            _quiet_dask()
            for c in _clusters() - before:              # also one half made
                _kill_local_workers(c)
                with contextlib.suppress(Exception):
                    c.close(timeout=DASK_CLOSE_S)
        elif cluster is not None:
            cluster.close()
        raise
    out = [None] * n
    stopping = False
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
        except BaseException as exc:
            stopping = isinstance(exc, KeyboardInterrupt)    # Ctrl-C, SIGTERM, SIGHUP
            if stopping:
                _quiet_dask()
            if stopping and cluster is not None:
                _kill_local_workers(cluster)        # before the cancel: nothing to wait on
            with contextlib.suppress(Exception):
                client.cancel(list(futures))
            raise
    finally:
        with contextlib.suppress(Exception) if stopping else contextlib.nullcontext():
            client.close(timeout=DASK_CLOSE_S if stopping else None)
        if cluster is not None:
            with contextlib.suppress(Exception) if stopping else contextlib.nullcontext():
                cluster.close(timeout=DASK_CLOSE_S if stopping else None)
    return out


#: seconds a stopping run waits for its Dask client and local cluster to close
DASK_CLOSE_S = 2


#: seconds to wait for a Dask scheduler (``$INVRAD_DASK_TIMEOUT`` changes it)
DASK_TIMEOUT_S = 10.0
ENV_DASK_TIMEOUT = "INVRAD_DASK_TIMEOUT"


def dask_timeout():
    """Seconds to wait for a Dask scheduler: ``$INVRAD_DASK_TIMEOUT`` or
    :data:`DASK_TIMEOUT_S`."""
    text = os.environ.get(ENV_DASK_TIMEOUT, "").strip()
    if not text:
        return DASK_TIMEOUT_S
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not (value > 0 and value < 1e6):
        raise SettingsError(f"{ENV_DASK_TIMEOUT}={text!r}: give the seconds to wait for the"
                            " Dask scheduler (a positive number)")
    return value


def probe_scheduler(address, timeout):
    """Refuse at once a ``tcp://``/``tls://`` scheduler address nobody listens on.

    ``distributed.Client`` retries a refused connection until its timeout (10 s): a typo
    in the port would cost that wait. One plain TCP connection tells a refused port or an
    unknown host at once; a host that does not answer costs ``timeout``."""
    import socket
    from urllib.parse import urlsplit
    text = address if "://" in address else "tcp://" + address
    try:
        parts = urlsplit(text)
        host, port = parts.hostname, parts.port
    except ValueError as exc:
        raise SettingsError(f"--dask {address!r}: not a scheduler address ({exc}); give"
                            " tcp://host:port or 'local'") from None
    if parts.scheme not in ("tcp", "tls") or not host:
        return                          # other transports: distributed decides
    try:
        socket.create_connection((host, port or 8786), timeout=timeout).close()
    except OSError as exc:
        why = exc.strerror or type(exc).__name__
        if isinstance(exc, socket.timeout):
            why = f"no answer in {timeout:g} s ({ENV_DASK_TIMEOUT} to wait longer)"
        raise SettingsError(f"cannot reach the Dask scheduler {address!r}: {why}") from None


def _clusters():
    """The Dask clusters of this process (also those still starting)."""
    try:
        from distributed.deploy.spec import SpecCluster
        return set(SpecCluster._instances)
    except (ImportError, AttributeError, TypeError):
        return set()


def _quiet_dask():
    """A stopping run's Dask shutdown logs connection errors of workers it killed on
    purpose: not the user's business (the run says in one line that it stopped)."""
    import logging
    for name in ("distributed", "tornado", "asyncio"):
        logging.getLogger(name).setLevel(logging.CRITICAL + 1)


def _kill_local_workers(cluster):
    """Stop a local Dask cluster's worker processes at once: a graceful close waits for
    the room they compute (the nanny kills them only after 4 s)."""
    import signal
    # and no second close at exit (distributed's atexit hook asserts on a cluster whose
    # bounded close is still under way)
    with contextlib.suppress(Exception):
        cluster.shutdown_on_close = False
    for nanny in list(getattr(cluster, "workers", {}).values()):
        with contextlib.suppress(Exception):
            nanny.auto_restart = False
            pid = nanny.process.process.pid
            if pid:
                os.kill(pid, getattr(signal, "SIGKILL", signal.SIGTERM))
