"""Shared test fixtures: where the real data lives."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


def shared_data_dir() -> Path:
    """The project's real data (``../shared/data`` beside the checkout, or $CHRONOFUSE_DATA)."""
    path = Path(os.environ.get("CHRONOFUSE_DATA", REPO.parent / "shared" / "data"))
    if not path.is_dir():
        raise RuntimeError(f"real test data not found at {path}; set CHRONOFUSE_DATA")
    return path


@pytest.fixture(scope="session")
def data_dir() -> Path:
    return shared_data_dir()
