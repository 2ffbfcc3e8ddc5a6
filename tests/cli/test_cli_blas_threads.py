"""The command line runs BLAS on one thread from its start (numpy's OpenBLAS threads
busy-wait for about 0.1 CPU s after the import otherwise), unless the user set a BLAS
thread count; a process that loaded numpy before it (FreeCAD, a script) is left alone."""
import os
import subprocess
import sys

import pytest

from repo_paths import ROOT

VARS = ("OPENBLAS_NUM_THREADS", "GOTO_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def _cli_process(**env):
    pytest.importorskip("threadpoolctl")
    code = ("import os, invrad_wb.cli, numpy.linalg; from threadpoolctl import threadpool_info;"
            " print(os.environ.get('OPENBLAS_NUM_THREADS'), sorted({d['num_threads'] for d"
            " in threadpool_info() if d['internal_api'] == 'openblas'}))")
    base = {k: v for k, v in os.environ.items() if k not in VARS}
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       timeout=120, cwd=ROOT, env=dict(base, **env))
    assert p.returncode == 0, p.stderr
    return p.stdout.split(None, 1)


def test_the_command_line_starts_blas_on_one_thread():
    var, threads = _cli_process()
    assert var == "1"
    assert threads in ("[1]\n", "[]\n")     # [] where numpy's BLAS is not OpenBLAS


def test_a_thread_count_the_user_set_is_kept():
    var, threads = _cli_process(OMP_NUM_THREADS="2")
    assert var == "None"


def test_a_process_with_numpy_loaded_is_left_alone(monkeypatch):
    import numpy  # noqa: F401
    from invrad_wb.cli import blas
    for k in VARS:
        monkeypatch.delenv(k, raising=False)
    blas.one_blas_thread_at_start()
    assert not any(k in os.environ for k in VARS)


def test_a_child_process_gets_the_users_blas_settings_not_the_command_lines():
    # freecadcmd launched by `python -m invrad_wb freecad` inherits the environment: the
    # one-thread setting is the command line's own, taken out; the user's is passed on
    code = ("import invrad_wb.cli; from invrad_wb.cli.freecad_cmd import child_environment;"
            " e = child_environment(); print(e.get('OPENBLAS_NUM_THREADS'),"
            " e.get('MKL_NUM_THREADS'), e.get('OMP_NUM_THREADS'))")
    base = {k: v for k, v in os.environ.items() if k not in VARS}
    for env, want in (({}, "None None None"), ({"OPENBLAS_NUM_THREADS": "1"}, "1 None None"),
                      ({"OMP_NUM_THREADS": "3"}, "None None 3")):
        p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                           timeout=120, cwd=ROOT, env=dict(base, **env))
        assert p.returncode == 0, p.stderr
        assert p.stdout.split() == want.split(), (env, p.stdout)
