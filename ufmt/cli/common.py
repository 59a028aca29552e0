"""Helpers shared by the sub-commands: the model argument and number types."""

from __future__ import annotations

import argparse
import math
from pathlib import Path


def load(path: str | None):
    """The model at ``path``, or the packaged UFMT."""
    from ufmt.model.load import load_model, packaged_path

    return load_model(path or packaged_path())


def positive(kind, below=None, at_most=None, at_least=None, even=False):
    """argparse type: a finite number of ``kind`` that must be > 0 (and < ``below``, <=
    ``at_most``, >= ``at_least`` if given; even if ``even``)."""

    def parse(text):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        if not (value > 0 and math.isfinite(value)):
            raise argparse.ArgumentTypeError(f"{text} must be a finite number > 0")
        if below is not None and not value < below:
            raise argparse.ArgumentTypeError(f"{text} must be < {below:g}")
        if at_most is not None and not value <= at_most:
            raise argparse.ArgumentTypeError(f"{text} must be <= {at_most:g}")
        if at_least is not None and not value >= at_least:
            raise argparse.ArgumentTypeError(f"{text} must be >= {at_least:g}")
        if even and value % 2:
            raise argparse.ArgumentTypeError(f"{text} must be even")
        return value

    return parse


def results_dir(model_path: str | None, kind: str, packaged: Path) -> Path:
    """Default output folder of a command: ``packaged`` for the packaged model (no path given),
    else ``results/<model file name>/<kind>/``, so a user's model never writes over the
    packaged model's results."""
    return packaged if model_path is None else Path("results") / Path(model_path).stem / kind
