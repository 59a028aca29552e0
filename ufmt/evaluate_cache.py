"""The disk cache of :func:`ufmt.evaluate`: one JSON file per evaluated case.

A record is stored as ``<dir>/<k[:2]>/<k>.json`` where ``k`` is the SHA-256 of its key (the
canonical JSON of what determines the result: the hinge values the design sets, the process,
the model's content hash and the physics code's hash). The file holds the key itself and the
outputs (numbers, non-finite ones as the strings "nan", "inf", "-inf"; the message as a string).
Reading it parses strict JSON and checks the shape and, through the caller's ``accept``, that
every value lies in its physical range (:func:`ufmt.evaluate.physical`: frequencies > 0,
PV, RMS and force >= 0, finite where the physics always gives a number); nothing in it is
executed, so a planted or tampered file can at worst give a wrong but physically possible
number for its own key, never run code. A file whose key, fields, types or ranges do not
match is ignored (recomputed and overwritten). Record files and two-character subdirectories
that are symbolic links are refused (the cache is then not used: one warning).

No HMAC: the directory is used only when it belongs to the user and no one else can write it
(below), so a record "written by someone else" can only come from the user's own processes;
a key file for an HMAC would sit in the same home directory, readable by exactly those
processes, and would add no protection against them while adding a secret to manage. The
range checks bound what a tampered record can do: a right-key record with plausible wrong
values (a PV times 5) is taken as written, as any file the user's own processes write is;
deleting the directory (or ``UFMT_CACHE_DIR=``) recomputes. Records are opened without
blocking and read only when they are regular files (a FIFO or device is a miss).

The directory is ``$UFMT_CACHE_DIR`` if set (the empty string switches the cache off), else
``$XDG_CACHE_HOME/ufmt`` or ``~/.cache/ufmt``. A directory that cannot be created or written,
is not a directory, belongs to another user or is writable by other users (group/world
writable without the sticky bit) is not used: one :class:`CacheWarning` and the run goes on
without the cache.
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import os
import stat
import tempfile
import warnings
from collections.abc import Callable, Mapping
from pathlib import Path

from ufmt import files

FORMAT = 1
_NON_FINITE = {"nan": math.nan, "inf": math.inf, "-inf": -math.inf}
_MAX_RECORD = 1 << 16  # bytes read of a record (a record is ~1 kB)
_broken: set[str] = set()  # directories that failed a write in this process
_warned: set[str] = set()  # cache warnings this process issued


class CacheWarning(UserWarning):
    """The evaluation cache cannot be used; results are computed without it."""


def location() -> str | None:
    """The configured cache directory (None: switched off)."""
    configured = os.environ.get("UFMT_CACHE_DIR")
    if configured is not None:
        return configured or None
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return str(Path(base) / "ufmt")


def directory() -> Path | None:
    """The usable cache directory, or None (switched off or unusable: warned once)."""
    try:
        where = location()
    except (RuntimeError, KeyError) as exc:  # no home directory to put the default cache in
        _warn("~/.cache/ufmt", exc)
        return None
    if where is None or where in _broken:
        return None
    return _usable(where)


@functools.cache
def _usable(where: str) -> Path | None:
    path = Path(where)
    try:
        if path.exists() and not path.is_dir():
            raise NotADirectoryError("not a directory")
        path.mkdir(parents=True, exist_ok=True)
        info = path.stat()
        if not stat.S_ISDIR(info.st_mode):
            raise NotADirectoryError("not a directory")
        if hasattr(os, "getuid") and info.st_uid != os.getuid():
            raise PermissionError("owned by another user")
        if info.st_mode & 0o022 and not info.st_mode & stat.S_ISVTX:
            raise PermissionError("writable by other users")
        with tempfile.NamedTemporaryFile(dir=path, prefix=".probe-"):
            pass
    except (OSError, RuntimeError) as exc:
        _warn(where, exc)
        return None
    return path


def _warn(where: str, exc: BaseException) -> None:
    reason = getattr(exc, "strerror", None) or str(exc) or type(exc).__name__
    warn_once(
        f"cache directory {where} is unusable ({reason}); running without the evaluation cache"
    )


def warn_once(message: str) -> None:
    """Issue the :class:`CacheWarning` ``message`` unless this process already did (a
    worker's cache failure is reported again by the main process, once)."""
    if message in _warned:
        return
    _warned.add(message)
    warnings.warn(message, CacheWarning, stacklevel=4)


def issued() -> frozenset[str]:
    """The messages :func:`warn_once` has issued in this process."""
    return frozenset(_warned)


def not_shown(messages) -> None:
    """Forget that ``messages`` were issued: a caller caught them without showing them (a
    study's chunk in the main process with one job), so the next :func:`warn_once` shows
    them."""
    _warned.difference_update(messages)


def key_digest(key: Mapping) -> str:
    """SHA-256 of the canonical JSON of ``key``."""
    return hashlib.sha256(_canonical(key).encode()).hexdigest()


def _canonical(key: Mapping) -> str:
    return json.dumps(key, sort_keys=True, separators=(",", ":"), allow_nan=False)


def _file(root: Path, key: Mapping) -> Path:
    digest = key_digest(key)
    return root / digest[:2] / f"{digest}.json"


def load(
    key: Mapping, names: tuple[str, ...], accept: Callable[[str, float], bool] | None = None
) -> dict | None:
    """The cached outputs (``names`` as floats, plus ``message``) for ``key``, or None.

    None also for a record that is not strict JSON (no ``NaN``/``Infinity`` literals), has
    other fields or types, or a value ``accept(name, value)`` refuses (the caller's physical
    ranges): such a record is recomputed and overwritten.
    """
    root = directory()
    if root is None:
        return None
    path = _file(root, key)
    if path.parent.is_symlink():
        _refuse_link(root, path.parent)
        return None
    try:
        data = json.loads(_read_no_follow(path), parse_constant=_not_strict)
    except (OSError, ValueError, RecursionError):
        return None
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        return None
    if _canonical(data.get("key", {})) != _canonical(key):
        return None
    stored = data.get("outputs")
    if not isinstance(stored, dict) or set(stored) != {*names, "message"}:
        return None
    if not isinstance(stored["message"], str):
        return None
    outputs = {}
    for name in names:
        value = stored[name]
        if isinstance(value, str) and value in _NON_FINITE:
            outputs[name] = _NON_FINITE[value]
        elif isinstance(value, int | float) and not isinstance(value, bool):
            outputs[name] = float(value)
        else:
            return None
        if accept is not None and not accept(name, outputs[name]):
            return None
    outputs["message"] = stored["message"]
    return outputs


def _not_strict(constant: str):
    raise ValueError(f"non-standard JSON constant {constant}")


def _read_no_follow(path: Path) -> str:
    """The text of ``path``, refusing a symbolic link or anything but a regular file (a
    planted FIFO or device): opened without blocking, checked before it is read."""
    fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_CLOEXEC | os.O_NONBLOCK)
    with open(fd, encoding="utf-8") as fh:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            raise OSError(f"{path.name} is not a regular file")
        return fh.read(_MAX_RECORD)


def _refuse_link(root: Path, link: Path) -> None:
    """Stop using the cache: ``link`` (a subdirectory) is a symbolic link."""
    _broken.add(str(root))
    _warn(str(root), OSError(f"{link.name} is a symbolic link; refusing to use it"))


def store(key: Mapping, outputs: Mapping) -> None:
    """Write ``outputs`` (floats and a ``message`` string) under ``key`` atomically."""
    root = directory()
    if root is None:
        return
    values = {
        k: v if isinstance(v, str) or math.isfinite(v) else repr(float(v))
        for k, v in outputs.items()
    }
    text = json.dumps({"format": FORMAT, "key": key, "outputs": values}, allow_nan=False)
    path = _file(root, key)
    if path.parent.is_symlink():
        _refuse_link(root, path.parent)
        return
    try:
        files.write_text(path, text)
    except OSError as exc:
        _broken.add(str(root))
        _warn(str(root), exc)
