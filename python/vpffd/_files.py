"""Writing files without ever losing one: the Python side of the rule the mesh writer
follows in C++ (cpp/src/io/atomic_write.cpp).

The new content goes to a temporary file in the target's folder; once it is complete,
it is flushed to the disk (fsync) and renamed over the target. Any failure on the
way (a full disk, a file-size limit, an exception in the code that writes) removes
the temporary file and leaves an existing target as it was. Targets that cannot be
replaced this way (a FIFO, a device, a folder) are refused before anything is written.
"""

from __future__ import annotations

import os
import secrets
import stat
from contextlib import contextmanager

from ._core import MeshIOError

__all__ = ["replaced_path", "open_replacing", "write_bytes", "write_text"]


def _target(path, what: str) -> str:
    p = os.fspath(path)
    if isinstance(p, bytes):
        p = os.fsdecode(p)
    real = os.path.realpath(p)  # a link stays a link: the file it names is replaced
    try:
        st = os.stat(real)
    except FileNotFoundError:
        st = None
    except OSError as e:
        raise MeshIOError(f"{what}: '{p}': {e.strerror or e}") from None
    if st is not None and not stat.S_ISREG(st.st_mode):
        kind = ("a folder" if stat.S_ISDIR(st.st_mode) else "a FIFO" if stat.S_ISFIFO(st.st_mode)
                else "a device" if stat.S_ISCHR(st.st_mode) or stat.S_ISBLK(st.st_mode) else "not a regular file")
        raise MeshIOError(f"{what}: '{p}' is {kind}, which cannot be replaced safely; write to a regular file")
    folder = os.path.dirname(real) or "."
    if not os.path.isdir(folder):
        raise MeshIOError(f"{what}: '{p}': the folder '{folder}' does not exist")
    return real


@contextmanager
def replaced_path(path, what: str = "write"):
    """Yields a temporary path (same folder, same extension, so libraries that pick
    the format by extension still do) to write the new file to; on success it
    replaces ``path``, on any exception it is removed and ``path`` is untouched.
    OSErrors become MeshIOError naming ``path``."""
    target = _target(path, what)
    folder, name = os.path.split(target)
    stem, ext = os.path.splitext(name)
    tmp = None
    for _ in range(100):
        candidate = os.path.join(folder or ".", f".{stem}.{secrets.token_hex(6)}.tmp{ext}")
        try:
            # 0o666: a new file gets what the umask gives, as open() would give it.
            os.close(os.open(candidate, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_CLOEXEC, 0o666))
        except FileExistsError:
            continue
        except OSError as e:
            raise MeshIOError(f"{what}: '{os.fspath(path)}': cannot create a file in its folder: "
                              f"{e.strerror or e}") from None
        tmp = candidate
        break
    if tmp is None:
        raise MeshIOError(f"{what}: '{os.fspath(path)}': cannot create a temporary file in its folder")
    try:
        try:
            os.chmod(tmp, stat.S_IMODE(os.stat(target).st_mode))  # an existing file keeps its permissions
        except FileNotFoundError:
            pass
        yield tmp
        fd = os.open(tmp, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
        os.replace(tmp, target)
    except OSError as e:
        _remove(tmp)
        raise MeshIOError(f"{what}: '{os.fspath(path)}': {e.strerror or e}; the old file (if any) is unchanged") \
            from None
    except BaseException:
        _remove(tmp)
        raise


def _remove(tmp: str) -> None:
    try:
        os.unlink(tmp)
    except FileNotFoundError:
        pass


@contextmanager
def open_replacing(path, mode: str = "w", what: str = "write", **kwargs):
    """``open(path, mode)`` for writing ("w" or "wb"), replacing ``path`` only when the
    ``with`` block ends without an error and every byte is on the disk."""
    if mode not in ("w", "wb"):
        raise ValueError(f"open_replacing: mode must be 'w' or 'wb', got {mode!r}")
    with replaced_path(path, what) as tmp:
        with open(tmp, mode, **kwargs) as fh:
            yield fh
            fh.flush()


def write_bytes(path, data: bytes, what: str = "write") -> None:
    with open_replacing(path, "wb", what) as fh:
        fh.write(data)


def write_text(path, text: str, what: str = "write", **kwargs) -> None:
    with open_replacing(path, "w", what, **kwargs) as fh:
        fh.write(text)
