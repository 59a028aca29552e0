"""Model text with ``[machine]`` keys set: the key's existing line (if any) is dropped and the
new value written at the top of the table, so a key the calibrated file already holds is
replaced, not written twice (which TOML refuses)."""

from __future__ import annotations

import re


def set_machine_keys(text: str, **keys) -> str:
    """``text`` (a model file) with each ``[machine]`` key of ``keys`` set to its value
    (written as given: a float, or a string holding a TOML value such as ``"nan"``)."""
    for key in keys:
        text = re.sub(rf"(?m)^{re.escape(key)}\s*=.*\n", "", text)
    lines = "".join(f"{key} = {value}\n" for key, value in keys.items())
    return re.sub(r"(?m)^\[machine\]\n", lambda m: m.group(0) + lines, text, count=1)
