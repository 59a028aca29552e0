"""The last few values of an expensive function, by key: a small thread-safe memo.

Designs of one study share their structure (topology, stiffness-free parts of the assembled
and static models) and a process change reuses its design's modal basis; each of those is
kept here for the last few keys. Values are built outside the lock (a build may take long or
raise; two threads may then build the same value, which is harmless), and the least recently
used key is dropped first.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Hashable
from typing import TypeVar

T = TypeVar("T")
_MISSING = object()


class Recent:
    """Values of the last ``size`` keys asked for (dask workers may call from threads)."""

    def __init__(self, size: int):
        self.size = size
        self._values: dict = {}  # least recently used first
        self._lock = threading.Lock()

    def get(self, key: Hashable, build: Callable[[], T]) -> T:
        """The value kept for ``key``, or ``build()`` kept from now on."""
        with self._lock:
            value = self._values.pop(key, _MISSING)
        if value is _MISSING:
            value = build()
        with self._lock:
            self._values[key] = value
            while len(self._values) > self.size:
                del self._values[next(iter(self._values))]
        return value

    def __contains__(self, key: Hashable) -> bool:
        with self._lock:
            return key in self._values

    def __len__(self) -> int:
        return len(self._values)

    def clear(self) -> None:
        """Forget every value."""
        with self._lock:
            self._values.clear()
