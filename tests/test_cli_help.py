"""The command line as a new user meets it: --version, bare `ufmt`, the top-level help
(oracle: the registered sub-parsers and the package version)."""

from __future__ import annotations

import re
import subprocess
import sys

import pytest

import ufmt
from ufmt.cli import build_parser, main


def test_version(capsys):
    with pytest.raises(SystemExit) as stop:
        main(["--version"])
    assert stop.value.code == 0
    assert capsys.readouterr().out.strip() == f"ufmt {ufmt.__version__}"


def test_bare_ufmt_prints_help_and_exits_0():
    run = subprocess.run([sys.executable, "-m", "ufmt.cli"], capture_output=True, text=True)
    assert run.returncode == 0 and run.stderr == ""
    assert run.stdout.startswith("usage: ufmt")


def test_top_level_help_lists_every_command_in_plain_text():
    parser = build_parser()
    text = parser.format_help()
    commands = next(a for a in parser._actions if a.dest == "command").choices
    assert {"validate", "report", "plot-mode", "run"} <= set(commands)
    for name in commands:
        assert re.search(rf"^\s+{re.escape(name)}\s+\S", text, re.MULTILINE), name
    assert "``" not in text and ":mod:" not in text
