"""Output paths checked before any work starts.

Every command checks where it will write before it reads or computes anything, so a typo
in ``-o`` costs a second, not the whole run, and never replaces a file it should not:

* a file output must not be a folder or a device, pipe or socket, its folder must be
  writable (or creatable), it must not be one of the command's inputs, and an existing
  read-only file is refused (never made writable behind the user's back);
* a folder output must not be an existing file, and its parent must be writable;
* a symbolic link is written through (the file it points to is replaced atomically; the
  link stays a link): :func:`resolve`.

Each checked path is declared to the run guard (:func:`invrad_wb.runguard.declare`), which
removes what a failed run created there and nothing that existed before.
"""
import os

from invrad_wb.core.io.atomic import FULL_BYTES
from invrad_wb.errors import InvradError
from invrad_wb.runguard import declare

#: bytes written to a probe file in an output's folder before a run (a block)
PROBE_BYTES = 4096


def resolve(path):
    """The path writes go to: a symbolic link's target, else the path itself."""
    return os.path.realpath(os.fspath(path))


def check_file(path, what="output", inputs=()):
    """Refuse an output file path that cannot or must not be written (InvradError)."""
    path = os.fspath(path)
    real = resolve(path)
    if os.path.isdir(real):
        raise InvradError(f"{path}: {what} is a folder; give a file name")
    if os.path.exists(real) and not os.path.isfile(real):
        # a device, pipe or socket (/dev/null, /dev/full, /dev/stdout): outputs are written
        # to a temporary file renamed onto the path, which would replace the device node
        raise InvradError(f"{path}: {what} is a device, pipe or socket, not a file; give a"
                          " file name")
    _check_parent(path, os.path.dirname(real) or ".", what)
    for src in inputs:
        if src and os.path.exists(src) and os.path.exists(real) \
                and os.path.samefile(src, real):
            raise InvradError(f"{path}: {what} is the input file {src}; write to another"
                              " file (invrad never replaces its input)")
    if os.path.exists(real) and not (os.stat(real).st_mode & 0o222 and
                                     os.access(real, os.W_OK)):
        # by its mode bits too: root may write anything, but a file marked read-only
        # says its owner wants it kept
        raise InvradError(f"{path}: {what} exists and is read-only; not replacing it")
    declare(path, real, "file")
    return real


def check_folder(path, what="output folder"):
    """Refuse an output folder path that is a file or cannot be created (InvradError)."""
    path = os.fspath(path)
    real = resolve(path)
    if os.path.exists(real) and not os.path.isdir(real):
        raise InvradError(f"{path}: {what} is an existing file, not a folder")
    _check_parent(path, os.path.dirname(os.path.abspath(real)) or ".", what)
    declare(path, real, "folder")
    return real


def _check_parent(path, folder, what):
    """The folder an output goes into exists and is writable, or can be created: its
    nearest existing ancestor is a writable folder (not a file)."""
    probe = os.path.abspath(folder)
    while not os.path.exists(probe):
        probe = os.path.dirname(probe)
    if not os.path.isdir(probe):
        raise InvradError(f"{path}: {what}: {probe} is a file, not a folder")
    if not os.access(probe, os.W_OK):
        raise InvradError(f"{path}: {what}: the folder {probe} is not writable")
    # permission bits do not tell everything (root, read-only mounts, /proc): try it
    import errno
    import tempfile
    try:
        fd, tmp = tempfile.mkstemp(prefix=".invrad-probe-", dir=probe)
    except OSError as exc:
        raise InvradError(f"{path}: {what}: cannot write in the folder {probe}"
                          f" ({exc.strerror or exc})") from None
    # a full disk or a spent quota still lets a file be made (an inode, no block): write
    # a block, and ask for the free space, before the run rather than at its last write
    # (the same line as a write that fails then: runguard.output_error)
    try:
        try:
            os.write(fd, b"\0" * PROBE_BYTES)
            try:
                os.fsync(fd)
            except OSError as exc:        # a file system without fsync is no full disk
                if exc.errno in (errno.ENOSPC, errno.EDQUOT, errno.EIO):
                    raise
        finally:
            os.close(fd)
            os.unlink(tmp)
        st = os.statvfs(probe)
        # (a file system that counts no blocks at all, /proc-like, says nothing here)
        if st.f_blocks and st.f_bavail * st.f_frsize < FULL_BYTES:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
    except OSError as exc:
        raise InvradError(f"{path}: cannot write the output:"
                          f" {exc.strerror or os.strerror(exc.errno or errno.EIO)}") from None
