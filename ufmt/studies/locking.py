"""What guards a study run: an exclusive lock on its results directory, and SIGTERM turned
into KeyboardInterrupt (so a terminated run stops its workers and records itself as
interrupted, like Ctrl-C).
"""

from __future__ import annotations

import fcntl
import os
import signal
import stat
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from ufmt.errors import StudyError
from ufmt.studies.outputs import META, POINTS

LOCK = ".lock"
GUARDED = (POINTS, META)  # the files a run appends to or rewrites
_PID_WIDTH = 11  # bytes of the pid record at the start of the lock file


@contextmanager
def locked(out_dir: Path) -> Iterator[None]:
    """Hold an exclusive lock on ``out_dir/.lock`` (created with ``out_dir``) for the run.

    The lock file is opened without following a link and is never truncated (the holder's
    pid is written over its first bytes): a ``.lock`` planted as a symlink or a hard link to
    another file is refused, never written through. A results directory that is itself a
    symlink, or whose ``points.csv`` or ``meta.json`` is one, is refused too.

    Raises
    ------
    StudyError
        The directory cannot be created or written, holds links, or another run holds the lock.
    """
    try:
        if out_dir.is_symlink():
            raise StudyError(f"{out_dir}: is a symbolic link; refusing to write results through it")
        out_dir.mkdir(parents=True, exist_ok=True)
        refuse_links(out_dir, (LOCK, *GUARDED))
        flags = os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_CLOEXEC
        fd = os.open(out_dir / LOCK, flags, 0o666)
    except OSError as exc:
        reason = exc.strerror or type(exc).__name__
        raise StudyError(f"--results: cannot write {out_dir}: {reason}") from None
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode) or info.st_nlink != 1:
            raise StudyError(
                f"{out_dir / LOCK}: not a plain file of its own (a link to another file?);"
                " remove it and rerun"
            )
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, _PID_WIDTH, 0).decode("ascii", "replace").strip() or "?"
            raise StudyError(
                f"{out_dir}: another ufmt run (pid {holder}) is writing these results; wait for"
                " it to finish (its rows are then reused) or use --results"
            ) from None
        os.pwrite(fd, f"{os.getpid():>{_PID_WIDTH - 1}}\n".encode(), 0)
        try:
            yield
        finally:
            fcntl.flock(fd, fcntl.LOCK_UN)
    finally:
        os.close(fd)


def refuse_links(out_dir: Path, names) -> None:
    """Raise StudyError if any of ``names`` in ``out_dir`` is a symbolic link."""
    for name in names:
        if (out_dir / name).is_symlink():
            raise StudyError(
                f"{out_dir / name}: is a symbolic link; refusing to write results through it"
                " (remove it and rerun)"
            )


@contextmanager
def sigterm_interrupts() -> Iterator[None]:
    """Turn SIGTERM into KeyboardInterrupt while running (main thread only), so a terminated
    run stops its workers and records itself as interrupted, like Ctrl-C."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def interrupt(signum, frame):
        raise KeyboardInterrupt(f"signal {signum}")

    previous = signal.signal(signal.SIGTERM, interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)
