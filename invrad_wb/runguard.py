"""A command's run guard: signals end it like Ctrl-C, and a failed run leaves no output it
created.

systemd and Kubernetes stop a service with SIGTERM and kill it after a grace period; a
closed terminal sends SIGHUP. Python's default for both is to die at once: worker processes
compute on with nobody to read their results, staging folders and half a batch stay
behind. Under :class:`RunGuard` (the command line's ``main`` wraps every command in one):

* SIGTERM, SIGHUP and SIGINT raise :class:`Terminated` (a ``KeyboardInterrupt``) in the main
  thread, so every ``finally`` and ``except BaseException`` of the run does its cleanup:
  worker pools are terminated and Dask futures cancelled
  (:mod:`invrad_wb.core.accel.workers`), temporary files and staging folders removed
  (:mod:`invrad_wb.core.io.atomic`). A second signal during that cleanup is ignored. The
  exit status is ``128 + signal`` (143 SIGTERM, 129 SIGHUP, 130 SIGINT), the message one
  line.
* Outputs are declared where they are checked, before any work
  (:func:`invrad_wb.outputs.check_file`/``check_folder`` call :func:`declare`), with
  whether they existed. When the run fails, a folder the run created is removed if it is
  empty (after a signal: results a batch finished stay); after an error writing an output
  (:func:`output_error`: a full disk, a read-only file system, an I/O error) everything
  the run created there is removed. What existed before the run is never touched.
* :func:`output_error` turns such an ``OSError`` into one line naming the path the user
  gave and the system's reason (errno text): a full disk is not a bug of invrad.
"""
import contextlib
import errno
import os
import shutil
import signal
import threading

#: signals handled like Ctrl-C (those the platform has)
SIGNALS = tuple(getattr(signal, n) for n in ("SIGTERM", "SIGHUP", "SIGINT")
                if hasattr(signal, n))

#: errors of the file system or device where an output is written: the user's to fix (free
#: space, a writable place), never a bug; one line naming the output, exit 2
OUTPUT_ERRNOS = frozenset(getattr(errno, n) for n in (
    "ENOSPC", "EDQUOT", "EROFS", "EIO", "EACCES", "EPERM", "EFBIG", "ENXIO", "ENODEV",
    "ESTALE", "ENOTCONN", "EREMOTEIO", "ENAMETOOLONG", "EMFILE", "ENFILE", "ENOMEM",
    "ENOTDIR", "EISDIR", "EEXIST", "ENOENT", "EXDEV", "EBUSY", "ETXTBSY", "ELOOP")
    if hasattr(errno, n))

#: errors that only writing gives: named as the last declared output's when the path does
#: not say which (a write() on a full disk has no file name)
WRITE_ERRNOS = frozenset(getattr(errno, n) for n in ("ENOSPC", "EDQUOT", "EROFS", "EIO",
                                                      "EFBIG") if hasattr(errno, n))

_active = None          # the RunGuard of the command now running (one per process)


class Terminated(KeyboardInterrupt):
    """The run was stopped by a signal (SIGTERM, SIGHUP, SIGINT)."""

    def __init__(self, signum):
        self.signum = int(signum)
        try:
            self.name = signal.Signals(self.signum).name
        except ValueError:
            self.name = f"signal {self.signum}"
        super().__init__(self.name)

    @property
    def exit_status(self):
        return 128 + self.signum


def exit_status(exc):
    """The exit status of an interrupted run: ``128 + signal``, 130 for a plain
    ``KeyboardInterrupt``."""
    return exc.exit_status if isinstance(exc, Terminated) else 128 + int(signal.SIGINT)


def interrupted_text(exc):
    """One line for an interrupted run."""
    if isinstance(exc, Terminated) and exc.name != "SIGINT":
        return f"stopped by {exc.name}; outputs left as they were before the run"
    return "interrupted"


def stop_early_on_signals():
    """Until a :class:`RunGuard` takes over: a stop signal while the modules load (nothing
    is made yet) ends the process with one line and ``128 + signal``, not a traceback from
    inside an import."""
    if threading.current_thread() is not threading.main_thread():
        return

    def stop(signum, frame):
        exc = Terminated(signum)
        try:
            os.write(2, f"invrad: {interrupted_text(exc)}\n".encode())
        finally:
            os._exit(exc.exit_status)
    for s in SIGNALS:
        try:
            if signal.getsignal(s) == signal.SIG_IGN:
                continue            # nohup, a background job: the caller asked to ignore it
            signal.signal(s, stop)
        except (ValueError, OSError):
            pass


class _Output:
    __slots__ = ("given", "real", "existed", "kind", "ancestor")

    def __init__(self, given, real, kind):
        self.given, self.real, self.kind = given, real, kind
        self.existed = os.path.lexists(real)
        probe = os.path.dirname(real)
        while probe and not os.path.exists(probe) and os.path.dirname(probe) != probe:
            probe = os.path.dirname(probe)
        self.ancestor = probe          # the nearest folder that existed before the run


def declare(given, real=None, kind="file"):
    """Note an output path (``given`` as the user wrote it; ``real`` where writes go) of the
    running command, before any work: whether it exists decides what a failure may remove.
    Does nothing outside a :class:`RunGuard`."""
    guard = _active
    if guard is None:
        return
    real = os.path.abspath(real or os.path.realpath(os.fspath(given)))
    if any(o.real == real for o in guard.outputs):
        return
    guard.outputs.append(_Output(os.fspath(given), real, kind))


class RunGuard:
    """Context manager around one command (see the module docstring)."""

    def __init__(self):
        self.outputs = []
        self._saved = {}
        self._stopping = False

    # ------------------------------------------------------------------ signals
    def _handler(self, signum, frame):
        if self._stopping:
            return                  # already stopping: let the cleanup finish
        self._stopping = True
        raise Terminated(signum)

    def __enter__(self):
        global _active
        _active = self
        if threading.current_thread() is threading.main_thread():
            for s in SIGNALS:
                try:
                    old = signal.getsignal(s)
                    if old == signal.SIG_IGN:
                        continue    # nohup, a background job: the caller asked to ignore it
                    signal.signal(s, self._handler)
                    self._saved[s] = old
                except (ValueError, OSError):
                    pass
        return self

    def __exit__(self, etype, exc, tb):
        global _active
        try:
            if exc is not None:
                self._stopping = True       # a signal now must not break the cleanup
                line = output_error(exc)
                if line is not None:
                    # said now, while the declared outputs are known (main reports it)
                    with contextlib.suppress(AttributeError, TypeError):
                        exc.invrad_output_error = line
                self.cleanup(remove_written=line is not None)
        finally:
            for s, old in self._saved.items():
                try:
                    signal.signal(s, old if old is not None else signal.SIG_DFL)
                except (ValueError, OSError):
                    pass
            self._saved = {}
            _active = None
        return False

    # ------------------------------------------------------------------ outputs
    def cleanup(self, remove_written=False):
        """Remove what the run created: empty folders always, everything it created at a
        declared output when ``remove_written`` (an output could not be written)."""
        for o in reversed(self.outputs):
            if o.existed:
                continue
            try:
                if remove_written and os.path.lexists(o.real):
                    if os.path.isdir(o.real) and not os.path.islink(o.real):
                        shutil.rmtree(o.real, ignore_errors=True)
                    else:
                        os.unlink(o.real)
                elif os.path.isdir(o.real) and not os.path.islink(o.real):
                    _remove_empty_tree(o.real)
            except OSError:
                pass
            # folders made on the way to it (``-o new/sub/r.json``), if empty now
            folder = os.path.dirname(o.real)
            while folder and len(folder) > len(o.ancestor) and folder.startswith(o.ancestor):
                try:
                    os.rmdir(folder)
                except OSError:
                    break
                folder = os.path.dirname(folder)


def _remove_empty_tree(top):
    """Remove ``top`` and the folders in it if they hold no file."""
    for root, dirs, files in os.walk(top, topdown=False):
        if not files:
            try:
                os.rmdir(root)
            except OSError:
                pass


def output_error(exc):
    """One line (without ``invrad: error:``) for an ``OSError`` of the file system where an
    output is written, naming the output as the user gave it; None for other errors."""
    if getattr(exc, "invrad_output_error", None):
        return exc.invrad_output_error
    if not isinstance(exc, OSError) or isinstance(exc, BrokenPipeError) \
            or exc.errno not in OUTPUT_ERRNOS:
        return None
    guard = _active
    outputs = guard.outputs if guard is not None else []
    target = getattr(exc, "output_path", None)       # set by core.io.atomic's writers
    names = [os.path.abspath(os.path.realpath(p)) for p in
             (target, exc.filename, getattr(exc, "filename2", None)) if p]
    given = None
    best = -1
    for o in outputs:
        for n in names:
            match = (n == o.real or n.startswith(o.real + os.sep)
                     or os.path.dirname(n) == os.path.dirname(o.real)
                     and os.path.basename(n).startswith(".invrad-"))
            if match and len(o.real) > best:
                given, best = o.given, len(o.real)
    if given is None:
        # not at a declared output: only errors that can only come from writing (a full
        # disk, a read-only file system, a failing device) are the output's; the rest
        # (a missing file, a refused permission elsewhere) stay what they are
        if not outputs or exc.errno not in WRITE_ERRNOS:
            return None
        given = outputs[-1].given
    reason = exc.strerror or os.strerror(exc.errno)
    return f"{given}: cannot write the output: {reason}"
