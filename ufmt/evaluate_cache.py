"""The disk cache of :func:`ufmt.evaluate`: one JSON file per evaluated case.

A record is stored as ``<dir>/<k[:2]>/<k>.json`` where ``k`` is the SHA-256 of its key (the
canonical JSON of what determines the result: the hinge values the design sets, the process,
the model's content hash and the physics code's hash). The file holds the key itself and the
outputs (numbers, non-finite ones as the strings "nan", "inf", "-inf"; the message as a string).
Reading it parses JSON and checks the shape; nothing in it is executed, so a planted or
tampered file can at worst give a wrong number for its own key, never run code. A file whose
key, fields or types do not match is ignored (recomputed and overwritten).

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
from collections.abc import Mapping
from pathlib import Path

FORMAT = 1
_NON_FINITE = {"nan": math.nan, "inf": math.inf, "-inf": -math.inf}
_broken: set[str] = set()  # directories that failed a write in this process


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
    warnings.warn(
        f"cache directory {where} is unusable ({reason}); running without the evaluation cache",
        CacheWarning,
        stacklevel=3,
    )


def key_digest(key: Mapping) -> str:
    """SHA-256 of the canonical JSON of ``key``."""
    return hashlib.sha256(_canonical(key).encode()).hexdigest()


def _canonical(key: Mapping) -> str:
    return json.dumps(key, sort_keys=True, separators=(",", ":"), allow_nan=False)


def _file(root: Path, key: Mapping) -> Path:
    digest = key_digest(key)
    return root / digest[:2] / f"{digest}.json"


def load(key: Mapping, names: tuple[str, ...]) -> dict | None:
    """The cached outputs (``names`` as floats, plus ``message``) for ``key``, or None."""
    root = directory()
    if root is None:
        return None
    try:
        data = json.loads(_file(root, key).read_text(encoding="utf-8"))
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
    outputs["message"] = stored["message"]
    return outputs


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
    try:
        path.parent.mkdir(exist_ok=True)
        with tempfile.NamedTemporaryFile(
            "w", dir=path.parent, prefix=".tmp-", suffix=".json", delete=False, encoding="utf-8"
        ) as fh:
            fh.write(text)
        os.replace(fh.name, path)
    except OSError as exc:
        _broken.add(str(root))
        _warn(str(root), exc)
