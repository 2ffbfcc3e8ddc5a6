#!/usr/bin/env bash
# Two runs in the FreeCAD 1.0 root at once, from the same checkout: the one that ends first
# must not unmount what the other still uses (its checkout, /proc, /sys, /dev), and the last
# one leaves no mount or folder behind. Part of `make test` (test-freecad1).
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
root="$("$here/.ci/setup-freecad1.sh" | tail -1)"
long='sleep 4; test -r /proc/self/status && test -c /dev/null && test -d /sys/devices && test -f tests/conftest.py && python -c "import os; os.sched_getaffinity(0)"'
"$here/.ci/test-freecad1.sh" bash -c "$long" & a=$!
sleep 1.5
"$here/.ci/test-freecad1.sh" true
"$here/.ci/test-freecad1.sh" bash -c 'test -r /proc/self/status'
if ! wait "$a"; then
  echo "FAIL: a run in the FreeCAD 1.0 root lost its mounts when another run ended" >&2; exit 1
fi
# the leftovers are judged only when no other run (another checkout, a person) is inside
exec 7>>"$root.users"
if flock -x -n 7; then
  left=""
  for d in "$root"/invrad-*; do [ -e "$d" ] && left="$left $d"; done
  for m in proc sys dev; do mountpoint -q "$root/$m" && left="$left $root/$m"; done
  if [ -n "$left" ]; then echo "FAIL: left behind in the root:$left" >&2; exit 1; fi
  echo "FreeCAD 1.0 root: concurrent runs kept their mounts and left nothing behind"
else
  echo "FreeCAD 1.0 root: concurrent runs kept their mounts (another run is inside: leftovers not judged)"
fi
