"""Run invrad's FreeCAD tests (``tests/freecad/test_*.py``, unittest) under freecadcmd.

Two ways to start it::

    PYTHONPATH=<venv site-packages>:<checkout> freecadcmd tests/freecad/run.py
    .venv/bin/python tests/freecad/run.py [-k PATTERN] [-v]   # re-launches under freecadcmd

``INVRAD_FC_TESTS=PATTERN`` (or ``-k``) keeps only tests whose id contains PATTERN.
At the end the slowest tests are listed with their wall and CPU seconds (CPU of this
process and of the children it waited for), like pytest's ``--durations``
(``INVRAD_FC_DURATIONS=N``, default 15; 0: none).
FreeCAD's recompute progress bars, which its C++ console writes to stdout, are silenced
unless ``INVRAD_FC_NOISE=1``.

Exit status: 0 when every test passed, 1 otherwise. freecadcmd exits 0 even after an
uncaught exception in a script, so the runner ends with ``os._exit(status)``.
"""
import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))


def _inside_freecad():
    fc = sys.modules.get("FreeCAD")
    return fc is not None and hasattr(fc, "newDocument")


def _selected(suite, pattern):
    import unittest
    out = unittest.TestSuite()
    for t in suite:
        if isinstance(t, unittest.TestSuite):
            out.addTests(_selected(t, pattern))
        elif not pattern or pattern in t.id():
            out.addTest(t)
    return out


def _cpu_s():
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


def _timed_result(base):
    """``base`` (a TextTestResult class) that records each test's wall and CPU seconds."""
    class Timed(base):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            self.durations = []

        def startTest(self, test):
            self._t0 = (time.time(), _cpu_s())
            super().startTest(test)

        def stopTest(self, test):
            super().stopTest(test)
            w0, c0 = self._t0
            self.durations.append((time.time() - w0, _cpu_s() - c0, test.id()))
    return Timed


def _slowest(out, durations, n):
    if n <= 0 or not durations:
        return
    out.write(f"slowest {min(n, len(durations))} FreeCAD tests (wall s, CPU s):\n")
    for wall, cpu, name in sorted(durations, reverse=True)[:n]:
        out.write(f"{wall:8.1f} {cpu:8.1f}  {name}\n")


def run_inside():
    import unittest
    out = sys.stdout
    if not os.environ.get("INVRAD_FC_NOISE"):
        out = os.fdopen(os.dup(1), "w", buffering=1, encoding="utf-8", errors="replace")
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, 1)
        sys.stdout = out
    status = 1
    try:
        # FreeCAD 1.0's freecadcmd ignores PYTHONPATH: its folders are added here, in front
        paths = [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]
        for p in reversed([ROOT, HERE] + paths):
            if p not in sys.path:
                sys.path.insert(0, p)
        import FreeCAD
        out.write(f"invrad FreeCAD tests: FreeCAD {'.'.join(FreeCAD.Version()[:3])},"
                  f" Python {sys.version.split()[0]}\n")
        loader = unittest.TestLoader()
        suite = loader.discover(HERE, pattern="test_*.py", top_level_dir=HERE)
        suite = _selected(suite, os.environ.get("INVRAD_FC_TESTS", ""))
        verbosity = 2 if os.environ.get("INVRAD_FC_VERBOSE", "1") != "0" else 1
        t0 = time.time()
        runner = unittest.TextTestRunner(stream=out, verbosity=verbosity,
                                         resultclass=_timed_result(unittest.TextTestResult))
        result = runner.run(suite)
        _slowest(out, result.durations, int(os.environ.get("INVRAD_FC_DURATIONS", "15")))
        out.write(f"{result.testsRun} FreeCAD test(s) in {time.time() - t0:.1f} s:"
                  f" {len(result.failures)} failure(s), {len(result.errors)} error(s),"
                  f" {len(result.skipped)} skipped\n")
        status = 0 if result.wasSuccessful() and result.testsRun > 0 else 1
    except BaseException:
        import traceback
        traceback.print_exc(file=out)
        status = 1
    finally:
        out.flush()
        sys.stderr.flush()
        os._exit(status)


def relaunch(argv):
    import argparse
    import shutil
    import subprocess
    import sysconfig
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("-k", dest="pattern", help="only tests whose id contains this")
    ap.add_argument("-q", "--quiet", action="store_true")
    ap.add_argument("--freecadcmd", default=os.environ.get("INVRAD_FREECADCMD", "freecadcmd"))
    args = ap.parse_args(argv)
    exe = shutil.which(args.freecadcmd)
    if not exe:
        print(f"run.py: {args.freecadcmd} not found (install FreeCAD: freecad-python3)",
              file=sys.stderr)
        return 2
    env = os.environ.copy()
    paths = [sysconfig.get_paths()["purelib"], ROOT]
    if env.get("PYTHONPATH"):
        paths.append(env["PYTHONPATH"])
    env["PYTHONPATH"] = os.pathsep.join(paths)
    env.setdefault("QT_QPA_PLATFORM", "offscreen")
    if args.pattern:
        env["INVRAD_FC_TESTS"] = args.pattern
    if args.quiet:
        env["INVRAD_FC_VERBOSE"] = "0"
    return subprocess.call([exe, os.path.abspath(__file__)], env=env)


if _inside_freecad():
    run_inside()
elif __name__ == "__main__":
    sys.exit(relaunch(sys.argv[1:]))
