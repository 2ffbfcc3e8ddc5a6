"""The radiosity's LU without scipy.linalg's import: scipy's numbers bit for bit, and
scipy.linalg still imports (and uses the same LAPACK module) afterwards."""
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from repo_paths import ROOT

pytest.importorskip("scipy.linalg")


def _run(code):
    p = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], cwd=ROOT,
                       capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, p.stderr[-2000:]
    return p.stdout


def test_twins_give_scipys_bits_and_scipy_linalg_imports_after_them():
    """In a fresh process: the twins load scipy's LAPACK module alone (no scipy.linalg,
    no scipy.sparse), their factors and solves equal scipy.linalg's bit for bit (a
    diagonally dominant system like the radiosity's, one and several right-hand sides,
    overwrite on), and scipy.linalg imported afterwards shares that module."""
    out = _run("""
        import sys
        import numpy as np
        from invrad_wb.core.accel.lapack import lu_functions
        lu_factor, lu_solve = lu_functions()
        loaded = sorted(m for m in sys.modules if m.startswith("scipy"))
        rng = np.random.default_rng(3)
        n = 300
        F = rng.random((n, n)) / n
        a = np.eye(n) - 0.7 * F
        b1, b2 = rng.random(n), rng.random((n, 4))
        mine = lu_factor(a.copy(), overwrite_a=True, check_finite=False)
        x1, x2 = lu_solve(mine, b1, check_finite=False), lu_solve(mine, b2)
        import scipy.linalg as sl
        ref = sl.lu_factor(a.copy(), overwrite_a=True, check_finite=False)
        y1, y2 = sl.lu_solve(ref, b1, check_finite=False), sl.lu_solve(ref, b2)
        same = (np.array_equal(mine[0], ref[0]) and np.array_equal(mine[1], ref[1])
                and np.array_equal(x1, y1) and np.array_equal(x2, y2))
        print(loaded, same, sys.modules["scipy.linalg._flapack"] is sl.lapack._flapack,
              lu_factor is not sl.lu_factor)
        """)
    assert out.split() == ["['scipy.linalg._flapack']", "True", "True", "True"], out


def test_with_scipy_linalg_imported_its_own_functions_are_used():
    import scipy.linalg as sl
    from invrad_wb.core.accel.lapack import lu_functions
    assert lu_functions() == (sl.lu_factor, sl.lu_solve)


def test_twins_solve_and_report_like_scipy():
    """A float32 system goes to scipy's own function; a wrong shape is an error."""
    from invrad_wb.core.accel import lapack
    flapack = lapack._flapack()
    if flapack is None:
        pytest.skip("scipy's LAPACK module is not where it is looked for")
    lu_factor, lu_solve = lapack._twins(flapack)
    a = np.array([[4.0, 1.0], [2.0, 3.0]])
    lu = lu_factor(a)
    np.testing.assert_allclose(a @ lu_solve(lu, np.array([1.0, 2.0])), [1.0, 2.0])
    lu32 = lu_factor(a.astype(np.float32))
    assert lu32[0].dtype == np.float32
    with pytest.raises(ValueError):
        lu_solve(lu, np.ones(3))


def test_a_radiosity_solve_does_not_import_scipy_linalg():
    """The direct solve's LU is scipy's LAPACK module alone: scipy.linalg and the
    scipy.sparse it brings (0.03-0.04 CPU s of a command line's run) stay unloaded."""
    out = _run("""
        import sys
        import numpy as np
        from invrad_wb.core.forward.radiosity import RadiosityModel
        from invrad_wb.core.synthetic import generate
        scene = generate.with_reflectances(generate.box_room(size=(3.0, 2.5, 2.5), cell=0.5))
        model = RadiosityModel(scene, backend="numpy", patch_size=0.5)
        b = model.solve(np.full(model.n_patches, 100.0))
        print(model.last_iterations == 0 and bool(np.all(b > 0)),
              sorted(m for m in ("scipy.linalg", "scipy.sparse") if m in sys.modules))
        """)
    assert out.split() == ["True", "[]"], out
