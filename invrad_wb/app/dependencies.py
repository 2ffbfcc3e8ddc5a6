"""What the workbench needs from the Python environment, and the command that installs it.

FreeCAD 0.20's GUI clears ``PYTHONPATH`` at start-up (MainGui.cpp, Linux), so the packages
that ``make setup`` installed into the checkout's ``.venv`` are not found there as they are
under ``freecadcmd``. :func:`add_site_packages` appends that venv's site-packages (and the
folders in ``$INVRAD_SITE_PACKAGES``) at the END of ``sys.path``: what FreeCAD, the system
and other workbenches import stays what it was, and only packages found nowhere else come
from the venv. The workbench calls it in ``Initialize()``, when it is first activated.

:func:`problems` then names each missing piece with the one command that installs it:
``make setup`` in a checkout, else the ``pip`` command (or, for an OpenCL driver, the
Debian package). Nothing here imports FreeCAD at module level.

:func:`install` is the installer an architect uses (the first-activation dialog runs it,
and it runs headless: ``freecadcmd -c "from invrad_wb.app import dependencies;
dependencies.install()"``): every package of :func:`packages` that is missing or of a
version this FreeCAD cannot use goes with one pip run (:mod:`.pip_runner`) into FreeCAD's
own add-on package folder, :func:`target_dir`; one line per package says what happened.
"""
import importlib.metadata
import importlib.util
import os
import re
import shlex
import sys
import tempfile
from dataclasses import dataclass, field

from invrad_wb import constants as C
from invrad_wb.app import pip_runner

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
    pip into FreeCAD's add-on package folder (:func:`target_dir`) or the user's
    site-packages."""
    if is_checkout(root) and not pip:
        return f"cd {shlex.quote(root)} && make setup"
    python = "python%d.%d" % sys.version_info[:2]
    reqs = " ".join(shlex.quote(r) for r in requirements)
    target = target_dir()
    if target:
        # --upgrade: without it pip --target leaves a package already there (and says
        # it succeeded). dependencies.install() does this for every package at once.
        return f"{python} -m pip install --upgrade --target {shlex.quote(target)} {reqs}"
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


# --------------------------------------------------------------------------- installer
@dataclass(frozen=True)
class Package:
    """One Python package invrad uses at run time.

    name: the pip distribution (what the user reads); module: its import name;
    requirement: the pip requirement for this FreeCAD; needed: False where the workbench
    works without it (it says what is lost: ``use``).
    """
    name: str
    module: str
    requirement: str
    needed: bool
    use: str


def freecad_version():
    """(major, minor) of FreeCAD, or None outside FreeCAD."""
    try:
        import FreeCAD
        return int(FreeCAD.Version()[0]), int(FreeCAD.Version()[1])
    except Exception:
        return None


def ifcopenshell_requirement():
    """The 0.8 series for FreeCAD 1.0's NativeIFC (it uses what 0.9 removed), else >=0.8."""
    version = freecad_version()
    if version is not None and version < (1, 1) and _has_nativeifc():
        return IFCOPENSHELL_NATIVEIFC
    return IFCOPENSHELL


def packages():
    """Every package invrad needs at run time (requirements.txt less the test and build
    tools), with this FreeCAD's pins."""
    return [
        Package("numpy", "numpy", numpy_requirement(), True, "everything"),
        Package("scipy", "scipy", "scipy>=1.10", True, "designs and rooms"),
        Package("trimesh", "trimesh", REQUIRED["trimesh"], True, "meshes"),
        # trimesh reads a mesh whose text or STL header is not UTF-8 with it (not a
        # requirement of trimesh's own)
        Package("charset-normalizer", "charset_normalizer", "charset-normalizer>=3", False,
                "meshes whose text is not UTF-8 (STL, OBJ)"),
        Package("OpenImageIO", "OpenImageIO", REQUIRED["OpenImageIO"], True,
                "illuminance images"),
        Package("jinja2", "jinja2", "jinja2>=3.0", True, "every report"),
        Package("matplotlib", "matplotlib", "matplotlib>=3.5", True, "the reports' figures"),
        Package("threadpoolctl", "threadpoolctl", "threadpoolctl>=3.1", True,
                "rooms in parallel"),
        Package("tqdm", "tqdm", "tqdm>=4.60", True, "progress on the command line"),
        Package("photompy", "photompy", "photompy>=0.3.1", False, "IES luminaire files"),
        # the distribution is eulumdat-py, the module pyldt
        Package("eulumdat-py", "pyldt", "eulumdat-py>=1.0", False, "EULUMDAT luminaire files"),
        Package("pyopencl", "pyopencl", PYOPENCL, False,
                "speed: without it locating runs on numpy, much slower"),
        Package("ifcopenshell", "ifcopenshell", ifcopenshell_requirement(), False,
                "IFC files and NativeIFC"),
        Package("weasyprint", "weasyprint", "weasyprint>=57", False, "the reports' PDF"),
        Package("dask", "dask", "dask[distributed]>=2023.1", False,
                "rooms on a Dask cluster (--dask)"),
    ]


def target_dir():
    """FreeCAD's own folder for add-ons' Python packages, where the Addon Manager installs
    them and FreeCAD puts on sys.path at start-up (if the folder exists then):
    ``<user data>/AdditionalPythonPackages/pyXY`` on FreeCAD 1.x,
    ``<user data>/AdditionalPythonPackages`` on 0.x (its Addon Manager's worker and
    FreeCADInit use the folder itself). None outside FreeCAD."""
    version = freecad_version()
    if version is None:
        return None
    target = addon_target()
    return target if version >= (1, 0) else os.path.dirname(target)


def _numbers(version):
    """Leading release numbers of a version string: '0.9.0.post1' -> (0, 9, 0)."""
    out = []
    for part in str(version).split("."):
        m = re.match(r"\d+", part)
        if not m:
            break
        out.append(int(m.group()))
        if m.end() != len(part):
            break
    return tuple(out)


def satisfies(version, requirement):
    """True if ``version`` meets the requirement's >=, <, == bounds (an unknown version
    meets them: a package found without metadata is taken as it is)."""
    if not version:
        return True
    spec = re.sub(r"^[A-Za-z0-9_.\-]+(\[[^\]]*\])?", "", requirement).strip()
    have = _numbers(version)
    for clause in filter(None, (c.strip() for c in spec.split(","))):
        m = re.match(r"(>=|<=|==|<|>)\s*(.+)", clause)
        if not m:
            continue
        op, want = m.group(1), _numbers(m.group(2))
        n = max(len(have), len(want))
        a, b = have + (0,) * (n - len(have)), want + (0,) * (n - len(want))
        if not {">=": a >= b, "<=": a <= b, "==": a == b, "<": a < b, ">": a > b}[op]:
            return False
    return True


def _norm(name):
    return re.sub(r"[-_.]+", "-", name).lower()


def _dist_version(name, folder):
    """Version of distribution ``name`` installed in ``folder`` ('' if unknown, None if
    not there)."""
    try:
        for d in importlib.metadata.distributions(path=[folder]):
            if _norm(d.metadata.get("Name") or "") == _norm(name):
                return d.version or ""
    except Exception:
        return ""
    return None


def installed_version(pkg):
    """(found, version) of the package Python imports now: version from the metadata
    next to the module FreeCAD would import ('' when there is none)."""
    try:
        spec = importlib.util.find_spec(pkg.module)
    except (ImportError, ValueError):
        spec = None
    if spec is None:
        return False, None
    mod = sys.modules.get(pkg.module)
    if mod is not None and isinstance(getattr(mod, "__version__", None), str):
        return True, mod.__version__
    where = spec.origin if spec.origin not in (None, "namespace") else \
        next(iter(spec.submodule_search_locations or []), None)
    if not where:
        return True, ""
    folder = os.path.dirname(where)
    if os.path.basename(where).startswith("__init__."):
        folder = os.path.dirname(folder)
    version = _dist_version(pkg.name, folder)
    return True, version or ""


@dataclass
class Status:
    """A package as FreeCAD finds it now: state 'ok', 'missing', 'wrong' (a version this
    FreeCAD cannot use), 'no-device' (pyopencl without an OpenCL driver) or 'pending'
    (installed into the folder, used after a restart)."""
    package: Package
    state: str
    detail: str = ""

    @property
    def line(self):
        p = self.package
        what = {"missing": "missing", "wrong": f"version {self.detail} cannot be used"
                f" (needs {p.requirement})",
                "no-device": "no OpenCL driver (no OpenCL device)",
                "pending": f"installed ({self.detail}), used after FreeCAD restarts",
                "ok": f"ok {self.detail}".strip()}[self.state]
        # what it is for, so that an architect can tell what she must have from what
        # only adds a feature ("trimesh: missing" said neither)
        need = (f"; needed for {p.use}" if p.needed else f"; without it: no {p.use}"
                if p.name != "pyopencl" else f"; {p.use}")
        return f"{p.name}: {what}" + (need if self.state not in ("ok", "pending") else "")


def check(target=None):
    """What FreeCAD finds of every package of :func:`packages`, as a list of
    :class:`Status` (in that order). Packages already installed into ``target`` (default
    :func:`target_dir`) for the next start are 'pending', not missing."""
    target = target_dir() if target is None else target
    out = []
    for pkg in packages():
        found, version = installed_version(pkg)
        if found and satisfies(version, pkg.requirement):
            state = "ok"
            if pkg.name == "pyopencl" and _opencl_devices() == 0:
                state = "no-device"
        else:
            state = "wrong" if found else "missing"
        if state != "ok" and target and os.path.isdir(target):
            pending = _dist_version(pkg.name, target)
            if pending is not None and satisfies(pending, pkg.requirement) and (
                    state != "no-device" or _dist_version("pocl-binary-distribution",
                                                          target) is not None):
                state, version = "pending", pending
        out.append(Status(pkg, state, version or ""))
    return out


@dataclass
class InstallResult:
    """What :func:`install` did: per package name, 'installed', 'failed', 'ok' (nothing to
    do) or 'pending'; ``reasons`` for the failed; ``lines`` what it printed."""
    target: str = None
    python: str = None
    outcome: dict = field(default_factory=dict)
    reasons: dict = field(default_factory=dict)
    lines: list = field(default_factory=list)

    @property
    def installed(self):
        return [n for n, o in self.outcome.items() if o == "installed"]

    @property
    def failed(self):
        return [n for n, o in self.outcome.items() if o == "failed"]

    @property
    def restart_needed(self):
        return any(o in ("installed", "pending") for o in self.outcome.values())

    @property
    def ok(self):
        return not self.failed

    def __repr__(self):
        return (f"InstallResult(installed={self.installed}, failed={self.failed},"
                f" restart_needed={self.restart_needed})")


def _constraints(folder):
    """A pip constraints file that keeps the numpy FreeCAD already imports (its scipy,
    matplotlib and FreeCAD's own modules are built for that major version): the same
    minor series. None when FreeCAD has no numpy."""
    found, version = installed_version(Package("numpy", "numpy", "numpy", True, ""))
    nums = _numbers(version) if found else ()
    if len(nums) < 2:
        return None
    path = os.path.join(folder, "constraints.txt")
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(f"numpy>={nums[0]}.{nums[1]},<{nums[0]}.{nums[1] + 1}\n")
    return path


def install(target=None, python=None, say=print, progress=None):
    """Install every missing or unusable package into FreeCAD's add-on package folder.

    One pip run (``--upgrade --target``) for all that is missing; if it fails, one run per
    package, so that each failure is named with its reason. Packages that are fine are
    left alone (running it twice installs nothing the second time). Never raises.

    Parameters
    ----------
    target : folder (default :func:`target_dir`, FreeCAD's AdditionalPythonPackages).
    python : interpreter for pip (default: FreeCAD's Python version, found as the Addon
        Manager finds it, :func:`invrad_wb.app.pip_runner.find_python`).
    say : callable(str), one line at a time (default print).
    progress : callable(fraction, text) or None.

    Returns
    -------
    :class:`InstallResult`.
    """
    result = InstallResult()

    def tell(line):
        result.lines.append(line)
        try:
            say("invrad install: " + line)
        except Exception:
            pass

    def step(frac, text):
        if progress is not None:
            try:
                progress(frac, text)
            except Exception:
                pass

    try:
        _install(result, target, python, tell, step)
    except Exception as exc:        # never a traceback for the user: one line
        tell(f"stopped: {type(exc).__name__}: {exc}")
        for name, o in list(result.outcome.items()):
            if o == "installing":
                result.outcome[name] = "failed"
                result.reasons[name] = f"{type(exc).__name__}: {exc}"
    step(1.0, "done")
    return result


def _install(result, target, python, tell, step):
    target = target or target_dir() or _fallback_target()
    result.target = target
    step(0.0, "checking what is installed")
    todo = []
    for st in check(target):
        name = st.package.name
        if st.state in ("ok", "pending"):
            result.outcome[name] = st.state
        else:
            todo.append(st)
    if not todo:
        pending = [n for n, o in result.outcome.items() if o == "pending"]
        tell("every package is installed"
             + (f"; restart FreeCAD to use {', '.join(pending)}" if pending else ""))
        return
    tell(f"{len(todo)} package(s) to install into {target}:")
    for st in todo:
        tell("  " + st.line)
    if python is None:
        try:
            import FreeCAD
            pref = FreeCAD.ParamGet(pip_runner.PREF_GROUP).GetString(pip_runner.PREF_KEY, "")
            home = FreeCAD.getHomePath()
        except Exception:
            pref, home = None, None
        python, why = pip_runner.find_python(pref, home)
        if python is None:
            for st in todo:
                _fail(result, tell, st.package, why)
            return
    result.python = python
    os.makedirs(target, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="invrad-install-") as tmp:
        constraints = _constraints(tmp)
        reqs = [st.package.requirement for st in todo]
        for st in todo:
            result.outcome[st.package.name] = "installing"
        seen = [0]

        def on_line(line):
            if line.startswith(("Collecting", "Installing collected", "Successfully")):
                seen[0] += 1
                step(min(0.9, 0.05 + 0.85 * seen[0] / (3.0 * len(reqs) + 3)), line)

        step(0.05, f"pip install {' '.join(reqs)}")
        rc, out = pip_runner.run(pip_runner.pip_command(python, target, reqs, constraints),
                                 on_line)
        if rc == 0:
            for st in todo:
                _settle(result, tell, st.package, target, out)
        elif pip_runner.network_error(out):
            # offline, a proxy or a certificate: each package would fail alike, slowly
            for st in todo:
                _fail(result, tell, st.package, pip_runner.network_error(out))
        else:
            tell("pip could not install them together (" + pip_runner.error_line(out)
                 + "); one by one:")
            for i, st in enumerate(todo):
                step(0.5 + 0.4 * i / len(todo), f"pip install {st.package.requirement}")
                rc, out = pip_runner.run(pip_runner.pip_command(
                    python, target, [st.package.requirement], constraints))
                if rc == 0:
                    _settle(result, tell, st.package, target, out)
                else:
                    _fail(result, tell, st.package, pip_runner.error_line(out))
    failed = result.failed
    if result.installed:
        tell("restart FreeCAD to use the installed packages")
    if failed:
        tell(f"{len(failed)} package(s) could not be installed: {', '.join(failed)}")


def _settle(result, tell, pkg, target, out):
    """After a pip run that succeeded: the package's metadata must be in ``target``."""
    version = _dist_version(pkg.name, target)
    if version is None or not satisfies(version, pkg.requirement):
        _fail(result, tell, pkg, f"pip reported success but {target} holds"
              f" {version or 'no'} {pkg.name}")
        return
    result.outcome[pkg.name] = "installed"
    tell(f"{pkg.name} {version}: installed")


def _fail(result, tell, pkg, reason):
    result.outcome[pkg.name] = "failed"
    result.reasons[pkg.name] = reason
    tell(f"{pkg.name}: FAILED: {reason}"
         + ("" if pkg.needed else f" (the workbench works without it: no {pkg.use})"
            if pkg.name != "pyopencl" else " (the workbench runs on numpy, much slower)"))


def _fallback_target():
    """Outside FreeCAD: the user's site-packages (where a plain Python finds it)."""
    import site
    return site.getusersitepackages()
