"""`make docs` builds the documentation site offline: every page, the API reference from the
docstrings and the changelog, with no warning (``--strict``: a broken link or an unresolved
reference fails the build)."""

from __future__ import annotations

import html
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]

pytest.importorskip("mkdocs")
pytest.importorskip("mkdocstrings")


def test_site_builds_strict_with_api_and_changelog(tmp_path):
    site = tmp_path / "site"
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
    run = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(site)],
        cwd=REPO,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert run.returncode == 0, run.stderr[-2000:]
    assert (site / "index.html").is_file()
    api_html = (site / "api.html").read_text(encoding="utf-8")
    api = " ".join(html.unescape(re.sub(r"<[^>]+>", "", api_html)).split())
    # the reference is generated from the docstrings: each entry point's own first sentence
    import ufmt

    for name in ("simulate", "evaluate", "load_model", "frf", "read_surface"):
        summary = " ".join(getattr(ufmt, name).__doc__.strip().split("\n\n")[0].split())
        assert summary.replace("`", "")[:50] in api, name
    changelog = (site / "changelog.html").read_text(encoding="utf-8")
    assert "Unreleased" in changelog
