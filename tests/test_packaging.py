"""Packaging: one version, a plain (non-editable) install that works from anywhere, and the
workbench's dependency set-up (sys.path appended, never reordered; install commands)."""
import glob
import json
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import tomllib
import xml.etree.ElementTree as ET
import zipfile

import numpy as np
import pytest

import invrad_wb
from invrad_wb.app import dependencies
from repo_paths import ROOT

#: What a wheel is built from (the rest of the checkout is not needed for it).
SOURCES = ("pyproject.toml", "README.md", "invrad_wb", "kernels", "tables", "resources")


# --------------------------------------------------------------------------- version
def test_version_lives_in_the_package_only():
    with open(os.path.join(ROOT, "pyproject.toml"), "rb") as fh:
        project = tomllib.load(fh)
    assert "version" not in project["project"]
    assert "version" in project["project"]["dynamic"]
    assert project["tool"]["setuptools"]["dynamic"]["version"] == {
        "attr": "invrad_wb.__version__"}
    ns = {"p": "https://wiki.freecad.org/Package_Metadata"}
    xml_version = ET.parse(os.path.join(ROOT, "package.xml")).getroot().find("p:version", ns)
    assert xml_version is not None and xml_version.text.strip() == invrad_wb.__version__


# --------------------------------------------------------------------------- pip install .
def _run(cmd, **kwargs):
    p = subprocess.run(cmd, capture_output=True, text=True, **kwargs)
    assert p.returncode == 0, f"{cmd}\n{p.stdout}\n{p.stderr}"
    return p


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """A wheel built from the checkout's sources, installed into a fresh venv that sees the
    test interpreter's packages (numpy, pyopencl ...) through a .pth file, not the checkout.
    No network: no build isolation, no index."""
    tmp = tmp_path_factory.mktemp("install")
    src = tmp / "src"           # a copy: the build writes build/ and *.egg-info next to it
    src.mkdir()
    for name in SOURCES:
        path = os.path.join(ROOT, name)
        if os.path.isdir(path):
            shutil.copytree(path, src / name,
                            ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
        else:
            shutil.copy2(path, src / name)
    wheels = tmp / "wheels"
    _run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "--no-build-isolation",
          "--no-index", "-w", str(wheels), str(src)], cwd=tmp)
    (wheel,) = glob.glob(str(wheels / "invrad-*.whl"))
    venv = tmp / "venv"
    _run([sys.executable, "-m", "venv", "--without-pip", "--system-site-packages", str(venv)])
    py = str(venv / "bin" / "python")
    site = _run([py, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"]
                ).stdout.strip()
    # the dependencies of the test interpreter; a .pth line adds the folder only (the
    # editable-install finder's own .pth file there is not run)
    with open(os.path.join(site, "invrad-test-deps.pth"), "w") as fh:
        fh.write(sysconfig.get_paths()["purelib"] + "\n")
    _run([sys.executable, "-m", "pip", "--python", py, "install", "-q", "--no-deps",
          "--no-index", wheel])
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    return {"venv": venv, "python": py, "site": site, "wheel": wheel, "env": env, "tmp": tmp}


def test_the_wheel_ships_kernels_tables_and_resources(installed):
    names = set(zipfile.ZipFile(installed["wheel"]).namelist())
    for folder in ("kernels", "tables", "resources"):
        for path in glob.glob(os.path.join(ROOT, folder, "**", "*"), recursive=True):
            rel = os.path.relpath(path, ROOT)
            if os.path.isfile(path) and "__pycache__" not in rel:
                assert f"invrad_wb/{rel}" in names, rel


def test_installed_package_is_imported_not_the_checkout(installed, tmp_path):
    code = ("import json, os, sys, invrad_wb, invrad_wb.constants as C;"
            "print(json.dumps({'file': invrad_wb.__file__, 'version': invrad_wb.__version__,"
            " 'path': [os.path.realpath(p) for p in sys.path],"
            " 'kernels': C.KERNELS_DIR, 'tables': C.TABLES_DIR,"
            " 'resources': C.RESOURCES_DIR}))")
    got = json.loads(_run([installed["python"], "-c", code], cwd=tmp_path,
                          env=installed["env"]).stdout)
    real = os.path.realpath
    package = real(os.path.join(installed["site"], "invrad_wb"))
    assert real(os.path.dirname(got["file"])) == package
    assert got["version"] == invrad_wb.__version__
    # of the checkout, only its venv's site-packages (the dependencies) is on the path
    venv = real(os.path.join(ROOT, ".venv"))
    inside = [p for p in got["path"] if (p + os.sep).startswith(real(ROOT) + os.sep)]
    assert all(p.startswith(venv + os.sep) for p in inside), inside
    for key in ("kernels", "tables", "resources"):
        assert real(got[key]) == os.path.join(package, key)
    assert glob.glob(os.path.join(got["kernels"], "*.cl"))
    assert glob.glob(os.path.join(got["tables"], "voting_table.npz"))


def test_installed_cli_locates_from_another_directory(installed, tmp_path):
    exe = str(installed["venv"] / "bin" / "invrad")
    out = tmp_path / "OUT" / "result.json"
    p = _run([exe, "locate", os.path.join(ROOT, "examples", "office.ply"), "--flux", "3000",
              "-o", str(out)], cwd=tmp_path, env=installed["env"])
    with open(out) as fh:
        found = [l["position"] for l in json.load(fh)["luminaires"]]
    with open(os.path.join(ROOT, "examples", "office_true.json")) as fh:
        true = json.load(fh)
    true = [l["position"] for l in (true["luminaires"] if isinstance(true, dict) else true)]
    assert len(found) == len(true), p.stdout
    for t in true:   # every true luminaire found within 5 cm
        assert min(np.linalg.norm(np.subtract(f, t)) for f in found) < 0.05, (t, found)


# --------------------------------------------------------------------------- workbench deps
def test_site_packages_are_appended_never_put_first(tmp_path):
    venv_site = tmp_path / ".venv" / "lib" / ("python%d.%d" % sys.version_info[:2]) / \
        "site-packages"
    venv_site.mkdir(parents=True)
    extra = tmp_path / "extra"
    extra.mkdir()
    path = ["/usr/lib/freecad/lib", "/usr/lib/python3/dist-packages", str(extra)]
    before = list(path)
    env = {dependencies.ENV_SITE_PACKAGES: os.pathsep.join([str(extra), "/nonexistent/x"])}
    added = dependencies.add_site_packages(root=str(tmp_path), environ=env, path=path)
    assert added == [str(venv_site)]
    assert path == before + [str(venv_site)]          # nothing reordered, nothing missing
    assert dependencies.add_site_packages(root=str(tmp_path), environ=env, path=path) == []


def test_missing_dependencies_name_the_command_that_installs_them(monkeypatch, tmp_path):
    # the test environment has every required package (else the suite could not run)
    assert [p for p in dependencies.problems() if p[0] == "error"] == []
    monkeypatch.setitem(sys.modules, "pyopencl", None)    # import fails
    monkeypatch.setitem(sys.modules, "trimesh", None)
    (level_t, text_t), (level_p, text_p) = dependencies.problems(ROOT)
    assert level_t == "error" and "trimesh" in text_t
    assert level_p == "warning" and "pyopencl" in text_p and "numpy backend" in text_p
    assert text_t.endswith(f"cd {ROOT} && make setup")
    # an installed copy (no Makefile): the pip command
    (_, text_t), (_, text_p) = dependencies.problems(str(tmp_path))
    assert "-m pip install --user 'trimesh>=4.0'" in text_t
    assert "-m pip install --user 'pyopencl[pocl]>=2024.1'" in text_p


def test_missing_opencl_driver_is_a_warning_with_its_install_command(tmp_path):
    code = ("from invrad_wb.app import dependencies as d; import json, sys;"
            "print(json.dumps([d.problems(), d.problems(sys.argv[1])]))")
    env = dict(os.environ, OCL_ICD_VENDORS=str(tmp_path), PYTHONPATH=ROOT)  # no ICD there
    in_checkout, installed_copy = json.loads(_run([sys.executable, "-c", code, str(tmp_path)],
                                                  env=env, cwd=tmp_path).stdout)
    assert [p[0] for p in in_checkout] == ["warning"]
    assert "no OpenCL driver" in in_checkout[0][1]
    assert in_checkout[0][1].endswith("make setup")
    assert installed_copy[0][1].endswith(dependencies.OPENCL_DRIVER_APT)


# --------------------------------------------------------------------------- package.xml
#: FreeCAD's Addon Manager pip-installs only names on its allow-list; these are on the lists
#: of FreeCAD 0.20 and 1.0 (src/Mod/AddonManager/ALLOWED_PYTHON_PACKAGES.txt)
ADDON_MANAGER_ALLOWED = {"numpy", "scipy", "matplotlib", "pillow", "lxml", "requests",
                         "pandas", "PyYAML"}
#: FreeCAD's internal workbenches as the Addon Manager names them (its Addon.py:
#: INTERNAL_WORKBENCHES, lower-case keys on 0.20 and 1.0)
ADDON_MANAGER_INTERNAL = {"arch", "draft", "fem", "mesh", "openscad", "part", "partdesign",
                          "plot", "points", "robot", "sketcher", "spreadsheet", "techdraw"}
#: requirements.txt's entries that are for tests and builds only
NOT_AT_RUN_TIME = {"pytest", "setuptools", "pyradiance"}


def _package_xml_depends():
    ns = {"p": "https://wiki.freecad.org/Package_Metadata"}
    root = ET.parse(os.path.join(ROOT, "package.xml")).getroot()
    return [(d.get("type"), d.text.strip()) for d in root.iter(f"{{{ns['p']}}}depend")]


def _allowed_here():
    """The allow-list of the FreeCAD installed on this machine, if there is one."""
    for path in ("/usr/share/freecad/Mod/AddonManager/ALLOWED_PYTHON_PACKAGES.txt",
                 "/usr/lib/freecad/Mod/AddonManager/ALLOWED_PYTHON_PACKAGES.txt"):
        if os.path.isfile(path):
            with open(path, encoding="utf-8") as fh:
                return {l.strip() for l in fh if l.strip() and not l.startswith("#")}
    return None


def test_package_xml_declares_only_what_the_addon_manager_installs_without_a_warning():
    deps = _package_xml_depends()
    python = [name for kind, name in deps if kind == "python"]
    assert {"numpy", "scipy", "matplotlib"} <= set(python)
    allowed = _allowed_here()
    by_module = {p.module: p for p in dependencies.packages()}
    for name in python:
        # on the allow-list (it refuses and warns otherwise) ...
        assert name in ADDON_MANAGER_ALLOWED, name
        if allowed is not None:
            assert name in allowed, name
        # ... and importable by that very name (its check is __import__(name))
        assert name in by_module, name
    # an internal workbench by the name the Addon Manager recognises (no "Unrecognized
    # internal workbench" warning)
    internal = [name for kind, name in deps if kind == "internal"]
    assert internal == ["spreadsheet"]
    assert all(name in ADDON_MANAGER_INTERNAL for name in internal)
    assert {kind for kind, _ in deps} <= {"python", "internal"}


def test_the_installer_covers_every_run_time_requirement():
    names = set()
    with open(os.path.join(ROOT, "requirements.txt"), encoding="utf-8") as fh:
        for line in fh:
            line = line.split("#")[0].strip()
            if line:
                names.add(re.split(r"[\[<>=!~ ]", line)[0].lower())
    installer = {p.name.lower() for p in dependencies.packages()}
    assert names - NOT_AT_RUN_TIME == installer
    reqs = {p.name: p.requirement for p in dependencies.packages()}
    assert reqs["numpy"] == "numpy>=1.24,<2"        # no FreeCAD here: the 0.20 pin
    assert reqs["pyopencl"].startswith("pyopencl[pocl]")      # OpenCL without a system driver
    assert reqs["dask"].startswith("dask[distributed]")
