"""The process environment the CLI prepares before any command: a writable matplotlib
configuration directory, so a read-only home directory costs no multi-line warning."""

from __future__ import annotations

import os
import stat
import tempfile
from pathlib import Path


def matplotlib_config_dir() -> None:
    """Set ``MPLCONFIGDIR`` to a private directory under the temporary folder when it is not
    set and matplotlib's default (``$XDG_CONFIG_HOME/matplotlib`` or
    ``~/.config/matplotlib``) cannot be written; matplotlib would otherwise print a warning of
    several lines and build its font cache in a new temporary directory on every run."""
    if os.environ.get("MPLCONFIGDIR"):
        return
    try:
        base = os.environ.get("XDG_CONFIG_HOME") or str(Path.home() / ".config")
    except RuntimeError:  # no home directory
        base = ""
    if base and _writable(Path(base) / "matplotlib"):
        return
    private = Path(tempfile.gettempdir()) / f"ufmt-matplotlib-{os.getuid()}"
    try:
        private.mkdir(mode=0o700, exist_ok=True)
        info = private.lstat()
        if not stat.S_ISDIR(info.st_mode) or info.st_uid != os.getuid():
            return  # someone else's: leave matplotlib to its own fallback
    except OSError:
        return
    os.environ["MPLCONFIGDIR"] = str(private)


def _writable(directory: Path) -> bool:
    """Whether ``directory`` exists and is writable, or can be created."""
    for candidate in (directory, *directory.parents):
        if candidate.exists():
            return candidate.is_dir() and os.access(candidate, os.W_OK | os.X_OK)
    return False
