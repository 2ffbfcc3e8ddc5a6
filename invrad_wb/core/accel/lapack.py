"""scipy's LU factors and solves (``lu_factor``, ``lu_solve``) without importing
``scipy.linalg``: the radiosity's direct solve needs two LAPACK routines, and the package
brings ``scipy.sparse``, ``scipy.sparse.linalg`` and ``scipy.sparse.csgraph`` with it.

Measured on the 2-core machine (numpy loaded, one BLAS thread): ``from scipy.linalg
import lu_factor, lu_solve`` 0.034-0.038 CPU s, loading its LAPACK module alone
(``scipy/linalg/_flapack``) 0.004-0.005 s; in the office example's command line that
import was 0.065 of 0.18 s of imports (wall, the least of six runs).

The functions below call the same routines of the same module (``dgetrf``, ``dgetrs``)
as scipy's own functions do for float64 arrays, with the same arguments: the same numbers
bit for bit. Anything else (other dtypes, a scipy whose module is not where it is looked
for) goes to ``scipy.linalg`` itself; where ``scipy.linalg`` is imported before the first
call, its own functions are used (a caller keeps what it got for the process's life).
The first load is done under a lock (two threads' first solves load it once).
"""
import importlib.machinery
import importlib.util
import os
import sys
import threading
import warnings

import numpy as np

_FLAPACK = "scipy.linalg._flapack"
_LOCK = threading.Lock()


def _flapack():
    """:func:`_load` under the module's lock."""
    with _LOCK:
        return _load()


def _load():
    """scipy's LAPACK module, loaded on its own (not its package), or None where it is
    not found. Registered under its own name in ``sys.modules`` (Python does so for an
    extension module of the classic kind): a later ``import scipy.linalg`` uses this
    module instead of loading it twice."""
    if _FLAPACK in sys.modules:
        return sys.modules[_FLAPACK]
    try:
        spec = importlib.util.find_spec("scipy")        # where scipy is; not imported
    except (ImportError, ValueError):
        return None
    for folder in (spec.submodule_search_locations or []) if spec else []:
        for suffix in importlib.machinery.EXTENSION_SUFFIXES:
            path = os.path.join(folder, "linalg", "_flapack" + suffix)
            if not os.path.isfile(path):
                continue
            try:
                loader = importlib.machinery.ExtensionFileLoader(_FLAPACK, path)
                mod = importlib.util.module_from_spec(
                    importlib.util.spec_from_file_location(_FLAPACK, path, loader=loader))
                loader.exec_module(mod)
            except Exception:        # noqa: BLE001 -- any failure: scipy.linalg itself
                sys.modules.pop(_FLAPACK, None)
                return None
            sys.modules.setdefault(_FLAPACK, mod)
            return mod
    return None


def lu_functions():
    """``(lu_factor, lu_solve)`` with scipy's signatures and numbers: scipy.linalg's own
    where it is imported already, else these twins calling its LAPACK module (None:
    scipy.linalg's, imported now)."""
    if "scipy.linalg" not in sys.modules:
        lapack = _flapack()
        if lapack is not None and hasattr(lapack, "dgetrf") and hasattr(lapack, "dgetrs"):
            return _twins(lapack)
    from scipy.linalg import lu_factor, lu_solve
    return lu_factor, lu_solve


def _datacopied(arr, original):
    """scipy's own test: ``arr = asarray(original)`` shares no data with ``original``
    (then scipy lets LAPACK overwrite it)."""
    if arr is original:
        return False
    if not isinstance(original, np.ndarray) and hasattr(original, "__array__"):
        return False
    return arr.base is None


def _twins(lapack):
    def scipy_lu():
        from scipy.linalg import lu_factor, lu_solve
        return lu_factor, lu_solve

    def lu_factor(a, overwrite_a=False, check_finite=True):
        """``scipy.linalg.lu_factor``: its steps for a float64 array (other dtypes: scipy's
        own function)."""
        a1 = np.asarray_chkfinite(a) if check_finite else np.asarray(a)
        if a1.dtype != np.float64:
            return scipy_lu()[0](a, overwrite_a=overwrite_a, check_finite=check_finite)
        overwrite_a = overwrite_a or _datacopied(a1, a)
        lu, piv, info = lapack.dgetrf(a1, overwrite_a=overwrite_a)
        if info < 0:
            raise ValueError("illegal value in %dth argument of internal getrf (lu_factor)"
                             % -info)
        if info > 0:
            warnings.warn("Diagonal number %d is exactly zero. Singular matrix." % info,
                          RuntimeWarning, stacklevel=2)
        return lu, piv

    def lu_solve(lu_and_piv, b, trans=0, overwrite_b=False, check_finite=True):
        """``scipy.linalg.lu_solve``: its steps for float64 factors and right-hand side
        (other dtypes: scipy's own function)."""
        lu, piv = lu_and_piv
        b1 = np.asarray_chkfinite(b) if check_finite else np.asarray(b)
        if lu.dtype != np.float64 or b1.dtype != np.float64:
            return scipy_lu()[1](lu_and_piv, b, trans=trans, overwrite_b=overwrite_b,
                                 check_finite=check_finite)
        overwrite_b = overwrite_b or _datacopied(b1, b)
        if lu.shape[0] != b1.shape[0]:
            raise ValueError(f"Shapes of lu {lu.shape} and b {b1.shape} are incompatible")
        x, info = lapack.dgetrs(lu, piv, b1, trans=trans, overwrite_b=overwrite_b)
        if info == 0:
            return x
        raise ValueError("illegal value in %dth argument of internal gesv|posv" % -info)

    return lu_factor, lu_solve
