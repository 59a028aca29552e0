"""Strict JSON output (RFC 8259): non-finite floats become ``null``, never ``NaN``/``Infinity``.

Every JSON the package writes (``--json`` output, ``meta.json``) goes through
:func:`dumps_strict`, so any standards-conforming parser reads it.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from typing import Any


def strict(value: Any) -> Any:
    """``value`` with every non-finite float (also inside containers, numpy scalars and
    arrays) replaced by None; other objects are returned as they are."""
    if hasattr(value, "tolist") and not isinstance(value, str | bytes):
        value = value.tolist()  # numpy arrays and scalars
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, Mapping):
        return {k: strict(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [strict(v) for v in value]
    return value


def dumps_strict(value: Any, **kwargs) -> str:
    """``json.dumps`` of :func:`strict` ``(value)`` with ``allow_nan=False``; objects JSON does
    not know are written as their ``str``."""
    kwargs.setdefault("default", str)
    return json.dumps(strict(value), allow_nan=False, **kwargs)
