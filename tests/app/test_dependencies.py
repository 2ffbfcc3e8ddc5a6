"""invrad's own installer (invrad_wb.app.dependencies.install) without a network: pip is a
stand-in script that writes the packages' metadata into the target folder (or fails for
one package, as pip does for a name the index does not have). What is checked: only the
missing packages go to pip, with --upgrade --target; a failure is named with pip's reason,
the others still installed; a second run installs nothing; nothing raises. The real pip
run against the index is tests/freecad/test_install_fc.py."""
import os
import sys

import pytest

from invrad_wb.app import dependencies as deps
from invrad_wb.app import pip_runner

FAKE_PIP = r'''#!{python}
import os, sys
log = os.environ["FAKE_PIP_LOG"]
if sys.argv[1] == "-c":
    exec(sys.argv[2])
    sys.exit(0)
with open(log, "a") as fh:
    fh.write(" ".join(sys.argv[1:]) + "\n")
args = sys.argv[1:]
assert args[:3] == ["-m", "pip", "install"], args
target = args[args.index("--target") + 1]
reqs, skip = [], False
for a in args[3:]:
    if skip:
        skip = False
    elif a in ("--target", "--constraint", "--progress-bar"):
        skip = True
    elif not a.startswith("-"):
        reqs.append(a)
names = [r.split("[")[0].split(">")[0].split("<")[0].split("=")[0] for r in reqs]
if os.environ.get("FAKE_PIP_OFFLINE"):
    print("WARNING: Retrying (Retry(total=4)) after connection broken by 'NewConnection"
          "Error('<HTTPSConnection>: Failed to establish a new connection: [Errno 101]"
          " Network is unreachable')': /simple/%s/" % names[0])
    print("ERROR: Could not find a version that satisfies the requirement %s" % reqs[0])
    sys.exit(1)
if "badpkg" in names:
    print("ERROR: Could not find a version that satisfies the requirement badpkg")
    print("ERROR: No matching distribution found for badpkg")
    sys.exit(1)
for n in names:
    d = os.path.join(target, n.replace("-", "_") + "-2.0.dist-info")
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, "METADATA"), "w") as fh:
        fh.write("Metadata-Version: 2.1\nName: %s\nVersion: 2.0\n" % n)
print("Successfully installed " + " ".join(names))
'''


@pytest.fixture
def fake(tmp_path, monkeypatch):
    exe = tmp_path / "python-with-pip"
    exe.write_text(FAKE_PIP.format(python=sys.executable))
    exe.chmod(0o755)
    log = tmp_path / "pip.log"
    monkeypatch.setenv("FAKE_PIP_LOG", str(log))
    target = tmp_path / "AdditionalPythonPackages"
    pkgs = [deps.Package("numpy", "numpy", "numpy>=1.0", True, "everything"),
            deps.Package("good-one", "invrad_test_good_one", "good-one>=1.5", True, "x"),
            deps.Package("other", "invrad_test_other", "other[extra]>=1", False, "y")]
    monkeypatch.setattr(deps, "packages", lambda: list(pkgs))
    return {"python": str(exe), "log": log, "target": str(target), "pkgs": pkgs}


def _calls(log):
    return log.read_text().splitlines() if log.exists() else []


def test_missing_packages_are_installed_with_upgrade_into_the_target(fake):
    lines = []
    r = deps.install(target=fake["target"], python=fake["python"], say=lines.append)
    assert r.outcome == {"numpy": "ok", "good-one": "installed", "other": "installed"}
    assert r.ok and r.restart_needed and r.failed == []
    (call,) = _calls(fake["log"])                # one pip run for all that is missing
    assert "--upgrade" in call.split() and f"--target {fake['target']}" in call
    assert call.endswith("good-one>=1.5 other[extra]>=1")
    assert "numpy" not in call.split()[-2:]      # what FreeCAD has stays alone
    assert "invrad install: good-one 2.0: installed" in lines
    assert any("restart FreeCAD" in l for l in lines)
    # the same session again: installed for the next start, nothing to do
    lines.clear()
    r2 = deps.install(target=fake["target"], python=fake["python"], say=lines.append)
    assert len(_calls(fake["log"])) == 1
    assert r2.outcome == {"numpy": "ok", "good-one": "pending", "other": "pending"}
    assert r2.failed == [] and "every package is installed" in lines[0]


def test_a_package_that_cannot_be_installed_is_named_with_the_reason(fake):
    fake["pkgs"].append(deps.Package("badpkg", "invrad_test_badpkg", "badpkg>=1", False,
                                     "z"))
    lines = []
    r = deps.install(target=fake["target"], python=fake["python"], say=lines.append)
    assert r.failed == ["badpkg"]
    assert r.outcome["good-one"] == "installed" and r.outcome["other"] == "installed"
    assert r.reasons["badpkg"] == ("Could not find a version that satisfies the requirement"
                                   " badpkg")
    assert len(_calls(fake["log"])) == 1 + 3     # together, then one by one
    failed = [l for l in lines if "badpkg: FAILED" in l]
    assert len(failed) == 1 and "works without it" in failed[0]
    assert not r.ok


def test_without_network_every_package_fails_once_with_the_reason(fake, monkeypatch):
    monkeypatch.setenv("FAKE_PIP_OFFLINE", "1")
    lines = []
    r = deps.install(target=fake["target"], python=fake["python"], say=lines.append)
    assert r.failed == ["good-one", "other"] and not r.restart_needed
    assert len(_calls(fake["log"])) == 1           # not retried package by package
    assert r.reasons["other"].startswith("the package index cannot be reached"
                                         " ([Errno 101] Network is unreachable)")
    assert len([l for l in lines if "FAILED" in l]) == 2


def test_no_python_for_pip_fails_every_package_in_one_line_each(fake, monkeypatch):
    monkeypatch.setattr(pip_runner, "candidates", lambda *a, **k: [])
    lines = []
    r = deps.install(target=fake["target"], say=lines.append)
    assert r.failed == ["good-one", "other"]
    assert "no Python %d.%d" % sys.version_info[:2] in r.reasons["good-one"]
    assert not os.path.exists(fake["target"])


def test_an_error_inside_is_one_line_never_a_traceback(fake, monkeypatch):
    def broken(*a, **k):
        raise OSError("disk full")
    monkeypatch.setattr(pip_runner, "run", broken)
    lines = []
    r = deps.install(target=fake["target"], python=fake["python"], say=lines.append)
    assert r.failed == ["good-one", "other"]
    assert r.reasons["other"] == "OSError: disk full"
    assert lines[-1] == "invrad install: stopped: OSError: disk full"


def test_find_python_takes_the_same_python_version_with_pip(tmp_path):
    exe, why = pip_runner.find_python(preferred=sys.executable)
    assert why is None and exe == sys.executable
    other = tmp_path / "python2.7"
    other.write_text("#!/bin/sh\necho 2.7\necho 9.0\n")
    other.chmod(0o755)
    exe, why = pip_runner.find_python(preferred=str(other))
    assert exe != str(other)          # another Python version is never used


@pytest.mark.parametrize("version, req, ok", [
    ("0.9.0.post1", "ifcopenshell>=0.8.1,<0.9", False),
    ("0.8.5", "ifcopenshell>=0.8.1,<0.9", True),
    ("2.2.4", "numpy>=1.24,<2", False),
    ("1.24.2", "numpy>=1.24,<2", True),
    ("2026.1.4", "pyopencl[pocl]>=2024.1", True),
    ("", "trimesh>=4.0", True),
    ("3.0.0rc1", "x>=3.0", True),
])
def test_version_bounds(version, req, ok):
    assert deps.satisfies(version, req) is ok


def test_each_missing_package_says_whether_it_is_needed_and_for_what():
    # the install dialog and the headless installer list these lines: a required
    # package said only "trimesh: missing", an optional one what is lost without it
    by_name = {p.name: p for p in deps.packages()}
    line = deps.Status(by_name["trimesh"], "missing").line
    assert line == "trimesh: missing; needed for meshes"
    assert deps.Status(by_name["jinja2"], "missing").line.endswith(
        "needed for every report")
    assert deps.Status(by_name["ifcopenshell"], "missing").line.endswith(
        "without it: no IFC files and NativeIFC")
    assert deps.Status(by_name["trimesh"], "ok", "4.5").line == "trimesh: ok 4.5"
