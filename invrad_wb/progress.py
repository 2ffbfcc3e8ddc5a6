"""The command line's progress: a bar on a terminal (tqdm), lines with ``-v``, else quiet."""
import sys


class CliProgress:
    """``progress(fraction, message) -> True`` for :func:`locate` / :func:`design`.

    On a terminal (stderr a TTY) a tqdm bar shows the fraction and the current step (the
    room's name); ``verbose`` prints one line per step instead; neither: nothing. Use as
    a context manager so the bar is closed (and the terminal line ended) on errors too.
    """

    def __init__(self, verbose=False, desc="invrad", stream=None):
        self.verbose = verbose
        self.stream = stream or sys.stderr
        self.bar = None
        self._last = None
        if not verbose and getattr(self.stream, "isatty", lambda: False)():
            try:
                from tqdm import tqdm
            except ImportError:
                tqdm = None
            if tqdm is not None:
                self.bar = tqdm(total=1000, desc=desc, file=self.stream, leave=False,
                                bar_format="{desc}: {percentage:3.0f}%|{bar}| {elapsed}"
                                           " {postfix}")

    def __call__(self, frac, msg):
        if self.verbose:
            if msg != self._last:
                print(f"  {100 * frac:5.1f} %  {msg}", file=self.stream)
                self._last = msg
        elif self.bar is not None:
            n = int(round(1000 * min(max(frac, 0.0), 1.0)))
            if n > self.bar.n:
                self.bar.update(n - self.bar.n)
            if msg != self._last:
                self.bar.set_postfix_str(msg, refresh=True)
                self._last = msg
        return True

    def close(self):
        if self.bar is not None:
            self.bar.close()
            self.bar = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False


#: rooms from which a locate or design announces its size before it starts (a 256-room
#: floor took minutes on two cores)
FLOOR_NOTE_ROOMS = 16


def floor_note(scene, workers=1, what="located"):
    """One line announcing a run over many rooms (rooms x faces), or None for a few."""
    rooms = getattr(scene, "rooms", None)
    rooms = 0 if rooms is None else len(rooms)
    if rooms < FLOOR_NOTE_ROOMS:
        return None
    faces = len(scene.faces)
    par = (f"{workers} at a time" if isinstance(workers, int) and workers > 1
           else "one after another (--workers N: N at a time)")
    return (f"{rooms} rooms x {faces // rooms} faces on average ({faces} faces): each room"
            f" is {what} on its own, {par}; this takes a while")


def add_parallel_args(p):
    """--workers and --dask (rooms in parallel; the result is the same as one by one)."""
    p.add_argument("--workers", default="1", metavar="N",
                   help="rooms on N local worker processes ('auto': one per core; default 1);"
                        " the result does not depend on N")
    p.add_argument("--dask", metavar="ADDRESS",
                   help="rooms on a Dask cluster: a scheduler address (tcp://host:8786) or"
                        " 'local' (a local cluster of --workers processes); the wait for a"
                        " scheduler is $INVRAD_DASK_TIMEOUT seconds (10)")


def workers_arg(value):
    from invrad_wb.core.accel.workers import check_workers
    from invrad_wb.errors import InvradError
    try:
        return check_workers(value.strip() if isinstance(value, str) else value)
    except InvradError as exc:
        raise InvradError(f"--workers: {exc}")
