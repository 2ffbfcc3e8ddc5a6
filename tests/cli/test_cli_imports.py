"""What ``python -m invrad_wb locate`` loads: the command line and the modules a locate
run imports (the core's locate, scene reading, the requirement check, JSON writing) leave
out the report's and the GUI's heavy libraries; each costs every run 0.2-1 s of start-up."""
import subprocess
import sys

from repo_paths import ROOT

#: libraries that ``locate`` never needs
HEAVY = ("matplotlib", "weasyprint", "jinja2", "dask", "distributed", "trimesh",
         "ifcopenshell", "FreeCAD", "PIL", "tqdm")


def test_the_locate_command_imports_no_report_library():
    code = ("import sys; import invrad_wb.cli, invrad_wb.cli.locate;"
            " import invrad_wb.core.inverse.locate, invrad_wb.core.io.sceneio,"
            " invrad_wb.core.io.atomic, invrad_wb.core.io.jsonout;"
            " import invrad_wb.core.design.requirements, invrad_wb.core.output.fitquality;"
            f" print(' '.join(m for m in {HEAVY!r} if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120, cwd=ROOT)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == []


def test_the_colour_scale_is_still_matplotlibs_viridis():
    # made on first use now: the same nine stops
    import numpy as np
    from invrad_wb.core.output import images
    v = images.VIRIDIS
    assert v.shape == (9, 3)
    np.testing.assert_allclose(v[0], [68.08602, 1.24287, 84.000825], atol=1e-4)
    np.testing.assert_allclose(v[-1], [253.27824, 231.070035, 36.70368], atol=1e-4)
    rgb = images.false_colour(np.array([0.0, 100.0, np.nan]), 0.0, 100.0)
    assert tuple(rgb[0]) == tuple(np.round(v[0]).astype(np.uint8))
    assert tuple(rgb[1]) == tuple(np.round(v[-1]).astype(np.uint8))


def _leave(tmp_path, body, env=None):
    import os
    out = tmp_path / "out.txt"
    code = ("import sys, atexit; from invrad_wb.cli.common import leave;"
            f" atexit.register(lambda: open({str(tmp_path / 'hook')!r}, 'w').close());"
            + body)
    with open(out, "w") as fh:
        p = subprocess.run([sys.executable, "-c", code], stdout=fh, stderr=subprocess.PIPE,
                           text=True, timeout=60, cwd=ROOT,
                           env=dict({k: v for k, v in os.environ.items()
                                     if k != "PYTHONUNBUFFERED"}, **(env or {})))
    return p, out.read_text(), (tmp_path / "hook").exists()


def test_leave_flushes_the_output_runs_the_exit_hooks_and_keeps_the_status(tmp_path):
    # stdout to a file is block-buffered: 100 kB still in the buffer when leave() is called
    p, text, hooked = _leave(tmp_path, "print('x' * 100000, end=''); leave(3)")
    assert p.returncode == 3, p.stderr
    assert text == "x" * 100000 and hooked
    p, text, hooked = _leave(tmp_path, "print('ok'); leave(None)")
    assert p.returncode == 0 and text == "ok\n" and hooked


def test_leave_waits_for_a_live_thread_as_python_does(tmp_path):
    body = ("import threading, time; t = threading.Thread(target=lambda: (time.sleep(0.3),"
            " print('thread done'))); t.start(); leave(4)")
    p, text, hooked = _leave(tmp_path, body)
    assert p.returncode == 4 and text == "thread done\n" and hooked


def test_leave_skips_the_finalisation_unless_a_profiler_or_tracer_runs(tmp_path):
    # a module-level object's __del__ runs in the interpreter's finalisation only; it
    # writes through a descriptor it holds (sys.stdout may be gone by then)
    body = ("import os\nfd = os.dup(1)\n"
            "class D:\n    def __del__(self, w=os.write, fd=fd): w(fd, b'finalised')\n"
            "d = D()\n{}leave(0)")
    p, text, hooked = _leave(tmp_path, "\n" + body.format(""))
    assert p.returncode == 0 and hooked and "finalised" not in text
    p, text, hooked = _leave(tmp_path, "\n" + body.format("sys.settrace(lambda *a: None)\n"))
    assert p.returncode == 0 and hooked and "finalised" in text       # as Python ends
    p, text, hooked = _leave(tmp_path, "\n" + body.format(""), {"INVRAD_SLOW_EXIT": "1"})
    assert p.returncode == 0 and "finalised" in text
