#!/usr/bin/env bash
# make test: every suite, in two streams side by side (on 2 cores one suite alone leaves a
# core idle much of the time: numpy and Python mostly run on one, the OpenCL kernels and the
# room workers on both):
#   host:          the set-up (make setup), the core tests (pytest), then FreeCAD 0.20's
#                  (make test-core test-freecad), in the foreground: output as it comes;
#   FreeCAD 1.0:   the root's concurrency check, FreeCAD 1.0's tests, then the core tests
#                  with Python 3.13 and numpy 2 (make test-freecad1), in the background with
#                  its own log (out/test-freecad1.XXXXXX.log, or in $INVRAD_TEST_LOGS),
#                  printed whole at the end and kept if it failed; INVRAD_NO_FREECAD1=1
#                  skips it.
# The exit status is 0 only when both streams passed; each stream's status is printed.
# INVRAD_TEST_SERIAL=1 runs the streams one after the other (the log still printed at the
# end), e.g. to time one suite alone.
set -uo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
cd "$here"
make="${MAKE:-make}"
bg=""
log=""
stop_bg() {   # a stopped make test leaves no background stream (it unmounts on TERM)
  if [ -n "$bg" ] && kill -0 "$bg" 2>/dev/null; then
    kill -TERM -- "-$bg" 2>/dev/null || kill -TERM "$bg" 2>/dev/null
    wait "$bg" 2>/dev/null
  fi
}
trap 'stop_bg; exit 130' INT
trap 'stop_bg; exit 143' TERM
trap 'stop_bg; exit 129' HUP
if [ -z "${INVRAD_NO_FREECAD1:-}" ]; then
  logs="${INVRAD_TEST_LOGS:-$here/out}"
  mkdir -p "$logs"
  log="$(mktemp "$logs/test-freecad1.XXXXXX.log")"
  if [ -n "${INVRAD_TEST_SERIAL:-}" ]; then
    "$make" --no-print-directory test-freecad1 </dev/null >"$log" 2>&1
    fc1=$?
  else
    # own process group (job control): it keeps SIGINT (a background job of a script
    # would ignore it, which the cancellation tests notice) and stop_bg can end it whole
    set -m
    "$make" --no-print-directory test-freecad1 </dev/null >"$log" 2>&1 &
    bg=$!
    set +m
    echo "FreeCAD 1.0 tests and the numpy 2 core pass run beside these (log: $log)"
  fi
fi
# the host's set-up (venv, Debian packages) runs beside the root's stream too: it needs
# neither (the two set-ups take turns at apt: /tmp/invrad-apt.lock)
fc020=-
if "$make" --no-print-directory setup; then
  "$make" --no-print-directory test-core
  core=$?
  "$make" --no-print-directory test-freecad
  fc020=$?
else
  core=$?
  echo "make setup failed: the host's tests were not run" >&2
fi
if [ -n "$bg" ]; then
  wait "$bg"
  fc1=$?
  bg=""
fi
status=0
line() {
  local what="FAILED (status $2)"
  [ "$2" = 0 ] && what=passed
  [ "$2" = - ] && what="not run"
  printf '  %-44s %s\n' "$1" "$what"
}
if [ -n "$log" ]; then
  echo "================ FreeCAD 1.0 root: FreeCAD 1.0 tests, core tests on numpy 2 ($log)"
  cat "$log"
  echo "================ end of the FreeCAD 1.0 root's log"
fi
echo "make test:"
line "set-up and core tests (host, numpy 1)" "$core"
line "FreeCAD 0.20 tests" "$fc020"
if [ -n "$log" ]; then
  line "FreeCAD 1.0 tests and core tests on numpy 2" "$fc1"
  [ "$fc1" = 0 ] && rm -f "$log"
else
  echo "  FreeCAD 1.0 tests skipped (INVRAD_NO_FREECAD1)"; fc1=0
fi
for s in "$core" "$fc020" "$fc1"; do [ "$s" = 0 ] || status=1; done
exit "$status"
