"""Real receiver captures for the reader tests: ``tests/data/receivers`` when the full set has been copied
there, else the project's shared data (``$CHRONOFUSE_DATA/receivers`` or ``../shared/data/receivers``)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

_REPO = Path(__file__).resolve().parents[2]


def receivers_dir() -> Path:
    """Folder holding ``gpsd/``, ``ubx/`` and ``rinex/`` of real receiver captures."""
    candidates = [_REPO / "tests" / "data" / "receivers"]
    if "CHRONOFUSE_DATA" in os.environ:
        candidates.append(Path(os.environ["CHRONOFUSE_DATA"]) / "receivers")
    candidates += [_REPO.parent / "shared" / "data" / "receivers", _REPO.parents[1] / "shared" / "data" / "receivers"]
    for path in candidates:
        # the full set the oracle test runs over (a partial copy, e.g. a few files for other tests, is skipped)
        if (path / "gpsd").is_dir() and sum(1 for _ in (path / "gpsd").glob("*.log")) >= 199:
            return path
    raise RuntimeError(f"receiver captures not found (looked in {', '.join(map(str, candidates))})")


@pytest.fixture(scope="session")
def receivers() -> Path:
    return receivers_dir()
