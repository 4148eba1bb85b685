"""Help, errors, code and docs refer to nothing outside the repository, and "seed" means a random seed.

The specification, the style notes and the issue tracker the project was built from are not shipped, so
"SPEC 4", "STYLE 5" or "issue 10.7" mean nothing to a reader; the three source papers are named by short
names defined once, with titles and references, in docs/sources.md.
"""

from __future__ import annotations

import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
BANNED = re.compile(r"\bSPEC(?: section)? [0-9]|\bSTYLE [0-9]|\bissue 10\.[0-9]|\b[Ss]eed 00[0-2]\b|\b[Ss]eed's\b"
                    r"|\bseed (?:documents?|experiments?|eqs?\.|table|figures?|claims?)\b")


def _texts():
    for pattern in ("src/**/*.py", "tests/**/*.py", "benchmarks/*.py", "docs/**/*.md", "README.md", "scenarios/*.toml"):
        for path in REPO.glob(pattern):
            rel = path.relative_to(REPO).as_posix()
            if "egg-info" in rel or rel.startswith("tests/data/"):
                continue
            yield rel, path.read_text(encoding="utf-8")


def test_no_text_refers_to_documents_outside_the_repository_or_calls_a_paper_a_seed():
    hits = [f"{rel}:{text.count(chr(10), 0, m.start()) + 1}: {m.group(0)}" for rel, text in _texts()
            if rel != "tests/test_words.py" for m in BANNED.finditer(text)]
    assert hits == []


def test_the_source_papers_are_named_once_with_title_and_reference():
    sources = (REPO / "docs" / "sources.md").read_text(encoding="utf-8")
    for title in ("Adaptive Frequency Disciplining Algorithm Based on Multi-Modal Information Fusion",
                  "High-Precision Clock Synchronization Algorithm for General Aviation Swarms",
                  "GNSS receiver clock-bias anomaly detection method and device"):
        assert sources.count(title) == 1, title
    assert "doi:10.12677/csa.2025.155122" in sources and "2026, 41(1): 89-108" in sources
