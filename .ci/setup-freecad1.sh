#!/usr/bin/env bash
# FreeCAD 1.0 next to the host's 0.20 (../shared/ENVIRONMENT.md): a Debian 13 (trixie) root
# with freecad-python3 (1.0.0), PoCL and a venv of invrad's dependencies built for its
# Python 3.13 and numpy 2. Built once (about 4 minutes, 2.5 GB) and cached in
# $INVRAD_FC1_ROOT (default /var/cache/invrad/trixie-freecad1); every later call is a check.
# Needs root (debootstrap, chroot); prints the root's path on its last line.
set -euo pipefail
root="${INVRAD_FC1_ROOT:-/var/cache/invrad/trixie-freecad1}"
stamp="$root/.invrad-freecad1-v1"
here="$(cd "$(dirname "$0")/.." && pwd)"
# the stamp holds the requirements the venv was built from: a change re-runs only pip
reqs="$(grep -v '^numpy' "$here/requirements.txt")"
# FreeCAD 1.0.0's NativeIFC (BIM workbench) uses entity_instance.wrapped_data, which
# ifcopenshell 0.9 removed: an ifcopenshell 0.8 in its own folder, put first on the path by
# test-freecad1.sh (the venv keeps the requirements' ifcopenshell; 0.8 needs nothing more)
nifc_req='ifcopenshell>=0.8.1,<0.9'
nifc=/opt/invrad-nativeifc
nifc_ok() { [ "$(cat "$root$nifc/.invrad-stamp" 2>/dev/null)" = "$nifc_req" ]; }
# PySide6 (Debian's, not used by FreeCAD 1.0's Qt 5 build): tests/freecad/test_qt_names.py
# looks up every Qt name the GUI uses in it, in a separate Python process
pyside6_ok() { [ -n "${INVRAD_NO_GUI:-}" ] || [ -d "$root/usr/lib/python3/dist-packages/PySide6" ]; }
if [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$reqs" ] && nifc_ok && pyside6_ok; then
  echo "$root"; exit 0
fi
if [ "$(id -u)" -ne 0 ]; then
  echo "invrad setup (FreeCAD 1.0): needs root for debootstrap/chroot; run as root or set" \
       "INVRAD_NO_FREECAD1=1 to test on the host's FreeCAD only" >&2
  exit 2
fi
# the Debian host this machine already uses
mirror="$(sed -n 's/^URIs: *//p' /etc/apt/sources.list.d/debian.sources 2>/dev/null | head -1)"
mirror="${mirror:-http://deb.debian.org/debian}"
command -v debootstrap >/dev/null 2>&1 || {
  # one apt at a time with .ci/setup.sh (make test starts both at once)
  flock /tmp/invrad-apt.lock apt-get update -qq
  DEBIAN_FRONTEND=noninteractive flock /tmp/invrad-apt.lock \
    apt-get install -y -qq debootstrap >/dev/null; }
# one build at a time (several checkouts may start at once): wait, then check again
mkdir -p "$(dirname "$root")"
exec 6>>"$root.build"
flock -x 6
if [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$reqs" ] && nifc_ok && pyside6_ok; then
  echo "$root"; exit 0
fi
# shellcheck source=fc1-mounts.sh
. "$here/.ci/fc1-mounts.sh"
echo "invrad setup: FreeCAD 1.0 in a Debian trixie root at $root (first time: a few minutes)"
[ -x "$root/usr/bin/apt-get" ] || debootstrap --variant=minbase trixie "$root" "$mirror" >/dev/null
cp /etc/resolv.conf "$root/etc/resolv.conf"
# pip inside the root uses this machine's pip settings (index, certificates: a proxy's CA
# may be in the host's bundle only)
[ -f /etc/pip.conf ] && cp /etc/pip.conf "$root/etc/pip.conf"
cert="${PIP_CERT:-/etc/ssl/certs/ca-certificates.crt}"
mkdir -p "$root/etc/ssl/certs"
[ -f "$cert" ] && cp "$cert" "$root/etc/ssl/certs/invrad-host-ca.crt"
# a user of the root while building (fc1-mounts.sh): /proc is not unmounted under another run
fc1_enter "$root"
trap 'fc1_leave "$root"' EXIT
# weasyprint (with Pango) for the reports' PDF, poppler-utils for the tests' PDF checks;
# PySide6 for the Qt 6 name check (tests/freecad/test_qt_names.py)
pkgs=(freecad-python3 python3-venv python3-pip pocl-opencl-icd ocl-icd-libopencl1
      weasyprint poppler-utils)
[ -n "${INVRAD_NO_GUI:-}" ] || pkgs+=(freecad xvfb xauth python3-pyside6.qtwidgets)
chroot "$root" apt-get update -qq
chroot "$root" env DEBIAN_FRONTEND=noninteractive \
  apt-get install -y -qq --no-install-recommends "${pkgs[@]}" >/dev/null
# no numpy<2 pin here: trixie's scipy/matplotlib are built for numpy 2
grep -v '^numpy' "$here/requirements.txt" > "$root/tmp/invrad-requirements.txt"
chroot "$root" python3 -m venv --system-site-packages /opt/invrad-venv
pipcert=(env); [ -f "$root/etc/ssl/certs/invrad-host-ca.crt" ] && \
  pipcert=(env PIP_CERT=/etc/ssl/certs/invrad-host-ca.crt \
            SSL_CERT_FILE=/etc/ssl/certs/invrad-host-ca.crt \
            REQUESTS_CA_BUNDLE=/etc/ssl/certs/invrad-host-ca.crt)
chroot "$root" "${pipcert[@]}" PIP_FIND_LINKS= /opt/invrad-venv/bin/python -m pip install -q \
  -r /tmp/invrad-requirements.txt
if ! nifc_ok; then
  rm -rf "${root:?}$nifc"
  chroot "$root" "${pipcert[@]}" PIP_FIND_LINKS= /opt/invrad-venv/bin/python -m pip install -q \
    --no-deps --target "$nifc" "$nifc_req"
  printf '%s' "$nifc_req" > "$root$nifc/.invrad-stamp"
fi
printf '%s' "$reqs" > "$stamp"
echo "$root"
