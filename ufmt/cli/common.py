"""Helpers shared by the sub-commands: the model argument and number types."""

from __future__ import annotations

import argparse


def load(path: str | None):
    """The model at ``path``, or the packaged UFMT."""
    from ufmt.model.load import load_model, packaged_path

    return load_model(path or packaged_path())


def positive(kind):
    """argparse type: a number of ``kind`` that must be > 0."""

    def parse(text):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        if not value > 0:
            raise argparse.ArgumentTypeError(f"{text} must be > 0")
        return value

    return parse
