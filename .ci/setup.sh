#!/usr/bin/env bash
# One set-up path for a fresh Debian 12 machine (see ../shared/ENVIRONMENT.md facts):
# FreeCAD 0.20 (freecadcmd), PoCL (OpenCL on the CPU), and a venv built on Debian's
# python3 so that pytest and freecadcmd see the same packages.
# Idempotent: each step is skipped when its result is already there.
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
cd "$here"
venv="$here/.venv"
stamp="$venv/.invrad-setup-v1"

need_apt=()
command -v freecadcmd >/dev/null 2>&1 || need_apt+=(freecad-python3)
[ -e /etc/OpenCL/vendors/pocl.icd ] || need_apt+=(pocl-opencl-icd ocl-icd-libopencl1 clinfo)
command -v xvfb-run >/dev/null 2>&1 || [ -n "${INVRAD_NO_GUI:-}" ] || need_apt+=(xvfb xauth)
if [ -z "${INVRAD_NO_GUI:-}" ] && ! command -v freecad >/dev/null 2>&1; then need_apt+=(freecad); fi
/usr/bin/python3 -c 'import venv, ensurepip' 2>/dev/null || need_apt+=(python3-venv python3-pip)
# the reports' PDF (WeasyPrint with its Pango) and the PDF checks of the tests (pdftoppm,
# pdftotext, pdfimages)
/usr/bin/python3 -c 'import weasyprint' 2>/dev/null || need_apt+=(weasyprint)
command -v pdftoppm >/dev/null 2>&1 || need_apt+=(poppler-utils)
if [ ${#need_apt[@]} -gt 0 ]; then
  echo "invrad setup: installing Debian packages: ${need_apt[*]}"
  SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  # one apt at a time with .ci/setup-freecad1.sh (make test starts both at once)
  flock /tmp/invrad-apt.lock $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive flock /tmp/invrad-apt.lock \
    $SUDO apt-get install -y -qq --no-install-recommends "${need_apt[@]}" >/dev/null
fi

if [ ! -f "$stamp" ] || [ requirements.txt -nt "$stamp" ]; then
  echo "invrad setup: building the venv in $venv"
  [ -x "$venv/bin/python" ] || /usr/bin/python3 -m venv --system-site-packages "$venv"
  "$venv/bin/python" -m pip install -q --upgrade pip
  "$venv/bin/python" -m pip install -q -r requirements.txt
  "$venv/bin/python" -m pip install -q --no-deps -e .
  touch "$stamp"
fi
