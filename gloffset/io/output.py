"""Writing an output (the ``-o`` of every command), in one place.

- ``-`` is standard output.
- A regular file, or a name that does not exist yet, is replaced atomically: the data go to a
  temporary file in the same folder, flushed to disk, which then replaces the target with
  :func:`os.replace`. On any error the temporary file is removed and the target is left as it
  was. An existing file keeps its permission bits (and owner, where allowed); a new file gets
  those the umask gives (0644 under umask 022), whatever the writer made the temporary file
  with (:func:`replacing`: for GDAL and SQLite, which write to a name).
- A symbolic link is followed: the file it points to is replaced as above and the link stays.
- A FIFO, a character or block device (``/dev/null``, ``/dev/full``) or a socket is written
  through, as the shell's ``>`` does; it is never replaced by a file.
- ``/dev/stdout``, ``/dev/fd/N`` and ``/proc/self/fd/N`` write to this process's descriptor N:
  a pipe, a terminal, or the file the shell redirected it to, at its current position.

A write that cannot be made (a missing folder, no permission, no space left, a folder in the
way) raises :class:`~gloffset.errors.OutputError`, one line that names the target.
"""

from __future__ import annotations

import io
import os
import re
import secrets
import stat
import sys
from contextlib import contextmanager
from dataclasses import dataclass

from ..errors import OutputError

__all__ = [
    "STDOUT",
    "Target",
    "check_output",
    "keep_mode",
    "new_file_mode",
    "open_output",
    "refuse_stdout",
    "replacing",
    "write_bytes",
]

#: The name that means standard output.
STDOUT = "-"

_PROC_FD = re.compile(r"/proc/(\d+)/fd/(\d+)")


@dataclass(frozen=True)
class Target:
    """Where an output goes.

    ``kind`` is ``"fd"`` (an open descriptor ``fd``: standard output, ``/dev/stdout``),
    ``"replace"`` (the regular file ``path``, replaced atomically; it may not exist yet) or
    ``"through"`` (the FIFO or device ``path``, written in place).
    """

    name: str
    kind: str
    path: str | None = None
    fd: int | None = None


def _fail(target: str, exc: OSError | str) -> OutputError:
    what = "standard output" if target == STDOUT else repr(target)
    why = exc if isinstance(exc, str) else (exc.strerror or str(exc))
    return OutputError(f"cannot write {what}: {why}")


def _stdout_fd() -> int | None:
    """The descriptor under :data:`sys.stdout`, None when it has none (captured output)."""
    try:
        return sys.stdout.fileno()
    except (AttributeError, OSError, ValueError):
        return None


def _resolve(name: str) -> Target:
    if name == STDOUT:
        return Target(name, "fd", fd=_stdout_fd())
    if not name:
        raise OutputError("cannot write '': the output name is empty")
    try:
        path = os.path.abspath(name)
        for _ in range(40):
            head, tail = os.path.split(path)
            path = os.path.join(os.path.realpath(head), tail)
            m = _PROC_FD.fullmatch(path)
            if m and int(m[1]) == os.getpid():
                return Target(name, "fd", path, int(m[2]))
            try:
                link = os.readlink(path)
            except OSError:  # not a link, or nothing there
                break
            path = os.path.join(os.path.dirname(path), link)
        else:
            raise _fail(name, "too many levels of symbolic links")
        st = os.stat(path)
    except OutputError:
        raise
    except FileNotFoundError:
        return Target(name, "replace", path)
    except ValueError:  # a NUL character in the name
        raise _fail(name, "the name is not a valid file name") from None
    except OSError as exc:
        raise _fail(name, exc) from None
    if stat.S_ISDIR(st.st_mode):
        raise _fail(name, "it is a folder")
    return Target(name, "replace" if stat.S_ISREG(st.st_mode) else "through", path)


def check_output(target) -> Target:
    """Where ``target`` (a path, or ``-``) would be written, checked before any work is done:
    its folder exists and can be written to, it is not a folder. Raises
    :class:`~gloffset.errors.OutputError` otherwise; writes nothing."""
    t = _resolve(os.fspath(target))
    if t.kind == "replace":
        assert t.path is not None  # a file's target
        folder = os.path.dirname(t.path)
        if not os.path.isdir(folder):
            why = "is not a folder" if os.path.exists(folder) else "does not exist"
            raise _fail(t.name, f"folder {folder!r} {why}")
        if not os.access(folder, os.W_OK | os.X_OK):
            raise _fail(t.name, f"no permission to create files in folder {folder!r}")
        if os.path.exists(t.path) and not os.access(t.path, os.W_OK):
            raise _fail(t.name, "Permission denied")
    return t


def refuse_stdout(target, why: str) -> None:
    """Raise :class:`~gloffset.errors.OutputError` when ``target`` is ``-`` (standard output)
    for an output that cannot go there (a folder of files, a database); ``why`` says what the
    output is."""
    if os.fspath(target) == STDOUT:
        raise OutputError(f"cannot write standard output (-o -): {why}")


class _Sink(io.RawIOBase):
    """A raw writer over a binary stream that turns its errors into OutputError (a broken pipe
    excepted: the reader has gone, which is not an error of the output), and that can be told to
    discard what it is given (when the output is abandoned)."""

    def __init__(self, stream, target: Target, *, owned: bool = True):
        self._stream = stream
        self._target = target
        self._owned = owned
        self.discard = False

    def writable(self) -> bool:
        return True

    def write(self, b) -> int:
        if self.discard:
            return len(b)
        try:
            n = self._stream.write(b)
        except BrokenPipeError:
            raise
        except OSError as exc:
            raise _fail(self._target.name, exc) from None
        return len(b) if n is None else n

    def fileno(self) -> int:
        return self._stream.fileno()

    def sync(self) -> None:
        """Flush the data to the disk."""
        try:
            os.fsync(self._stream.fileno())
        except OSError as exc:
            raise _fail(self._target.name, exc) from None

    def close(self) -> None:
        if self.closed:
            return
        try:
            if self._owned:
                self._stream.close()
            elif not self.discard:
                self._stream.flush()
        except BrokenPipeError:
            raise
        except OSError as exc:
            raise _fail(self._target.name, exc) from None
        finally:
            super().close()


def _temporary(path: str, name: str) -> tuple[int, str]:
    """A new file next to ``path`` (same folder, so that os.replace is atomic)."""
    folder, base = os.path.split(path)
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0)
    flags |= getattr(os, "O_BINARY", 0)
    for _ in range(100):
        tmp = os.path.join(folder, f".{base[:200]}.{secrets.token_hex(4)}.tmp")
        try:
            return os.open(tmp, flags, 0o666), tmp
        except FileExistsError:
            continue
        except OSError as exc:
            raise _fail(name, exc) from None
    raise _fail(name, f"cannot make a temporary file in {folder!r}")  # pragma: no cover


def new_file_mode() -> int:
    """The permission bits a new file gets here: ``0o666`` less the process's umask (0644
    under umask 022), as :func:`open` gives."""
    try:  # Linux 4.7+: read without changing it
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return 0o666 & ~int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return 0o666 & ~mask


def keep_mode(tmp: str, path: str) -> None:
    """Give the temporary file the permission bits (and owner) of the file it replaces, or,
    replacing nothing, those of a new file (:func:`new_file_mode`: a writer that made it
    with other bits, SQLite's 0644 or a private temporary file's 0600, does not decide)."""
    try:
        st = os.stat(path)
    except OSError:
        os.chmod(tmp, new_file_mode())
        return
    os.chmod(tmp, stat.S_IMODE(st.st_mode))
    if hasattr(os, "chown"):
        try:
            os.chown(tmp, st.st_uid, st.st_gid)
        except OSError:  # not allowed: the file becomes ours
            pass


@contextmanager
def open_output(target, *, text: bool = False):
    """Open ``target`` (a path or ``-``) for writing, as the module docstring describes.

    Yields a binary file, or with ``text=True`` a UTF-8 text file (newlines untranslated).
    The output is complete when the ``with`` block ends without an error; an error inside the
    block abandons it (a replaced file is left as it was). Write errors raise
    :class:`~gloffset.errors.OutputError`.
    """
    t = check_output(target)
    tmp = None
    try:
        if t.kind == "fd" and t.fd is None:  # standard output without a descriptor (captured)
            sys.stdout.flush()
            sink = _Sink(sys.stdout.buffer, t, owned=False)
        elif t.kind == "fd":
            assert t.fd is not None  # the case above
            if t.fd in (1, 2):  # what Python buffered for it goes first
                (sys.stdout if t.fd == 1 else sys.stderr).flush()
            sink = _Sink(io.FileIO(os.dup(t.fd), "wb"), t)
        elif t.kind == "through":
            assert t.path is not None  # a file's target
            fd = os.open(t.path, os.O_WRONLY | getattr(os, "O_CLOEXEC", 0))
            sink = _Sink(io.FileIO(fd, "wb"), t)
        else:
            assert t.path is not None  # a file's target
            fd, tmp = _temporary(t.path, t.name)
            sink = _Sink(io.FileIO(fd, "wb"), t)
    except BrokenPipeError:
        raise
    except OSError as exc:
        if isinstance(exc, OutputError):
            raise
        raise _fail(t.name, exc) from None
    buf = io.BufferedWriter(sink, buffer_size=1 << 16)
    out = io.TextIOWrapper(buf, encoding="utf-8", newline="") if text else buf
    try:
        yield out
        out.flush()
        if tmp is not None:
            sink.sync()
        out.close()
        if tmp is not None:
            assert t.path is not None  # a temporary file is made for a file's target
            try:
                keep_mode(tmp, t.path)
                os.replace(tmp, t.path)
            except OSError as exc:
                raise _fail(t.name, exc) from None
            tmp = None
    except BaseException:
        sink.discard = True  # what is still buffered goes nowhere
        try:
            out.close()
        except OSError:
            pass
        if tmp is not None:
            try:
                os.unlink(tmp)
            except OSError:
                pass
        raise


@contextmanager
def replacing(target):
    """A temporary file name beside the file ``target``, for a writer that needs a name
    (GDAL, SQLite): when the ``with`` block ends without an error, the temporary file
    takes the permission bits of the file it replaces (of a new file where there is none)
    and replaces ``target`` atomically (a symbolic link is followed: the file it points to
    is replaced, beside which the temporary file is made, and the link stays); on an
    error it is removed and ``target`` is left as it was. The temporary file exists,
    empty, when the block starts. Raises :class:`~gloffset.errors.OutputError` naming
    ``target``."""
    name = os.fspath(target)
    t = _resolve(name)  # a symbolic link is followed: the file it points to is replaced
    path = t.path if t.kind == "replace" and t.path is not None else os.path.abspath(name)
    fd, tmp = _temporary(path, name)
    os.close(fd)
    try:
        yield tmp
        try:
            keep_mode(tmp, path)
            os.replace(tmp, path)
        except OSError as exc:
            raise _fail(name, exc) from None
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def write_bytes(target, data: bytes) -> None:
    """Write ``data`` to ``target`` (a path or ``-``) with :func:`open_output`."""
    with open_output(target) as fh:
        fh.write(data)
