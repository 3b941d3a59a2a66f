"""The README is built from its template, its test command is what CI runs, and it is a short
front page whose links (and those of the docs/ pages) resolve."""
from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
MAX_README_LINES = 200
PAGES_THE_README_LINKS = ("simulation.md", "study.md", "identification.md", "robots.md",
                          "physics.md", "interfaces.md", "dataset-format.md")
# [text](target) and ![alt](target); a target ends at whitespace or ")".
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")


def _readme() -> str:
    path = ROOT / "README.md"
    if not path.exists():
        pytest.skip("README.md not in this checkout (installed-package test run)")
    return path.read_text()


def _relative_link_targets(text: str) -> list[str]:
    """Link targets outside code blocks and code spans, without #anchors; web links left out."""
    text = re.sub(r"```.*?```", "", text, flags=re.S)
    text = re.sub(r"`[^`\n]*`", "", text)
    targets = []
    for target in LINK.findall(text):
        if target.startswith(("http://", "https://", "mailto:", "#")):
            continue
        targets.append(target.split("#", 1)[0])
    return targets


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


def test_readme_is_a_short_front_page():
    lines = _readme().splitlines()
    assert len(lines) <= MAX_README_LINES, (
        f"README.md has {len(lines)} lines; move detail into a page under docs/")


def test_every_relative_link_resolves():
    readme = _readme()
    documents = [(ROOT / "README.md", readme)]
    documents += [(page, page.read_text()) for page in sorted((ROOT / "docs").glob("*.md"))
                  if page.name != "readme_template.md"]  # its links are the README's
    broken = []
    for path, text in documents:
        for target in _relative_link_targets(text):
            if target and not (path.parent / target).exists():
                broken.append(f"{path.relative_to(ROOT)}: {target}")
    assert not broken, broken


def test_readme_links_every_docs_page():
    linked = {(ROOT / target).resolve() for target in _relative_link_targets(_readme())}
    missing = [name for name in PAGES_THE_README_LINKS
               if (ROOT / "docs" / name).resolve() not in linked]
    assert not missing, f"README.md does not link docs/{missing}"
