"""Help, errors, code and docs refer to nothing outside the repository, and "seed" means a random seed.

The specification, the style notes and the issue tracker the project was built from are not shipped, so
"SPEC 4", "STYLE 5" or "issue 10.7" mean nothing to a reader; the three source papers are named by short
names defined once, with titles and references, in docs/sources.md.
"""

from __future__ import annotations

import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
BANNED = re.compile(r"\bSPEC(?: section)? [0-9]|\bSPEC\.md\b|\bSTYLE [0-9]|\bSTYLE\.md\b|\b[Ii]ssues? #?[0-9]"
                    r"|\b[Ss]eed 00[0-2]\b|\b[Ss]eed's\b|\bseed (?:documents?|experiments?|eqs?\.|table|figures?|claims?)\b")
#: The project's data store beside the clone: the tests' conftest and tests/data/README.md name it for
#: whoever adds a file; a user reads the copies in tests/data (or the package's data), never it.
OUTSIDE_PATHS = re.compile(r"\bshared/data\b|(?<![\w.])/tmp/[\w.-]+/[\w./-]*\.(?:pt|json|csv|parquet|png)\b")


def _texts():
    for pattern in ("src/**/*.py", "tests/**/*.py", "benchmarks/*.py", "docs/**/*.md", "docs/**/*.rst",
                    "docs/**/*.ipynb", "docs/**/*.json", "docs/*.py", "docs/_ext/*.py", "README.md", "CHANGELOG.md",
                    "scenarios/*.toml"):
        for path in REPO.glob(pattern):
            rel = path.relative_to(REPO).as_posix()
            if "egg-info" in rel or rel.startswith("tests/data/"):
                continue
            yield rel, path.read_text(encoding="utf-8")


def test_no_text_refers_to_documents_outside_the_repository_or_calls_a_paper_a_seed():
    hits = [f"{rel}:{text.count(chr(10), 0, m.start()) + 1}: {m.group(0)}" for rel, text in _texts()
            if rel != "tests/test_words.py" for m in BANNED.finditer(text)]
    assert hits == []


def test_the_banned_words_are_found_where_they_stand():
    # The check must be able to fail: each of these is a reference a reader cannot follow.
    for text in ("docs say (issue 10)", "see SPEC 4", "STYLE 5 says", "Issue 17, item 9", "issues 8",
                 "read ../shared/SPEC.md", "the seed 001 figures"):
        assert BANNED.search(text), text
    for text in ("the issue tracker", "an issue with 10 ns steps", "tissue 1", "seed 0", "SPECTRUM 4"):
        assert not BANNED.search(text), text
    assert OUTSIDE_PATHS.search("models: bp = /tmp/i19/models_keep/bp.pt")
    assert OUTSIDE_PATHS.search("tables in `shared/data/stability`")
    assert not OUTSIDE_PATHS.search("tables in `tests/data/stability`, out to swarm-models/bp.pt")


def test_docs_and_the_package_name_no_file_outside_the_repository():
    """Docs, README and the package (its help, errors and written reports) name files a user has: no
    model file under a temporary folder of the machine that wrote a document, no data store beside the
    clone. Commands that write into /tmp (``--out /tmp/...``) are fine: the user runs them."""
    hits = [f"{rel}:{text.count(chr(10), 0, m.start()) + 1}: {m.group(0)}" for rel, text in _texts()
            if not rel.startswith(("tests/", "benchmarks/")) for m in OUTSIDE_PATHS.finditer(text)]
    assert hits == []


def test_the_source_papers_are_named_once_with_title_and_reference():
    sources = (REPO / "docs" / "sources.md").read_text(encoding="utf-8")
    for title in ("Adaptive Frequency Disciplining Algorithm Based on Multi-Modal Information Fusion",
                  "High-Precision Clock Synchronization Algorithm for General Aviation Swarms",
                  "GNSS receiver clock-bias anomaly detection method and device"):
        assert sources.count(title) == 1, title
    assert "doi:10.12677/csa.2025.155122" in sources and "2026, 41(1): 89-108" in sources
