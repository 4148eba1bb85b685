"""CITATION.cff and CHANGELOG.md say the version the package is built as."""

import re
import tomllib
from pathlib import Path

ROOT = Path(__file__).parents[1]


def test_the_citation_and_the_changelog_name_the_packages_version():
    version = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]
    cff = (ROOT / "CITATION.cff").read_text()
    assert re.search(r'^version: "?([^"\n]+)"?$', cff, re.M).group(1) == version
    assert re.search(r"^cff-version: 1\.2\.0$", cff, re.M)
    assert f"version {version}" in (ROOT / "CHANGELOG.md").read_text()
