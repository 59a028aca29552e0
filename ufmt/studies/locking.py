"""What guards a study run: an exclusive lock on its results directory, and SIGTERM turned
into KeyboardInterrupt (so a terminated run stops its workers and records itself as
interrupted, like Ctrl-C).
"""

from __future__ import annotations

import fcntl
import os
import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from ufmt.errors import StudyError

LOCK = ".lock"


@contextmanager
def locked(out_dir: Path) -> Iterator[None]:
    """Hold an exclusive lock on ``out_dir/.lock`` (created with ``out_dir``) for the run.

    Raises
    ------
    StudyError
        The directory cannot be created or written, or another run holds the lock.
    """
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
        handle = (out_dir / LOCK).open("a+", encoding="utf-8")
    except OSError as exc:
        reason = exc.strerror or type(exc).__name__
        raise StudyError(f"--results: cannot write {out_dir}: {reason}") from None
    with handle:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            handle.seek(0)
            holder = handle.read().strip() or "?"
            raise StudyError(
                f"{out_dir}: another ufmt run (pid {holder}) is writing these results; wait for"
                " it to finish (its rows are then reused) or use --results"
            ) from None
        handle.seek(0)
        handle.truncate()
        handle.write(f"{os.getpid()}\n")
        handle.flush()
        try:
            yield
        finally:
            handle.seek(0)
            handle.truncate()
            fcntl.flock(handle, fcntl.LOCK_UN)


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
