# Sourced by setup-freecad1.sh and test-freecad1.sh: the FreeCAD 1.0 root is shared by every
# run on this machine (several checkouts, a test and a person at once), so its mounts are
# reference-counted with flock(1) instead of guessed from what is mounted:
# - "$root.users": every run holds a SHARED lock on it while it uses the root (inherited by
#   its children); the run that leaves last can take it EXCLUSIVELY, and only that run
#   unmounts /proc, /sys and /dev (and stale per-run mounts of killed runs). A run that
#   arrives meanwhile waits for the shared lock until that unmounting is over, then mounts
#   again.
# - "$root.mount": serialises the mounting itself (two runs never both mount /proc).
# Each run bind-mounts its checkout at its own /invrad-<path hash>-<pid>, so two runs of one
# checkout never unmount each other's.
FC1_USERS_FD=8
FC1_MUTEX_FD=9

fc1_enter() {  # fc1_enter ROOT: become a user of ROOT and mount /proc, /sys, /dev
  local root="$1"
  eval "exec $FC1_USERS_FD>>\"$root.users\""
  flock -s "$FC1_USERS_FD"
  eval "exec $FC1_MUTEX_FD>>\"$root.mount\""
  flock -x "$FC1_MUTEX_FD"
  # /proc for FreeCAD, /sys for PoCL's CPU topology (hwloc), /dev for /dev/shm and ptys
  mountpoint -q "$root/proc" || mount -t proc proc "$root/proc"
  mountpoint -q "$root/sys" || mount --rbind /sys "$root/sys"
  mountpoint -q "$root/dev" || mount --rbind /dev "$root/dev"
  flock -u "$FC1_MUTEX_FD"
}

fc1_leave() {  # fc1_leave ROOT: stop using ROOT; the last user unmounts
  local root="$1" d m
  eval "exec $FC1_USERS_FD>&-"
  exec 7>>"$root.users"
  if flock -x -n 7; then
    # nobody else inside: per-run mounts still there belong to killed runs
    for d in "$root"/invrad-*; do
      [ -d "$d" ] || continue
      umount -l "$d" 2>/dev/null || true
      rmdir "$d" 2>/dev/null || true
    done
    for m in proc sys dev; do umount -l "$root/$m" 2>/dev/null || true; done
  fi
  exec 7>&-
}
