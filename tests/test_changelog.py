"""CHANGELOG.md keeps the Keep a Changelog 1.1.0 shape: ``## [Unreleased]`` first, then
releases ``## [X.Y.Z] - YYYY-MM-DD``, newest first, each with its ``### `` sections once
and in the format's order, none of them empty."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CHANGELOG = ROOT / "CHANGELOG.md"
UNRELEASED = "## [Unreleased]"
RELEASE = re.compile(r"## \[(\d+)\.(\d+)\.(\d+)\] - (\d{4})-(\d{2})-(\d{2})")
SECTIONS = ("Added", "Changed", "Deprecated", "Removed", "Fixed", "Security")


def parse(text: str) -> list[tuple[str, list[tuple[str, list[str]]]]]:
    """The ``## `` headings after the title, each with its ``### `` sections and their
    lines (blank lines dropped); lines before a release's first section go under ``""``."""
    lines = text.splitlines()
    assert lines[0] == "# Changelog"
    releases: list[tuple[str, list[tuple[str, list[str]]]]] = []
    for line in lines[1:]:
        if line.startswith("## "):
            releases.append((line, [("", [])]))
        elif line.startswith("### "):
            assert releases, f"{line!r} before any release heading"
            releases[-1][1].append((line[4:], []))
        elif line.strip() and releases:
            releases[-1][1][-1][1].append(line)
    return releases


def problems(text: str) -> list[str]:
    """Each way ``text`` departs from the changelog's shape, one line each (none: it keeps it)."""
    found = []
    releases = parse(text)
    if not releases or releases[0][0] != UNRELEASED:
        found.append(f"the first heading is not {UNRELEASED!r}")
    versions = []
    for heading, sections in releases[1:]:
        match = RELEASE.fullmatch(heading)
        if match is None:
            found.append(f"{heading!r} is not '## [X.Y.Z] - YYYY-MM-DD'")
            continue
        versions.append(tuple(int(g) for g in match.groups()))
        names = [name for name, _ in sections[1:]]
        if len(set(names)) != len(names):
            found.append(f"{heading}: a section repeated in {names}")
        elif names != [name for name in SECTIONS if name in names]:  # an unknown name too
            found.append(f"{heading}: sections {names} not in the order {list(SECTIONS)}")
        if sections[0][1]:
            found.append(f"{heading}: lines before its first section")
        if not names:
            found.append(f"{heading}: no section")
        found += [f"{heading}: {name} is empty" for name, body in sections[1:] if not body]
        found += [
            f"{heading}: {name} has no item"
            for name, body in sections[1:]
            if body and not any(line.startswith("- ") for line in body)
        ]
    if versions != sorted(versions, reverse=True) or len(set(versions)) != len(versions):
        found.append("releases are not newest first, each once")
    return found


def test_changelog_keeps_its_shape():
    assert problems(CHANGELOG.read_text(encoding="utf-8")) == []


GOOD = """# Changelog

## [Unreleased]

## [0.2.0] - 2026-12-05

### Added
- a
### Fixed
- b

## [0.1.0] - 2026-11-22

### Added
- c
"""


@pytest.mark.parametrize(
    ("before", "after", "problem"),
    [
        ("## [Unreleased]\n", "", "the first heading is not '## [Unreleased]'"),
        ("## [0.1.0] - 2026-11-22", "## 0.1.0", "'## 0.1.0' is not '## [X.Y.Z] - YYYY-MM-DD'"),
        ("- b\n", "- b\n### Added\n- d\n", "## [0.2.0] - 2026-12-05: a section repeated"),
        ("### Added\n- a", "### Fixed\n- a", "## [0.2.0] - 2026-12-05: a section repeated"),
        ("### Fixed\n- b", "### Changes\n- b", "sections ['Added', 'Changes'] not in the order"),
        ("### Added\n- a\n### Fixed", "### Fixed\n- a\n### Added", "not in the order"),
        ("### Fixed\n- b\n", "### Fixed\n", "## [0.2.0] - 2026-12-05: Fixed is empty"),
        ("### Added\n- c\n", "", "## [0.1.0] - 2026-11-22: no section"),
        ("0.1.0] - 2026", "0.3.0] - 2026", "releases are not newest first, each once"),
    ],
)
def test_a_changelog_out_of_shape_is_named(before: str, after: str, problem: str):
    assert problems(GOOD) == []
    assert GOOD.count(before) == 1
    found = problems(GOOD.replace(before, after))
    assert len(found) == 1 and problem in found[0], found
