"""Fault injection (SQLite's way): signals at several points of a run, a full file system, a
read-only one, an I/O error while writing. Each asserts the exit status, a one-line
message, no traceback, no process left, no output the run created left behind, and the
user's earlier files byte-identical. (The address-space limit: tests/core/model/test_memory_limits.py.)
"""
import contextlib
import errno
import hashlib
import os
import signal
import subprocess
import sys
import time

import pytest
from repo_paths import ROOT

PY = [sys.executable, "-m", "invrad_wb"]


# --------------------------------------------------------------------------- helpers
def _example_batch(tmp_path_factory, name, example, cell):
    """A batch folder holding the example scene ``example`` twice (a.ply, b.ply), and the
    file of its known luminaires."""
    d = tmp_path_factory.mktemp(name)
    batch = d / "batch"
    batch.mkdir()
    truth = d / "truth.json"
    subprocess.run(PY + ["example", example, "-o", str(batch / "a.ply"), "--cell", cell,
                         "--truth", str(truth)], cwd=ROOT, check=True, capture_output=True)
    (batch / "b.ply").write_bytes((batch / "a.ply").read_bytes())
    return batch, truth


@pytest.fixture(scope="module")
def scenes(tmp_path_factory):
    """Two small four-room scenes in a folder (a batch), and one's known luminaires."""
    return _example_batch(tmp_path_factory, "scenes", "four_rooms", "0.4")


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    """A one-room scene (twice, in a batch folder) and its known luminaire."""
    return _example_batch(tmp_path_factory, "small", "one_ceiling", "0.5")


def _tree(path):
    """{relative path: sha256} of every file under path (the user's earlier files)."""
    out = {}
    for root, _, files in os.walk(path):
        for f in files:
            p = os.path.join(root, f)
            with open(p, "rb") as fh:
                out[os.path.relpath(p, path)] = hashlib.sha256(fh.read()).hexdigest()
    return out


def _children(pid):
    """Every process below pid (workers, their helpers)."""
    out, todo = set(), [pid]
    while todo:
        p = todo.pop()
        try:
            tasks = os.listdir(f"/proc/{p}/task")
        except OSError:
            continue
        for t in tasks:
            try:
                with open(f"/proc/{p}/task/{t}/children") as fh:
                    kids = {int(x) for x in fh.read().split()}
            except OSError:
                continue
            todo += sorted(kids - out)
            out |= kids
    return out


def _ignores_sigint(pid):
    try:
        with open(f"/proc/{pid}/status") as fh:
            line = next(l for l in fh if l.startswith("SigIgn:"))
    except (OSError, StopIteration):
        return False
    return bool(int(line.split()[1], 16) & (1 << (signal.SIGINT - 1)))


def _alive(pid):
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def _one_line(stderr):
    lines = [l for l in stderr.splitlines() if l.strip()]
    assert "Traceback" not in stderr and "internal error" not in stderr, stderr
    assert len(lines) == 1, stderr
    return lines[0]


def _wait_for(cond, timeout=120.0):
    t = time.time()
    while time.time() - t < timeout:
        if cond():
            return True
        time.sleep(0.05)
    return False


needs_proc = pytest.mark.skipif(not os.path.isdir("/proc/self/task"),
                                reason="needs Linux /proc to find worker processes")


def _as_in_a_terminal():
    """A child's stop signals as a terminal gives them (preexec_fn): the suite itself may run
    under ``nohup`` (SIGHUP ignored) or as a background job (SIGINT ignored), which a child
    inherits and invrad rightly keeps (test_the_guard_leaves_ignored_signals_ignored_...)."""
    for s in (signal.SIGINT, signal.SIGHUP, signal.SIGTERM):
        signal.signal(s, signal.SIG_DFL)


def _signalled(args, sig, when, tmp_path, group=False):
    """Run the CLI, send ``sig`` when ``when`` ('start': at once; 'workers': once worker
    processes run; 'room': once a batch announced its first scene), return
    (returncode, stderr, worker pids)."""
    out = open(tmp_path / "stdout.txt", "w+")
    p = subprocess.Popen(PY + [str(a) for a in args], cwd=ROOT, stdout=out,
                         stderr=subprocess.PIPE, text=True, start_new_session=True,
                         preexec_fn=_as_in_a_terminal)
    kids = set()
    try:
        if when == "workers":
            # workers that have started (their set-up ignores SIGINT); a signal while the
            # pool spawns them: test_a_stop_signal_that_another_thread_takes_waits_for_the_
            # pool_too, and bench/probe_faults.py's signals at random points
            assert _wait_for(lambda: sum(_ignores_sigint(k) for k in _children(p.pid)) >= 2
                             or p.poll() is not None)
        elif when == "room":
            assert _wait_for(lambda: "[1/" in open(tmp_path / "stdout.txt").read()
                             or p.poll() is not None)
        else:
            time.sleep(0.3)
        assert p.poll() is None, "the run ended before the signal"
        kids = _children(p.pid)
        if group:       # a terminal's Ctrl-C or hang-up reaches the whole process group
            os.killpg(p.pid, sig)
        else:
            p.send_signal(sig)
        _, err = p.communicate(timeout=60)
    finally:
        if p.poll() is None:
            p.kill()
        out.close()
    time.sleep(0.2)
    return p.returncode, err, kids


# --------------------------------------------------------------------------- signals
@needs_proc
@pytest.mark.parametrize("sig,status,group,when", [
    ("SIGTERM", 143, False, "workers"),
    ("SIGINT", 130, True, "workers"),
    ("SIGHUP", 129, True, "room"),
    ("SIGTERM", 143, False, "start"),
])
def test_a_signal_stops_a_batch_cleanly(scenes, tmp_path, sig, status, group, when):
    batch, _ = scenes
    before = _tree(batch)
    out, maps = tmp_path / "results", tmp_path / "maps"
    rc, err, kids = _signalled(["locate", batch, "--flux", "3000", "-o", out, "--vote-maps",
                                maps, "--workers", "2"], getattr(signal, sig), when,
                               tmp_path, group)
    assert rc == status, err
    line = _one_line(err)
    assert line in ("invrad: interrupted", f"invrad: stopped by {sig}; outputs left as they"
                    " were before the run"), line
    assert not [k for k in kids if _alive(k)], "worker processes left running"
    # the folders the run made are gone (they held nothing finished); no staging folder
    assert not maps.exists() and (not out.exists() or os.listdir(out)), os.listdir(tmp_path)
    assert _tree(batch) == before


@needs_proc
def test_sigterm_stops_design_workers_and_keeps_earlier_outputs(scenes, tmp_path):
    batch, _ = scenes
    spec = tmp_path / "spec.json"
    spec.write_text('{"catalogue": [{"name": "D", "flux_lm": 2000, "watts": 15,'
                    ' "mounting": ["ceiling"]}], "rooms": {"0": {"room_type": "office"},'
                    ' "1": {"room_type": "office"}, "2": {"room_type": "office"},'
                    ' "3": {"room_type": "office"}}}')
    earlier = tmp_path / "design.json"
    earlier.write_text('{"earlier": true}\n')
    report = tmp_path / "report"
    report.mkdir()
    (report / "index.html").write_text("<p>earlier report</p>\n")
    before = _tree(tmp_path)
    rc, err, kids = _signalled(["design", batch / "a.ply", "--spec", spec, "-o", earlier,
                                "--report", report, "--workers", "2"], signal.SIGTERM,
                               "workers", tmp_path)
    assert rc == 143 and "SIGTERM" in _one_line(err)
    assert not [k for k in kids if _alive(k)]
    after = _tree(tmp_path)
    after.pop("stdout.txt", None)
    before.pop("stdout.txt", None)
    assert after == before, "an earlier output was touched"


# --------------------------------------------------------------------------- file systems
@contextlib.contextmanager
def _tmpfs(path, size, readonly=False):
    """A small tmpfs at path (root only), unmounted after; skips where it cannot mount."""
    path.mkdir(exist_ok=True)
    if os.geteuid() != 0:
        pytest.skip("mounting a small file system needs root (tmpfs size=...)")
    p = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(path)],
                       capture_output=True, text=True)
    if p.returncode:
        pytest.skip(f"cannot mount a tmpfs here: {p.stderr.strip() or p.returncode}")
    try:
        yield path
    finally:
        subprocess.run(["umount", str(path)], capture_output=True)


def _fill(folder):
    """Fill a file system to the last byte."""
    fd = os.open(folder / "filler", os.O_WRONLY | os.O_CREAT)
    try:
        with contextlib.suppress(OSError):
            while True:
                os.write(fd, b"\0" * 4096)
    finally:
        os.close(fd)


def _run(*args):
    return subprocess.run(PY + [str(a) for a in args], cwd=ROOT, capture_output=True,
                          text=True, timeout=300)


def test_a_full_disk_is_one_line_and_removes_what_the_run_created(small, tmp_path):
    batch, truth = small
    scene = batch / "a.ply"
    with _tmpfs(tmp_path / "small", "256k") as fs:
        earlier = fs / "r.json"
        earlier.write_text('{"earlier": true}\n')
        (fs / "old_report").mkdir()
        (fs / "old_report" / "index.html").write_text("<p>earlier</p>\n")
        _fill(fs)
        before = _tree(fs)
        # vote maps into a new folder; the result would replace an earlier file: the
        # first output checked (-o) is refused before any work
        p = _run("locate", scene, "--flux", "3000", "-o", earlier, "--vote-maps",
                 fs / "votes")
        line = _one_line(p.stderr)
        assert p.returncode == 2, p.stderr
        assert line.startswith(f"invrad: error: {earlier}: cannot write the output")
        assert "No space left on device" in line and ".invrad-" not in line
        assert _tree(fs) == before and sorted(os.listdir(fs)) == ["filler", "old_report",
                                                                   "r.json"]
        # a report replacing an earlier one
        p = _run("verify", scene, "--luminaires", truth, "--report", fs / "old_report")
        line = _one_line(p.stderr)
        assert p.returncode == 2 and f"{fs / 'old_report'}: cannot write" in line, p.stderr
        assert _tree(fs) == before and sorted(os.listdir(fs)) == ["filler", "old_report",
                                                                   "r.json"]
        # a batch: its -o folder and --vote-maps folder, made by the run, are removed
        p = _run("locate", batch, "--flux", "3000", "-o", fs / "results", "--vote-maps",
                 fs / "maps")
        assert p.returncode == 2 and "No space left on device" in p.stderr, p.stderr
        assert "Traceback" not in p.stderr and "internal error" not in p.stderr
        assert _tree(fs) == before and sorted(os.listdir(fs)) == ["filler", "old_report",
                                                                   "r.json"]
        # a design is refused before any work: before its scene is even read (a scene
        # that is no PLY would be the error otherwise)
        broken = tmp_path / "broken.ply"
        broken.write_text("not a mesh\n")
        spec = os.path.join(ROOT, "examples", "office_design.json")
        p = _run("design", broken, "--spec", spec, "-o", fs / "d.json")
        line = _one_line(p.stderr)
        assert p.returncode == 2, p.stderr
        assert line == f"invrad: error: {fs / 'd.json'}: cannot write the output: No space" \
                       " left on device"
        assert _tree(fs) == before


def test_a_read_only_file_system_is_refused_before_work(small, tmp_path):
    batch, truth = small
    with _tmpfs(tmp_path / "ro", "1m") as fs:
        (fs / "r.json").write_text("{}\n")
        subprocess.run(["mount", "-o", "remount,ro", str(fs)], check=True)
        before = _tree(fs)
        for args in (["locate", batch / "a.ply", "--flux", "3000", "-o", fs / "r.json"],
                     ["verify", batch / "a.ply", "--luminaires", truth, "--report",
                      fs / "rep"]):
            p = _run(*args)
            line = _one_line(p.stderr)
            assert p.returncode == 2 and str(fs) in line, p.stderr
            assert "Read-only file system" in line or "not writable" in line, line
        assert _tree(fs) == before


def test_an_io_error_while_writing_names_the_output_not_a_temporary_file(small, tmp_path,
                                                                        monkeypatch, capsys):
    """An EIO from the device while RESULT.json is written (after the checks passed)."""
    from invrad_wb import cli
    from invrad_wb.core.io import atomic
    batch, _ = small

    fsync = os.fsync

    def failing_fsync(fd):
        if ".invrad-probe-" in os.readlink(f"/proc/self/fd/{fd}"):
            return fsync(fd)          # the output check's probe passes
        raise OSError(errno.EIO, os.strerror(errno.EIO))
    monkeypatch.setattr(atomic.os, "fsync", failing_fsync)
    out = tmp_path / "new" / "r.json"
    (tmp_path / "earlier.txt").write_text("kept\n")
    rc = cli.main(["locate", str(batch / "a.ply"), "--flux", "3000", "-o", str(out)])
    assert rc == 2
    line = _one_line(capsys.readouterr().err)
    assert line == f"invrad: error: {out}: cannot write the output: Input/output error"
    assert not (tmp_path / "new").exists(), "the folder the run made is left"
    assert sorted(os.listdir(tmp_path)) == ["earlier.txt"]
    assert (tmp_path / "earlier.txt").read_text() == "kept\n"


def test_output_errors_are_named_by_the_path_the_user_gave(tmp_path):
    from invrad_wb import runguard
    from invrad_wb.outputs import check_file, check_folder
    with pytest.raises(OSError) as e:
        with runguard.RunGuard():
            check_folder(tmp_path / "maps", "--vote-maps")
            check_file(tmp_path / "r.json", "-o")
            (tmp_path / "maps").mkdir()
            exc = OSError(errno.ENOSPC, os.strerror(errno.ENOSPC),
                          str(tmp_path / "maps" / ".invrad-123-abc" / "x.png"))
            raise exc
    assert runguard.output_error(e.value) == (f"{tmp_path / 'maps'}: cannot write the"
                                              " output: No space left on device")
    assert not (tmp_path / "maps").exists()
    # an error that is not about an output stays what it is
    assert runguard.output_error(FileNotFoundError(errno.ENOENT, "x", "/nope")) is None


def test_the_guard_leaves_ignored_signals_ignored_and_restores_handlers():
    """``nohup`` (SIGHUP ignored) and background jobs (SIGINT ignored) keep what their
    caller asked for; the handlers before the run come back after it."""
    from invrad_wb import runguard
    old_hup = signal.signal(signal.SIGHUP, signal.SIG_IGN)
    old_term = signal.getsignal(signal.SIGTERM)
    try:
        with runguard.RunGuard():
            assert signal.getsignal(signal.SIGHUP) == signal.SIG_IGN
            assert signal.getsignal(signal.SIGTERM) != old_term
            with pytest.raises(runguard.Terminated) as e:
                os.kill(os.getpid(), signal.SIGTERM)
                time.sleep(5)                      # the handler raises before this ends
            assert e.value.exit_status == 143
        assert signal.getsignal(signal.SIGTERM) == old_term
    finally:
        signal.signal(signal.SIGHUP, old_hup)


def test_a_device_or_pipe_is_refused_as_an_output_and_left_as_it_is(tmp_path):
    """Outputs are renamed onto their path: onto /dev/null (as root) that would replace the
    device node with a plain file. Refused before any work instead."""
    from invrad_wb.outputs import check_file
    from invrad_wb.errors import InvradError
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    for dev in ("/dev/null", "/dev/full", str(fifo)):
        if not os.path.exists(dev):
            continue
        mode = os.stat(dev).st_mode
        with pytest.raises(InvradError, match="a device, pipe or socket, not a file"):
            check_file(dev, "-o")
        assert os.stat(dev).st_mode == mode
    p = _run("example", "one_ceiling", "-o", "/dev/null", "--cell", "0.5")
    assert p.returncode == 2 and "/dev/null: -o is a device" in _one_line(p.stderr)
    import stat
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode)


@pytest.fixture
def usual_stop_handlers():
    """SIGINT with Python's own handler and SIGHUP with its default, as in a terminal,
    whatever the test runner inherited (a shell starts a background job with SIGINT
    ignored, and an ignored signal is rightly left ignored by invrad)."""
    old = {signal.SIGINT: signal.signal(signal.SIGINT, signal.default_int_handler),
           signal.SIGHUP: signal.signal(signal.SIGHUP, signal.SIG_DFL)}
    yield
    for sig, handler in old.items():
        signal.signal(sig, handler)


def _sig_bits(status, field):
    line = next(l for l in status.splitlines() if l.startswith(field + ":"))
    return int(line.split()[1], 16)


def test_workers_start_with_ctrl_c_held_and_then_ignore_it(usual_stop_handlers):
    """A worker spawned while the parent starts its pool inherits SIGINT and SIGHUP blocked
    (a Ctrl-C to the process group while it still imported ``site`` killed it with "Fatal
    Python error: init_import_site"), and its set-up ignores them, then unblocks them;
    SIGTERM is never blocked in it (the pool's terminate must stop it)."""
    import signal
    from invrad_wb.core.accel import workers
    show = "print(open('/proc/self/status').read())"
    with workers._stop_signals_deferred():
        child = subprocess.run([sys.executable, "-c", show], capture_output=True, text=True,
                               check=True).stdout
    blocked = _sig_bits(child, "SigBlk")
    held = blocked | _sig_bits(child, "SigIgn")
    for sig in (signal.SIGINT, signal.SIGHUP):
        # blocked, or ignored where this process ignores it already (a shell starts a
        # background job with SIGINT ignored; exec keeps an ignored signal ignored)
        if signal.getsignal(sig) is signal.SIG_IGN:
            assert held & (1 << (sig - 1)), hex(held)
        else:
            assert blocked & (1 << (sig - 1)), hex(blocked)
    assert not blocked & (1 << (signal.SIGTERM - 1)), hex(blocked)
    # the parent's own mask is back as it was
    assert not signal.pthread_sigmask(signal.SIG_BLOCK, set()) & {signal.SIGINT, signal.SIGHUP}
    init = ("import signal; from invrad_wb.core.accel.workers import worker_init;"
            " signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGHUP});"
            " worker_init(); " + show)
    after = subprocess.run([sys.executable, "-c", init], capture_output=True, text=True,
                           check=True, cwd=ROOT).stdout
    assert not _sig_bits(after, "SigBlk") & ((1 << (signal.SIGINT - 1))
                                            | (1 << (signal.SIGHUP - 1)))
    ignored = _sig_bits(after, "SigIgn")
    assert ignored & (1 << (signal.SIGINT - 1)) and ignored & (1 << (signal.SIGHUP - 1))


@needs_proc
@pytest.mark.parametrize("sig,status", [("SIGTERM", 143), ("SIGHUP", 129)])
def test_a_direct_freecad_cmd_run_is_guarded_too(tmp_path, sig, status):
    """``python -m invrad_wb.cli.freecad_cmd`` (not through ``python -m invrad_wb``) stops
    on SIGTERM/SIGHUP like the main command line: one line, 128 + signal, its freecadcmd
    child stopped and its job folder removed (it died of the signal, leaving the folder)."""
    import zipfile
    doc = tmp_path / "in.FCStd"
    with zipfile.ZipFile(doc, "w") as z:
        z.writestr("Document.xml", "<Document/>")
    started = tmp_path / "child.pid"
    fake = tmp_path / "freecadcmd"
    fake.write_text(f"#!/bin/sh\necho $$ > {started}\nexec sleep 60\n")
    fake.chmod(0o755)
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    p = subprocess.Popen([sys.executable, "-m", "invrad_wb.cli.freecad_cmd", str(doc),
                          "--out", str(tmp_path / "out.FCStd"), "--report",
                          str(tmp_path / "report"), "--freecadcmd", str(fake)], cwd=ROOT,
                         stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                         start_new_session=True, env=dict(os.environ, TMPDIR=str(tmp)),
                         preexec_fn=_as_in_a_terminal)
    try:
        assert _wait_for(lambda: started.exists() and started.read_text().strip()
                         or p.poll() is not None, 60)
        assert p.poll() is None, p.communicate()[1]
        child = int(started.read_text())
        p.send_signal(getattr(signal, sig))
        _, err = p.communicate(timeout=60)
    finally:
        if p.poll() is None:
            p.kill()
    assert p.returncode == status, err
    assert sig in _one_line(err)
    assert _wait_for(lambda: not _alive(child), 10), "freecadcmd left running"
    assert os.listdir(tmp) == [], "job folder left behind"
    assert not (tmp_path / "out.FCStd").exists() and not (tmp_path / "report").exists()


def test_a_stop_signal_that_another_thread_takes_waits_for_the_pool_too(usual_stop_handlers):
    """A signal for the process reaches any thread that does not block it (an OpenCL
    runtime's), and Python runs its handler in the main thread all the same: while the
    pool starts, it must be held, not raised (a KeyboardInterrupt inside the pool's
    constructor left a worker spawned but never told what to run: an EOFError traceback,
    or a FileNotFoundError on the pool's semaphore), and delivered after."""
    import threading
    from invrad_wb.core.accel import workers
    stop = threading.Event()
    other = threading.Thread(target=stop.wait)       # started before: SIGINT not blocked
    other.start()
    inside = None
    try:
        with pytest.raises(KeyboardInterrupt):
            with workers._stop_signals_deferred():
                signal.pthread_kill(other.ident, signal.SIGINT)
                for _ in range(50):
                    time.sleep(0.002)              # Python would run the handler here
                inside = "held"
            time.sleep(0.1)
    finally:
        stop.set()
        other.join()
    assert inside == "held"
