#!/usr/bin/env python3
"""Fault probe of the command line (not part of ``make test``): every subcommand with
broken inputs, signals at random moments, a full disk (a small tmpfs, root only), an
address-space limit, huge counts. Each case runs in its own session and output folder;
the probe checks what a user must never see:

* a traceback or "internal error" on stderr;
* an error that is not one line (``invrad: error: ...``, exit 2);
* a process of the run still alive after it ended;
* a file or folder the run created left behind by a failed or stopped run (its own
  output folder, ``/tmp/invrad-*``, hidden ``.invrad-*`` staging files);
* a signal that did not end the run with ``128 + signal``.

It prints one row per case and a summary; exit status 1 when a case failed.

Usage: python bench/probe_faults.py [--only SUBSTRING] [--signals N] [--seed S]
"""
import argparse
import contextlib
import glob
import json
import os
import random
import resource
import shutil
import signal
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PY = [sys.executable, "-m", "invrad_wb"]
TIMEOUT = 240


# --------------------------------------------------------------------------- inputs
def make_inputs(d):
    """Scenes, luminaires, specs and broken files in folder d; returns a dict of paths."""
    p = {k: os.path.join(d, v) for k, v in {
        "room": "room.ply", "four": "four.ply", "truth": "truth.json",
        "batch": "batch", "spec": "spec.json", "many": "lums10k.json",
        "empty": "empty.ply", "garbage": "garbage.ply", "truncated": "truncated.ply",
        "nan_lums": "nan.json", "neg_lums": "neg.json", "bad_json": "bad.json",
        "dir": "a_folder", "nan_targets": "nan_targets.ply", "bad_spec": "bad_spec.json",
        "huge_lums": "lums200k.json", "missing": "no_such_file.ply"}.items()}
    run = lambda *a: subprocess.run(PY + list(a), cwd=ROOT, check=True,  # noqa: E731
                                    capture_output=True)
    run("example", "one_ceiling", "-o", p["room"], "--cell", "0.25", "--truth", p["truth"],
        "--reflectance", "0.5")
    run("example", "four_rooms", "-o", p["four"], "--cell", "0.4")
    os.makedirs(p["batch"])
    for s in ("a", "b", "c"):
        shutil.copy(p["four"], os.path.join(p["batch"], s + ".ply"))
    os.makedirs(p["dir"])
    with open(p["spec"], "w") as f:
        json.dump({"catalogue": [{"name": "D", "flux_lm": 2000, "watts": 15,
                                  "mounting": ["ceiling"]}],
                   "rooms": {str(r): {"room_type": "office"} for r in range(4)}}, f)
    with open(p["bad_spec"], "w") as f:
        json.dump({"catalogue": [{"name": "D", "flux_lm": -5}], "rooms": {}}, f)
    rng = random.Random(0)
    for key, n in (("many", 10_000), ("huge_lums", 200_000)):
        with open(p[key], "w") as f:
            json.dump({"luminaires": [{"position": [rng.uniform(0.2, 5.8),
                                                    rng.uniform(0.2, 3.8), 2.95],
                                       "normal": [0, 0, -1], "flux_lm": 3.0}
                                      for _ in range(n)]}, f)
    open(p["empty"], "w").close()
    with open(p["garbage"], "wb") as f:
        f.write(os.urandom(4096))
    with open(p["room"], "rb") as f:
        data = f.read()
    with open(p["truncated"], "wb") as f:
        f.write(data[:len(data) // 2])
    with open(p["nan_lums"], "w") as f:
        f.write('{"luminaires": [{"position": [NaN, 1, 2.9], "normal": [0, 0, -1],'
                ' "flux_lm": 1000}]}')
    with open(p["neg_lums"], "w") as f:
        f.write('{"luminaires": [{"position": [1, 1, 2.9], "normal": [0, 0, -1],'
                ' "flux_lm": -1000}]}')
    with open(p["bad_json"], "w") as f:
        f.write('{"luminaires": [')
    # every target NaN: a PLY whose lux column is nan
    text = subprocess.run([sys.executable, "-c", (
        "import numpy as np, sys; sys.path.insert(0, %r);"
        "from invrad_wb.core.io.sceneio import read_scene, write_scene;"
        "s = read_scene(%r); write_scene(%r, s, lux=np.full(len(s.vertices), np.nan))")
        % (ROOT, p["room"], p["nan_targets"])], capture_output=True, text=True)
    if text.returncode:
        print("(no NaN-target scene:", text.stderr.strip().splitlines()[-1:], ")")
    return p


# --------------------------------------------------------------------------- cases
class Case:
    def __init__(self, name, args, expect=(2,), sig=None, group=False, delay=None,
                 limit_as=None, env=None, outputs=()):
        self.name, self.args, self.expect = name, args, tuple(expect)
        self.sig, self.group, self.delay = sig, group, delay
        self.limit_as, self.env, self.outputs = limit_as, env or {}, outputs


def cases(p, out, n_signals, rng):
    """The probe's cases; ``out(name)`` is the case's own (not yet made) output folder."""
    c = []
    room, four, truth = p["room"], p["four"], p["truth"]
    ok_lums = ["--luminaires", truth]
    # ---- broken inputs, each subcommand
    for key in ("missing", "empty", "garbage", "truncated", "dir"):
        scene = p[key]
        c += [Case(f"info {key}", ["info", scene]),
              Case(f"render {key}", ["render", scene, *ok_lums, "-o", out("r") + "/o.ply"]),
              Case(f"locate {key}", ["locate", scene, "--flux", "3000", "-o",
                                     out("l") + "/r.json"]),
              Case(f"verify {key}", ["verify", scene, *ok_lums, "--report", out("v")]),
              Case(f"design {key}", ["design", scene, "--spec", p["spec"], "-o",
                                     out("d") + "/d.json"])]
    for key in ("nan_lums", "neg_lums", "bad_json", "missing", "empty", "dir"):
        c += [Case(f"render lums {key}", ["render", room, "--luminaires", p[key], "-o",
                                          out("r") + "/o.ply"]),
              Case(f"verify lums {key}", ["verify", room, "--luminaires", p[key],
                                          "--report", out("v")])]
    for key in ("bad_spec", "bad_json", "missing", "empty"):
        c.append(Case(f"design spec {key}", ["design", four, "--spec", p[key], "-o",
                                             out("d") + "/d.json"]))
    if os.path.exists(p["nan_targets"]):
        c += [Case("locate all-NaN targets", ["locate", p["nan_targets"], "--flux", "3000",
                                              "-o", out("l") + "/r.json"]),
              Case("verify all-NaN targets", ["verify", p["nan_targets"], *ok_lums,
                                              "--report", out("v")])]
    c += [Case("example unknown", ["example", "no_such", "-o", out("e") + "/x.ply"]),
          Case("locate --flux -5", ["locate", room, "--flux", "-5", "-o", out("l") + "/r.json"]),
          Case("locate --flux nan", ["locate", room, "--flux", "nan", "-o",
                                     out("l") + "/r.json"]),
          Case("locate --resolution 0", ["locate", room, "--flux", "3000", "--resolution",
                                         "0", "-o", out("l") + "/r.json"]),
          Case("locate -o into a file", ["locate", room, "--flux", "3000", "-o",
                                         room + "/r.json"]),
          Case("render -o = the scene", ["render", room, *ok_lums, "-o", room]),
          Case("freecad missing", ["freecad", p["missing"], "--out", out("f") + "/o.FCStd",
                                   "--report", out("f2")])]
    # ---- huge counts
    c += [Case("locate --workers 100000", ["locate", four, "--flux", "3000", "--workers",
                                           "100000", "-o", out("l") + "/r.json"],
               expect=(0, 2)),
          Case("locate --workers -1", ["locate", four, "--flux", "3000", "--workers", "-1",
                                       "-o", out("l") + "/r.json"]),
          Case("locate --resolution 1e-6", ["locate", room, "--flux", "3000", "--resolution",
                                            "1e-6", "-o", out("l") + "/r.json"]),
          Case("render 10,000 luminaires", ["render", room, "--luminaires", p["many"], "-o",
                                            out("r") + "/o.ply"], expect=(0,)),
          Case("verify 10,000 luminaires", ["verify", room, "--luminaires", p["many"],
                                            "--report", out("v")], expect=(0,)),
          Case("render 200,000 luminaires", ["render", room, "--luminaires", p["huge_lums"],
                                             "-o", out("r") + "/o.ply"], expect=(0, 2))]
    # ---- memory: an address-space limit below the vote maps' estimate
    c.append(Case("locate under ulimit -v 4 GB", ["locate", room, "--flux", "3000",
                                                   "--resolution", "0.0025", "-o",
                                                   out("l") + "/r.json"],
                  limit_as=4 << 30))
    c.append(Case("render under ulimit -v 1 GB", ["render", room, "--luminaires",
                                                   p["huge_lums"], "-o", out("r") + "/o.ply"],
                  limit_as=1 << 30, expect=(0, 2)))
    # ---- signals at random moments of long runs (with workers)
    long_runs = [
        ("locate batch", ["locate", p["batch"], "--flux", "3000", "-o", out("l"),
                          "--vote-maps", out("m"), "--workers", "2"]),
        ("design", ["design", four, "--spec", p["spec"], "-o", out("d") + "/d.json",
                    "--report", out("dr"), "--workers", "2"]),
        ("verify 10k", ["verify", room, "--luminaires", p["many"], "--report", out("v")]),
        ("render 10k", ["render", room, "--luminaires", p["many"], "-o",
                        out("r") + "/o.ply"]),
    ]
    sigs = [(signal.SIGTERM, False), (signal.SIGINT, True), (signal.SIGHUP, True)]
    for i in range(n_signals):
        name, args = long_runs[i % len(long_runs)]
        sig, group = sigs[rng.randrange(len(sigs))]
        delay = rng.uniform(0.2, 6.0)
        c.append(Case(f"{name} {sig.name}{' (group)' if group else ''} at {delay:.1f} s",
                      list(args), sig=sig, group=group, delay=delay))
    return c


# --------------------------------------------------------------------------- running
def _session_pids(sid):
    out = []
    for d in os.listdir("/proc"):
        if not d.isdigit():
            continue
        try:
            with open(f"/proc/{d}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
            if fields[0] != "Z" and int(fields[3]) == sid:
                out.append(int(d))
        except (OSError, IndexError, ValueError):
            pass
    return out


def _tmp_leftovers():
    # the job folders of the freecad command (other invrad folders there belong to the
    # test suites of other runs on a shared machine)
    return set(glob.glob(os.path.join(tempfile.gettempdir(), "invrad-freecad-*")))


def run_case(case, workdir):
    before_tmp = _tmp_leftovers()
    before = _listing(workdir)
    env = dict(os.environ, **case.env)

    def limits():
        # a user at a terminal: Ctrl-C and hang-up as the defaults (a probe started in
        # the background by a shell without job control inherits SIGINT ignored, and
        # invrad rightly keeps an ignored signal ignored)
        for s in (signal.SIGINT, signal.SIGHUP, signal.SIGTERM):
            signal.signal(s, signal.SIG_DFL)
        if case.limit_as:
            resource.setrlimit(resource.RLIMIT_AS, (case.limit_as, case.limit_as))
    t = time.time()
    proc = subprocess.Popen(PY + [str(a) for a in case.args], cwd=ROOT, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            start_new_session=True, preexec_fn=limits)
    signalled = False
    try:
        if case.sig is not None:
            try:
                proc.wait(timeout=case.delay)
            except subprocess.TimeoutExpired:
                (os.killpg if case.group else os.kill)(proc.pid, case.sig)
                signalled = True
        _, err = proc.communicate(timeout=TIMEOUT)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        _, err = proc.communicate()
        return [f"no end in {TIMEOUT} s (killed)"], time.time() - t, proc.returncode, err, []
    seconds = time.time() - t
    time.sleep(0.3)
    problems = []
    left = _session_pids(proc.pid)
    if left:
        problems.append(f"{len(left)} process(es) left")
        for pid in left:
            with contextlib.suppress(OSError):
                os.kill(pid, signal.SIGKILL)
    if "Traceback" in err:
        problems.append("traceback")
    if "internal error" in err:
        problems.append("internal error")
    rc = proc.returncode
    # signalled: it must stop with 128 + signal; a run that ended before the moment: 0
    expect = ((128 + case.sig,) if signalled else (0,)) if case.sig else case.expect
    if rc not in expect:
        problems.append(f"exit {rc}, expected {'/'.join(map(str, expect))}")
    lines = [l for l in err.splitlines() if l.strip() and not l.startswith("invrad: warning")
             and "AVX vector" not in l and "this takes a while" not in l
             and not l.startswith("invrad: built")]
    if rc == 2 and not (len(lines) == 1 and lines[0].startswith("invrad: error:")):
        problems.append(f"{len(lines)} stderr lines for an error")
    if rc != 0:
        made = _listing(workdir) - before
        if made:
            problems.append("left: " + ", ".join(sorted(os.path.relpath(m, workdir)
                                                       for m in made))[:80])
        tmp = _tmp_leftovers() - before_tmp
        if tmp:
            problems.append("left in /tmp: " + ", ".join(sorted(tmp))[:80])
    return problems, seconds, rc, err, lines


def _listing(d):
    out = set()
    for root, dirs, files in os.walk(d):
        for n in dirs + files:
            out.add(os.path.join(root, n))
    return out


@contextlib.contextmanager
def full_disk(path):
    """A 256 kB tmpfs at path, filled to the last byte (root only), or None."""
    os.makedirs(path, exist_ok=True)
    if os.geteuid() != 0 or subprocess.run(["mount", "-t", "tmpfs", "-o", "size=256k",
                                            "tmpfs", path], capture_output=True).returncode:
        yield None
        return
    try:
        fd = os.open(os.path.join(path, "filler"), os.O_WRONLY | os.O_CREAT)
        try:
            with contextlib.suppress(OSError):
                while True:
                    os.write(fd, b"\0" * 4096)
        finally:
            os.close(fd)
        yield path
    finally:
        subprocess.run(["umount", path], capture_output=True)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--only", help="run the cases whose name holds this text")
    ap.add_argument("--signals", type=int, default=12, help="signal cases (random moments)")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    rng = random.Random(args.seed)
    top = tempfile.mkdtemp(prefix="probe-")
    inputs = make_inputs(os.path.join(top, "in"))
    work = os.path.join(top, "work")
    os.makedirs(work)
    counter = [0]

    def out(stem):
        counter[0] += 1
        return os.path.join(work, f"{stem}{counter[0]}")
    todo = cases(inputs, out, args.signals, rng)
    disk = os.path.join(top, "full")
    with full_disk(disk) as fs:
        if fs is not None:
            todo += [Case("locate -o on a full disk", ["locate", inputs["room"], "--flux",
                                                       "3000", "-o", fs + "/r.json"]),
                     Case("locate --vote-maps on a full disk",
                          ["locate", inputs["room"], "--flux", "3000", "-o",
                           out("l") + "/r.json", "--vote-maps", fs + "/maps"]),
                     Case("verify --report on a full disk",
                          ["verify", inputs["room"], "--luminaires", inputs["truth"],
                           "--report", fs + "/rep"]),
                     Case("render -o on a full disk", ["render", inputs["room"],
                                                       "--luminaires", inputs["many"],
                                                       "-o", fs + "/o.ply"]),
                     Case("design -o on a full disk", ["design", inputs["four"], "--spec",
                                                       inputs["spec"], "-o", fs + "/d.json"])]
        else:
            print("(no full-disk cases: mounting a tmpfs needs root)")
        if args.only:
            todo = [t for t in todo if args.only in t.name]
        bad = 0
        print(f"{'case':46s} {'exit':>5s} {'s':>6s}  verdict / stderr")
        for case in todo:
            problems, seconds, rc, err, lines = run_case(case, work if fs is None or
                                                         fs not in " ".join(case.args)
                                                         else fs)
            first = (lines[0] if lines else "")[:90]
            verdict = "ok" if not problems else "FAIL: " + "; ".join(problems)
            bad += bool(problems)
            print(f"{case.name[:46]:46s} {str(rc):>5s} {seconds:6.1f}  {verdict}"
                  + (f"\n{'':61s}{first}" if first else ""), flush=True)
            if problems and ("traceback" in verdict or "internal" in verdict):
                print("    " + "\n    ".join(err.strip().splitlines()[-6:]))
    print(f"\n{len(todo)} cases, {len(todo) - bad} clean, {bad} with a problem")
    shutil.rmtree(top, ignore_errors=True)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
