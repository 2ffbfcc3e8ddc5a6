#!/usr/bin/env bash
# Run a command of the checkout under FreeCAD 1.0 (the trixie root of setup-freecad1.sh):
#   .ci/test-freecad1.sh                      FreeCAD's test suite (tests/freecad/run.py)
#   .ci/test-freecad1.sh freecadcmd --version any command, in the checkout's folder
# The checkout is bind-mounted at /invrad-<hash of its path>-<pid> inside the root for the
# run, then unmounted, so that runs from one or several checkouts (git worktrees) can share the
# root at once; /proc, /sys and /dev are unmounted by the last run to leave (fc1-mounts.sh).
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
root="$("$here/.ci/setup-freecad1.sh" | tail -1)"
site="$(chroot "$root" /opt/invrad-venv/bin/python -c 'import site; print(site.getsitepackages()[0])')"
mnt="invrad-$(printf %s "$here" | md5sum | cut -c1-8)-$$"
# shellcheck source=fc1-mounts.sh
. "$here/.ci/fc1-mounts.sh"
cleanup() {
  umount -l "$root/$mnt" 2>/dev/null || true
  rmdir "$root/$mnt" 2>/dev/null || true
  fc1_leave "$root"
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM
trap 'exit 129' HUP
fc1_enter "$root"
mkdir -p "$root/$mnt"
mount --bind "$here" "$root/$mnt"
[ $# -gt 0 ] || set -- freecadcmd tests/freecad/run.py
# ifcopenshell 0.8 first for FreeCAD's NativeIFC; INVRAD_FC1_NATIVEIFC=0 leaves the venv's
# (the core tests: 0.8 segfaults on some of the IFC fuzz test's corrupt files, which the
# freecad command survives by checking in a child process)
nifc="/opt/invrad-nativeifc:"
[ "${INVRAD_FC1_NATIVEIFC:-1}" = 0 ] && nifc=""
# pip inside the root reaches the index with this machine's CA bundle (setup-freecad1.sh
# copies it there): the install test (tests/freecad/test_install_fc.py) runs pip
pipcert=""
[ -f "$root/etc/ssl/certs/invrad-host-ca.crt" ] && pipcert=/etc/ssl/certs/invrad-host-ca.crt
chroot "$root" env -i HOME=/root PATH=/opt/invrad-venv/bin:/usr/sbin:/usr/bin:/sbin:/bin \
  LANG=C.UTF-8 PYTHONPATH="$nifc$site:/$mnt" QT_QPA_PLATFORM=offscreen \
  ${pipcert:+PIP_CERT=$pipcert} \
  INVRAD_PYTHON=/opt/invrad-venv/bin/python \
  bash -c 'cd "$0" && exec "$@"' "/$mnt" "$@"
