"""Writing outputs so that nothing is lost: every file the package writes goes through here.

A file is written whole or not at all: its bytes go to a temporary file in the same
directory (``.<name>.<pid>.<random>.tmp``, created exclusively, never through a link), are
fsynced, and the temporary file is renamed over the target in one ``os.replace`` (the
directory is fsynced after it). A failure at any point (a full disk, a permission) leaves the
previous good file as it was and removes the temporary file; a kill -9 leaves the previous
file too, and its temporary file is removed by the next write of the same target (its pid is
gone). The target itself is never opened: a planted symlink at its name is replaced, never
followed.

A set of files (``simulate --save``, the plot sets) is written with :class:`FileSet`: every
member is staged first in a sibling folder and only then put in place, so a failure while
staging changes nothing. Into a directory that does not exist yet, the staged folder is renamed
into place; into one that holds nothing but the set's files, the two folders are exchanged in
one step (:func:`exchange`); either way a kill -9 leaves the old set or the new one, whole.
Where the directory holds other files too, the members are renamed one by one (module doc of
:class:`FileSet`). A killed writer's staging folder is removed by the next set written there.

An append-only log (a study's points.csv) appends each record with one ``os.write`` through
:func:`open_append` and :func:`append`.

Errors come out as :class:`~ufmt.errors.OutputError` (an ``OSError`` and a user error: the
CLI prints it as one line naming the path).
"""

from __future__ import annotations

import ctypes
import errno
import functools
import glob
import io
import os
import secrets
import shutil
import stat
import sys
from collections.abc import Callable
from pathlib import Path

from ufmt.errors import OutputError

_TMP_SUFFIX = ".tmp"
_NOFOLLOW = getattr(os, "O_NOFOLLOW", 0)
_AT_FDCWD = -100  # <fcntl.h>: a path relative to the working directory
_RENAME_EXCHANGE = 2  # renameat2 flag, <linux/fs.h>
_NO_EXCHANGE = {errno.EINVAL, errno.ENOSYS, errno.EOPNOTSUPP, errno.EXDEV}  # fall back


def write_bytes(path: str | os.PathLike, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically (module doc); parent folders are created."""
    path = Path(path)
    try:
        _refuse_directory(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        _atomic_write(path, data)
    except OutputError:
        raise
    except OSError as exc:
        raise output_error(path, exc) from None
    return path


def write_text(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` as UTF-8 to ``path`` atomically."""
    return write_bytes(path, text.encode("utf-8"))


def write_with(path: str | os.PathLike, writer: Callable[[io.BytesIO], object]) -> Path:
    """Write what ``writer(buffer)`` puts into a bytes buffer to ``path`` atomically (e.g.
    ``lambda b: table.to_csv(b, index=False)``)."""
    buffer = io.BytesIO()
    writer(buffer)
    return write_bytes(path, buffer.getvalue())


def figure_png(fig, dpi: int) -> bytes:
    """The PNG bytes of a matplotlib figure."""
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=dpi)
    return buffer.getvalue()


def open_append(path: str | os.PathLike) -> int:
    """A descriptor appending to ``path`` (created if absent), never through a symlink."""
    flags = os.O_WRONLY | os.O_APPEND | os.O_CREAT | _NOFOLLOW | getattr(os, "O_CLOEXEC", 0)
    try:
        return os.open(path, flags, 0o666)
    except OSError as exc:
        raise output_error(Path(path), exc) from None


def append(fd: int, data: bytes, path: str | os.PathLike) -> None:
    """Append ``data`` (one record of a log) to the descriptor of :func:`open_append`; a
    failure raises :class:`OutputError` naming ``path`` (what was cut off is a partial line,
    which the log's reader drops)."""
    try:
        _write_all(fd, data)
    except OSError as exc:
        raise output_error(Path(path), exc) from None


def output_error(path: Path, exc: OSError) -> OutputError:
    """An :class:`OutputError` naming ``path`` and the reason of ``exc``."""
    reason = exc.strerror or str(exc) or type(exc).__name__
    error = OutputError(exc.errno, f"cannot write {path}: {reason}")
    error.filename = str(path)
    return error


def _refuse_directory(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        raise IsADirectoryError(errno.EISDIR, "is a directory, not a file")


def _atomic_write(path: Path, data: bytes) -> None:
    """The write itself (see the module doc)."""
    directory = path.parent
    _sweep(directory, path.name)
    staged = _temporary_name(directory, path.name)
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | _NOFOLLOW | getattr(os, "O_CLOEXEC", 0)
    fd = os.open(staged, flags, 0o666)
    try:
        try:
            _write_all(fd, data)
            os.fsync(fd)
        finally:
            os.close(fd)
        os.replace(staged, path)
    except BaseException:
        _remove_quietly(staged)
        raise
    _sync_directory(directory)


def _temporary_name(directory: Path, name: str) -> Path:
    """``.<name>.<pid>.<random>.tmp`` next to the target (the pid lets a later write tell a
    killed writer's leftover from a live writer's file)."""
    return directory / f".{name}.{os.getpid()}.{secrets.token_hex(4)}{_TMP_SUFFIX}"


def _sweep(directory: Path, name: str) -> None:
    """Remove the temporary files and staging folders of ``name`` that killed writers left
    (their pid is gone)."""
    try:
        leftovers = list(directory.glob(f".{glob.escape(name)}.*.*{_TMP_SUFFIX}"))
    except OSError:
        return
    for leftover in leftovers:
        pid = leftover.name[len(name) + 2 :].split(".")[0]
        if pid.isdigit() and int(pid) != os.getpid() and not _alive(int(pid)):
            if leftover.is_dir() and not leftover.is_symlink():  # a FileSet's staging folder
                shutil.rmtree(leftover, ignore_errors=True)
            else:
                _remove_quietly(leftover)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:
        return True  # another user's process
    return True


def _write_all(fd: int, data: bytes) -> None:
    """``os.write`` until every byte is written (the one place bytes reach the disk)."""
    view = memoryview(data)
    while view:
        written = os.write(fd, view)
        view = view[written:]


def _sync_directory(directory: Path) -> None:
    """fsync the directory so the rename itself survives a power loss (best effort)."""
    try:
        fd = os.open(directory, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def _remove_quietly(path: Path) -> None:
    try:
        os.unlink(path)
    except OSError:
        pass


def check_set_target(directory: str | os.PathLike | None) -> None:
    """Raise :class:`OutputError` now if ``directory`` (a :class:`FileSet`'s, None: no
    output) exists and is not a directory: a command checks before it computes."""
    if directory is not None and Path(directory).exists() and not Path(directory).is_dir():
        raise OutputError(errno.EEXIST, f"cannot write {directory}: exists and is not a directory")


def exchange(a: str | os.PathLike, b: str | os.PathLike) -> bool:
    """Swap the paths ``a`` and ``b`` (two existing files or folders on one file system) in one
    step: Linux ``renameat2(RENAME_EXCHANGE)``. False, with nothing changed, where the system or
    the file system has no such call; any other failure raises ``OSError``."""
    renameat2 = _renameat2()
    if renameat2 is None:
        return False
    if renameat2(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE) == 0:
        return True
    code = ctypes.get_errno()
    if code in _NO_EXCHANGE:
        return False
    raise OSError(code, os.strerror(code), os.fspath(b))


@functools.cache
def _renameat2():
    """The C library's ``renameat2`` (glibc 2.28+), or None."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        function = ctypes.CDLL(None, use_errno=True).renameat2
    except (OSError, AttributeError):
        return None
    function.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p]
    function.argtypes += [ctypes.c_uint]
    function.restype = ctypes.c_int
    return function


class FileSet:
    """Files written as a set into ``directory``: :meth:`add` (or a writer given
    :meth:`staged`) stages each, nothing visible yet; leaving the ``with`` block puts them all
    in place; the set is lost as a whole on a failure.

    The members are staged in a sibling folder ``.<directory>.<pid>.<random>.tmp``. Into a
    directory that does not exist, that folder is renamed into place. Into one that holds
    nothing but members of this set, the two folders are exchanged in one step
    (:func:`exchange`) and the old one is removed: a kill -9 leaves the old set or the new
    one, whole. Into one that holds other files too (e.g. results/validation/ with
    reference-process/ inside), or where the system cannot exchange, the members are renamed
    one by one (microseconds apart; ``manifest``, the file that describes the set, last): a
    kill between two renames can leave old and new members mixed, but a new manifest means
    every member is new; the other files are left alone. The staging folder of a killed
    writer (its pid gone) is removed by the next set written to ``directory``. Use as a
    context manager: leaving it by an exception removes every staged file.
    """

    def __init__(self, directory: str | os.PathLike, manifest: str | None = None):
        self.directory = Path(directory)
        self.manifest = manifest
        self._names: list[str] = []
        self._stage: Path | None = None
        self._new = False

    def __enter__(self) -> FileSet:
        path = self.directory
        try:
            if path.exists() and not path.is_dir():
                raise FileExistsError(errno.EEXIST, "exists and is not a directory")
            self._new = not path.exists()
            path.parent.mkdir(parents=True, exist_ok=True)
            self._stage = _make_stage(path, self._new)
        except OSError as exc:
            raise output_error(path, exc) from None
        return self

    def add(self, name: str, data: bytes) -> Path:
        """Stage ``data`` as ``name``; returns the path it will have."""
        write_bytes(self.staged(name), data)
        return self.directory / name

    def staged(self, name: str) -> Path:
        """Where to write member ``name`` now (any writer; it is put in place on commit)."""
        assert self._stage is not None, "use FileSet as a context manager"
        if name not in self._names:
            self._names.append(name)
        return self._stage / name

    def __exit__(self, kind, value, traceback) -> None:
        try:
            if kind is None:
                self._commit()
        finally:  # the staged files, or after an exchange the old set
            if self._stage is not None and self._stage.exists():
                shutil.rmtree(self._stage, ignore_errors=True)

    def _commit(self) -> None:
        try:
            if self._new:
                os.rename(self._stage, self.directory)
                self._stage = None
                _sync_directory(self.directory.parent)
            elif self._holds_only_the_set() and self._exchange():
                _sync_directory(self.directory.parent)
            else:
                self._rename_members()
        except OSError as exc:
            raise output_error(self.directory, exc) from None

    def _holds_only_the_set(self) -> bool:
        """Whether the existing directory is a real folder, a sibling of the staging folder,
        whose entries are all members of this set (so exchanging loses nothing)."""
        target = self.directory
        if target.is_symlink() or self._stage.parent != target.parent:
            return False
        return set(os.listdir(target)) <= set(self._names)

    def _exchange(self) -> bool:
        """Exchange the staging folder (given the directory's mode) with the directory."""
        os.chmod(self._stage, stat.S_IMODE(os.stat(self.directory).st_mode))
        return exchange(self._stage, self.directory)

    def _rename_members(self) -> None:
        names = [n for n in self._names if n != self.manifest]
        names += [n for n in self._names if n == self.manifest]
        for name in names:
            _refuse_directory(self.directory / name)
            os.replace(self._stage / name, self.directory / name)
        _sync_directory(self.directory)


def _make_stage(directory: Path, new: bool) -> Path:
    """The staging folder of a set bound for ``directory``, made after sweeping the killed
    writers' ones: a sibling of it, or inside an existing directory where a sibling is not
    possible (the parent is read-only, or the directory is a mount point)."""
    homes = [directory.parent]
    if not new:
        mount_point = os.stat(directory).st_dev != os.stat(directory.parent).st_dev
        homes = [directory] if mount_point else [directory.parent, directory]
        _sweep(directory, directory.name)
    _sweep(directory.parent, directory.name)
    for home in homes[:-1]:
        try:
            return _new_folder(_temporary_name(home, directory.name))
        except OSError:
            pass
    return _new_folder(_temporary_name(homes[-1], directory.name))


def _new_folder(path: Path) -> Path:
    path.mkdir()
    return path
