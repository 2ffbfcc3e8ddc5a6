"""Atomic file output: write to a temporary file in the same folder, then rename.

A failed or interrupted write never leaves a half-written or truncated user file behind.
"""
import contextlib
import os
import re
import tempfile


@contextlib.contextmanager
def atomic_path(path, suffix=None):
    """Yield a temporary path next to ``path``; on success rename it onto ``path``.

    The temporary file keeps ``path``'s extension (or ``suffix``) so that writers that
    choose a format by extension (OpenImageIO, trimesh) still work. A symbolic link is
    written through: the file it points to is replaced, the link stays.
    """
    path = os.path.realpath(os.fspath(path))
    folder = os.path.dirname(os.path.abspath(path))
    os.makedirs(folder, exist_ok=True)
    ext = suffix if suffix is not None else os.path.splitext(path)[1]
    remove_stale(folder)
    fd, tmp = tempfile.mkstemp(prefix=temp_prefix(), suffix=ext, dir=folder)
    os.close(fd)
    try:
        yield tmp
        # mkstemp makes the file private (0600); give it the mode a plain open() would
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, path)
    except BaseException as exc:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        _name_output(exc, path)
        raise


def _name_output(exc, path):
    """An OSError while writing ``path`` says which output it was (``exc.output_path``):
    its own file name is a temporary one, or none at all (``write()`` on a full disk), and
    a caller reporting it should name the output, not that."""
    if isinstance(exc, OSError) and not getattr(exc, "output_path", None):
        with contextlib.suppress(AttributeError, TypeError):
            exc.output_path = path


def write_error(path, tmp, detail):
    """An ``OSError`` for a library's failed write of ``path`` (OpenImageIO returns False
    and a message, no errno): the errno read from the file system where it failed (full:
    ENOSPC, read-only: EROFS, else EIO), and the message with the temporary file's name
    replaced by ``path``."""
    import errno
    code = errno.EIO
    try:
        st = os.statvfs(os.path.dirname(os.path.abspath(tmp)))
        if st.f_flag & getattr(os, "ST_RDONLY", 1):
            code = errno.EROFS
        elif st.f_bavail * st.f_frsize < FULL_BYTES:
            code = errno.ENOSPC
    except (OSError, AttributeError):
        pass
    detail = str(detail).replace(os.fspath(tmp), os.fspath(path))
    text = os.strerror(code) + (f" ({detail})" if code == errno.EIO and detail else "")
    exc = OSError(code, text, os.fspath(path))
    exc.output_path = os.fspath(path)
    return exc


#: free space below which a failed write is taken for a full disk (a block or two)
FULL_BYTES = 64 << 10


_STALE = re.compile(r"^\.invrad-(?:old-)?(\d+)-")


def temp_prefix(kind=""):
    """Temporary names carry the writer's process id: a later run can tell a leftover of a
    killed run (SIGKILL, power loss) from the output of one still running."""
    return f".invrad-{kind}{os.getpid()}-"


def _alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OSError):
        return True                  # someone else's process: leave its files alone
    return True


def remove_stale(folder):
    """Remove the temporary files and folders that killed invrad runs left in ``folder``;
    returns their names."""
    removed = []
    try:
        names = os.listdir(folder)
    except OSError:
        return removed
    for name in names:
        m = _STALE.match(name)
        if not m or int(m.group(1)) == os.getpid() or _alive(int(m.group(1))):
            continue
        path = os.path.join(folder, name)
        try:
            if os.path.isdir(path) and not os.path.islink(path):
                import shutil
                shutil.rmtree(path)
            else:
                os.unlink(path)
            removed.append(name)
        except OSError:
            pass
    return removed


def _umask():
    mask = os.umask(0)
    os.umask(mask)
    return mask


def atomic_write_bytes(path, data):
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())


def atomic_write_text(path, text):
    atomic_write_bytes(path, text.encode("utf-8"))


@contextlib.contextmanager
def atomic_dir(path):
    """Yield a temporary folder next to ``path``; on success it replaces ``path`` whole.

    A multi-file output (a report) appears all at once or not at all: an interrupted run
    leaves the previous folder untouched (and no temporary folder when cleanup is
    possible). ``path`` must not be an existing file.
    """
    path = os.path.abspath(os.fspath(path))
    parent = os.path.dirname(path)
    if os.path.exists(path) and not os.path.isdir(path):
        raise FileExistsError(f"{path} is a file, not a folder")
    os.makedirs(parent, exist_ok=True)
    remove_stale(parent)
    tmp = tempfile.mkdtemp(prefix=temp_prefix(), dir=parent)
    try:
        yield tmp
        os.chmod(tmp, 0o777 & ~_umask())
        replace_dir(tmp, path)
    except BaseException as exc:
        import shutil
        shutil.rmtree(tmp, ignore_errors=True)
        _name_output(exc, path)
        raise


def replace_dir(src, dst):
    """Put the folder ``src`` in the place of ``dst`` (an existing folder there is moved
    aside first and removed after: two renames, no moment without one of them)."""
    old = None
    if os.path.isdir(dst):
        old = tempfile.mkdtemp(prefix=temp_prefix("old-"), dir=os.path.dirname(dst))
        os.rmdir(old)
        os.replace(dst, old)
    os.replace(src, dst)
    if old is not None:
        import shutil
        shutil.rmtree(old, ignore_errors=True)
