"""The README is assembled from its sections and its test command is what CI runs."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _readme() -> str:
    path = ROOT / "README.md"
    if not path.exists():
        pytest.skip("README.md not in this checkout (installed-package test run)")
    return path.read_text()


def test_readme_is_assembled_from_its_sections():
    result = subprocess.run([sys.executable, str(ROOT / "scripts" / "build_readme.py"), "--check"],
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 0, "README.md is stale: run python scripts/build_readme.py"


def test_ci_runs_the_readme_test_command():
    readme = _readme()
    ci_lines = [line.strip() for line in (ROOT / ".ci" / "run").read_text().splitlines()
                if line.strip() and not line.lstrip().startswith("#")
                and not line.startswith(("set ", "cd "))]
    assert len(ci_lines) == 1, ci_lines
    assert f"    {ci_lines[0]}\n" in readme


def test_every_figure_the_readme_shows_is_committed():
    readme = _readme()
    for part in readme.split("](")[1:]:
        target = part.split(")", 1)[0]
        if target.endswith(".png"):
            assert (ROOT / target).is_file(), target
