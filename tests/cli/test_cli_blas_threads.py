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
    import invrad_wb.cli as cli
    for k in VARS:
        monkeypatch.delenv(k, raising=False)
    cli._one_blas_thread_at_start()
    assert not any(k in os.environ for k in VARS)
