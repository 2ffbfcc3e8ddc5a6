"""What the workbench needs from the Python environment, and the command that installs it.

FreeCAD 0.20's GUI clears ``PYTHONPATH`` at start-up (MainGui.cpp, Linux), so the packages
that ``make setup`` installed into the checkout's ``.venv`` are not found there as they are
under ``freecadcmd``. :func:`add_site_packages` appends that venv's site-packages (and the
folders in ``$INVRAD_SITE_PACKAGES``) at the END of ``sys.path``: what FreeCAD, the system
and other workbenches import stays what it was, and only packages found nowhere else come
from the venv. The workbench calls it in ``Initialize()``, when it is first activated.

:func:`problems` then names each missing piece with the one command that installs it:
``make setup`` in a checkout, else the ``pip`` command (or, for an OpenCL driver, the
Debian package). Nothing here imports FreeCAD.
"""
import importlib.util
import os
import shlex
import sys

from invrad_wb import constants as C

#: Required packages: import name -> pip requirement (as in pyproject.toml); numpy's
#: depends on FreeCAD (:func:`numpy_requirement`).
REQUIRED = {"numpy": "numpy>=1.24,<2", "trimesh": "trimesh>=4.0",
            "OpenImageIO": "OpenImageIO>=2.5"}
#: IFC rooms and fixtures; FreeCAD 1.0.0's NativeIFC needs the 0.8 series (it uses
#: entity_instance.wrapped_data, which 0.9 removed)
IFCOPENSHELL = "ifcopenshell>=0.8"
IFCOPENSHELL_NATIVEIFC = "ifcopenshell>=0.8.1,<0.9"
#: pyopencl with PoCL (an OpenCL driver for the CPU) from PyPI.
PYOPENCL = "pyopencl[pocl]>=2024.1"
#: Debian's OpenCL driver for the CPU (what `make setup` installs).
OPENCL_DRIVER_APT = "sudo apt-get install pocl-opencl-icd"
#: Environment variable: extra folders (os.pathsep-separated) to append to sys.path.
ENV_SITE_PACKAGES = "INVRAD_SITE_PACKAGES"


def venv_site_packages(root=C.ROOT):
    """site-packages of the checkout's ``.venv`` for this Python version (may not exist)."""
    return os.path.join(root, ".venv", "lib", "python%d.%d" % sys.version_info[:2],
                        "site-packages")


def add_site_packages(root=C.ROOT, environ=None, path=None):
    """Append ``$INVRAD_SITE_PACKAGES`` and the checkout's venv to ``sys.path``.

    Only existing folders not yet on the path are added, after every entry already there
    (no ``.pth`` file in them is run). Cheap: nothing is imported.

    Returns
    -------
    list of str, the folders appended.
    """
    environ = os.environ if environ is None else environ
    path = sys.path if path is None else path
    wanted = [p for p in environ.get(ENV_SITE_PACKAGES, "").split(os.pathsep) if p]
    wanted.append(venv_site_packages(root))
    added = []
    for p in wanted:
        p = os.path.abspath(p)
        if os.path.isdir(p) and p not in path:
            path.append(p)
            added.append(p)
    return added


def is_checkout(root=C.ROOT):
    """True when ``root`` is a source checkout with ``make setup`` (not an installed copy)."""
    return (os.path.isfile(os.path.join(root, "Makefile"))
            and os.path.isfile(os.path.join(root, ".ci", "setup.sh")))


def freecad_major():
    """FreeCAD's major version (0 for 0.x), or None outside FreeCAD."""
    try:
        import FreeCAD
        return int(FreeCAD.Version()[0])
    except Exception:
        return None


def numpy_requirement():
    """numpy<2 for FreeCAD 0.x (Debian 12's scipy/matplotlib are numpy 1 builds); FreeCAD
    1.x brings numpy 2."""
    major = freecad_major()
    return "numpy>=1.24" if major is not None and major >= 1 else "numpy>=1.24,<2"


def addon_target():
    """Where FreeCAD's Addon Manager installs add-ons' Python packages (on FreeCAD's
    sys.path): ``<user data>/AdditionalPythonPackages/pyXY``; None outside FreeCAD."""
    try:
        import FreeCAD
        base = FreeCAD.getUserAppDataDir()
    except Exception:
        return None
    return os.path.join(base, "AdditionalPythonPackages", "py%d%d" % sys.version_info[:2])


def install_command(requirements, root=C.ROOT, pip=False):
    """The one command that installs ``requirements`` (list of pip requirement strings):
    ``make setup`` in a checkout (unless ``pip``: what it installs would not do), else
    pip into the Addon Manager's folder (in FreeCAD) or the user's site-packages."""
    if is_checkout(root) and not pip:
        return f"cd {shlex.quote(root)} && make setup"
    python = "python%d.%d" % sys.version_info[:2]
    reqs = " ".join(shlex.quote(r) for r in requirements)
    target = addon_target()
    if target:
        return f"{python} -m pip install --target {shlex.quote(target)} {reqs}"
    return f"{python} -m pip install --user {reqs}"


def _importable(name):
    """True if ``import name`` works (ImportError, or an OSError of a broken library: no)."""
    try:
        __import__(name)
        return True
    except Exception:
        return False


def _findable(name):
    """True if ``name`` is installed (found without importing it)."""
    try:
        return importlib.util.find_spec(name) is not None
    except (ImportError, ValueError):
        return False


def _opencl_devices():
    """Number of OpenCL devices pyopencl sees (0 without a driver or with a broken one)."""
    try:
        import pyopencl as cl
        return sum(len(p.get_devices()) for p in cl.get_platforms())
    except Exception:
        return 0


def problems(root=C.ROOT):
    """What is missing for the workbench, each as ``(level, text)``.

    ``level`` is 'error' (a required package: the workbench cannot work) or 'warning'
    (no pyopencl or no OpenCL driver: it works on the numpy backend, much slower). Each
    text names the one command that installs what is missing.
    """
    out = []
    # numpy is imported (everything needs it at once); the others only looked up (cheap)
    missing = [name for name in REQUIRED
               if not (_importable(name) if name == "numpy" else _findable(name))]
    if missing:
        reqs = [numpy_requirement() if n == "numpy" else REQUIRED[n] for n in missing]
        out.append(("error", f"missing Python package(s): {', '.join(missing)}. Install"
                             " with: " + install_command(reqs, root)))
    if not _importable("pyopencl"):
        out.append(("warning", "pyopencl cannot be imported: locating runs on the numpy"
                               " backend, much slower. Install it with:"
                               f" {install_command([PYOPENCL], root)}"))
    elif _opencl_devices() == 0:
        cmd = install_command([], root) if is_checkout(root) else OPENCL_DRIVER_APT
        out.append(("warning", "no OpenCL driver (no OpenCL device found): locating runs"
                               " on the numpy backend, much slower. Install one (PoCL, for"
                               f" the CPU) with: {cmd}"))
    out.extend(_ifc_problems(root))
    return out


def _ifc_problems(root):
    """ifcopenshell missing, or too new for this FreeCAD's NativeIFC (warnings: the rest
    of the workbench works)."""
    if not _findable("ifcopenshell"):
        return [("warning", "ifcopenshell is not installed: IFC files (rooms from IfcSpace,"
                            " light fixtures, NativeIFC) cannot be read. Install it with: "
                 + install_command([IFCOPENSHELL_NATIVEIFC if _has_nativeifc()
                                    else IFCOPENSHELL], root))]
    if _has_nativeifc():
        from invrad_wb.app import nativeifc
        try:
            nativeifc.check_available()
        except Exception as exc:
            if "ifcopenshell 0.8" in str(exc):
                return [("warning", "NativeIFC documents cannot be used: this FreeCAD's"
                                    " NativeIFC needs ifcopenshell 0.8 (0.9 removed what it"
                                    " uses). Install it with: "
                         + install_command([IFCOPENSHELL_NATIVEIFC], root, pip=True))]
    return []


def _has_nativeifc():
    return _findable("nativeifc")
