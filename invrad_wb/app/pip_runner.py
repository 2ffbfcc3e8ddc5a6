"""pip as FreeCAD's Addon Manager runs it: the Python that FreeCAD embeds, ``--target`` the
add-ons' package folder; used by :func:`invrad_wb.app.dependencies.install`.

Inside FreeCAD ``sys.executable`` is FreeCAD itself (``freecadcmd`` or the GUI), so pip
needs a separate interpreter of the SAME Python version as the one FreeCAD embeds (wheels
for another version would land in FreeCAD's folder and never import). The candidates
follow the Addon Manager's order (its worker's "Find Python" in 0.20, ``get_python_exe``
in 1.x): the user's preference ``PythonExecutableForPip``, ``python3``/``python`` in
FreeCAD's ``bin`` folder (AppImage, Windows and conda bundles), then the PATH; unlike the
Addon Manager each is asked its version and whether it has pip, and the first that
matches is used.

pip gets ``--upgrade``: without it ``pip install --target DIR`` leaves a package already in
DIR in place ("Target directory ... already exists") and still reports success (measured:
ifcopenshell 0.9 stayed when 0.8 was asked for). The environment goes to pip unchanged,
so ``PIP_CERT``, ``PIP_INDEX_URL``, a proxy or ``pip.conf`` apply as for any pip run.
Nothing here imports FreeCAD or raises: failures come back as one-line reasons.
"""
import os
import re
import shutil
import subprocess
import sys

#: FreeCAD's parameter group and key of the Addon Manager's Python for pip.
PREF_GROUP = "User parameter:BaseApp/Preferences/Addons"
PREF_KEY = "PythonExecutableForPip"


def wanted_version():
    """'X.Y' of the running (FreeCAD's) Python."""
    return "%d.%d" % sys.version_info[:2]


def candidates(preferred=None, freecad_home=None):
    """Interpreters to try for pip, in the Addon Manager's order, without duplicates."""
    ver = wanted_version()
    names = []
    if preferred and preferred != "Not set":
        names.append(preferred)
    if freecad_home:
        for exe in ("python3", "python", f"python{ver}"):
            names.append(os.path.join(freecad_home, "bin", exe + (
                ".exe" if sys.platform == "win32" else "")))
    if os.path.basename(sys.executable).lower().startswith("python"):
        names.append(sys.executable)           # a plain Python (tests, batch scripts)
    names.append(os.path.join(sys.base_exec_prefix, "bin", f"python{ver}"))
    for exe in (f"python{ver}", "python3", "python"):
        found = shutil.which(exe)
        if found:
            names.append(found)
    out = []
    for n in names:
        if n and n not in out and os.path.isfile(n) and os.access(n, os.X_OK):
            out.append(n)
    return out


def _probe(exe):
    """(version 'X.Y', pip version or None) of an interpreter; (None, None) if it fails."""
    code = ("import sys\n"
            "print('%d.%d' % sys.version_info[:2])\n"
            "try:\n"
            "    import pip; print(pip.__version__)\n"
            "except Exception:\n"
            "    print('')\n")
    try:
        p = subprocess.run([exe, "-c", code], capture_output=True, text=True, timeout=60,
                           env=_pip_environment())
    except (OSError, subprocess.SubprocessError):
        return None, None
    lines = p.stdout.splitlines()
    if p.returncode != 0 or not lines:
        return None, None
    return lines[0].strip(), (lines[1].strip() if len(lines) > 1 and lines[1].strip()
                              else None)


def find_python(preferred=None, freecad_home=None):
    """The interpreter that runs pip for FreeCAD's Python.

    Returns
    -------
    (path, None) or (None, reason): reason is one line saying what was tried and missing.
    """
    ver = wanted_version()
    without_pip = []
    for exe in candidates(preferred, freecad_home):
        got, pip = _probe(exe)
        if got != ver:
            continue
        if pip:
            return exe, None
        without_pip.append(exe)
    if without_pip:
        return None, (f"{without_pip[0]} (Python {ver}, FreeCAD's) has no pip: install it"
                      " (Debian/Ubuntu: sudo apt-get install python3-pip), or set the Addon"
                      " Manager's 'Python executable for pip' to a Python"
                      f" {ver} with pip")
    return None, (f"no Python {ver} (the version FreeCAD embeds) was found to run pip:"
                  " install python3 and python3-pip, or set the Addon Manager's 'Python"
                  " executable for pip'")


def _pip_environment():
    """pip's environment: the user's, less what would point the interpreter elsewhere
    (FreeCAD's own PYTHONHOME/PYTHONPATH are for its embedded Python)."""
    env = dict(os.environ)
    for key in ("PYTHONHOME", "PYTHONPATH", "PYTHONSTARTUP"):
        env.pop(key, None)
    env.setdefault("PYTHONIOENCODING", "utf-8")
    return env


def pip_command(python, target, requirements, constraints=None):
    """The pip command line (list) that installs ``requirements`` into ``target``."""
    cmd = [python, "-m", "pip", "install", "--disable-pip-version-check", "--no-input",
           "--progress-bar", "off", "--upgrade", "--target", target]
    if constraints:
        cmd += ["--constraint", constraints]
    return cmd + list(requirements)


def error_line(text):
    """The line of pip's output that says why it failed: its first ERROR line (for a
    missing version: "Could not find a version that satisfies the requirement X (from
    versions: ...)"), else its last line."""
    lines = [l.strip() for l in (text or "").splitlines() if l.strip()]
    errors = [l for l in lines if l.startswith("ERROR:")]
    pick = errors[0] if errors else (lines[-1] if lines else "no output")
    pick = pick.replace("ERROR: ", "", 1)
    return pick if len(pick) <= 300 else pick[:297] + "..."


#: what pip prints when it cannot reach the index (then every package fails alike)
_NETWORK_SIGNS = ("NewConnectionError", "ConnectTimeout", "ConnectionError", "ProxyError",
                  "SSLError", "CERTIFICATE_VERIFY_FAILED", "Could not fetch URL",
                  "Temporary failure in name resolution", "Name or service not known",
                  "Network is unreachable", "Connection refused", "ReadTimeoutError")


def network_error(text):
    """One line saying why pip could not reach the package index, or None when its
    output shows no such failure (a retry warning or a failed fetch)."""
    for line in (text or "").splitlines():
        if any(sign in line for sign in _NETWORK_SIGNS):
            m = re.search(r"(\[Errno [^\]]+\][^'\")]*|CERTIFICATE_VERIFY_FAILED[^'\")]*|"
                          r"Temporary failure in name resolution|Name or service not known|"
                          r"Read timed out|timed out)", line)
            why = m.group(1).strip() if m else line.strip()[:200]
            return (f"the package index cannot be reached ({why}); check the network,"
                    " or pip's index/proxy/certificate settings (PIP_INDEX_URL, HTTPS_PROXY,"
                    " PIP_CERT)")
    return None


def run(cmd, on_line=None):
    """Run a pip command, passing each output line to ``on_line``.

    Returns
    -------
    (returncode, output text); returncode -1 when pip could not be started.
    """
    out = []
    try:
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                text=True, errors="replace", env=_pip_environment())
    except OSError as exc:
        return -1, f"ERROR: cannot run {cmd[0]}: {exc}"
    try:
        for line in proc.stdout:
            out.append(line)
            if on_line is not None:
                on_line(line.rstrip("\n"))
    except BaseException:
        proc.kill()            # the caller gave up (an exception in on_line): no orphan pip
        proc.wait()
        raise
    return proc.wait(), "".join(out)
