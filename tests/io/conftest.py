"""Real receiver captures for the reader tests: ``tests/data/receivers`` when the full set has been copied
there, else the project's shared data (``$CHRONOFUSE_DATA/receivers`` or ``../shared/data/receivers``)."""

from __future__ import annotations

from pathlib import Path

import pytest
from _helpers import receivers_dir

@pytest.fixture(scope="session")
def receivers() -> Path:
    return receivers_dir()
