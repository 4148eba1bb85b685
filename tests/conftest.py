"""Shared test fixtures: the real data the tests read, shipped in ``tests/data``.

Every real record a test reads lives in ``tests/data/`` under the same relative path as in the project's
data store (``../shared/data``: ``stability/gps/...``, ``receivers/rinex/rtklib/...``), each source folder
with its licence beside it, so that ``make test`` passes on a bare clone. Only files a test reads are
shipped; large text files are gzipped where the reader accepts ``.gz``.

To use real data in a test, take the ``real_data`` fixture (``data_dir`` is the same folder under its old
name) and join the relative path::

    def test_something(real_data):
        x = np.loadtxt(real_data / "stability" / "gps" / "gps_1pps_phase_data.txt.gz")

A new file: copy it from ``../shared/data`` into ``tests/data`` under the same relative path (with its
source's licence file if the folder is new, and a line in ``tests/data/README.md``). Outside a fixture
(module-level helpers), call :func:`real_data_dir`.
"""

from __future__ import annotations

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
REAL_DATA = Path(__file__).resolve().parent / "data"


def real_data_dir() -> Path:
    """``tests/data``: the real records the tests read, shipped with the repository."""
    if not REAL_DATA.is_dir():
        raise RuntimeError(f"the test data folder {REAL_DATA} is missing from this checkout")
    return REAL_DATA


# The former name, kept so that tests written before the data moved in still run.
shared_data_dir = real_data_dir


@pytest.fixture(scope="session")
def real_data() -> Path:
    """``tests/data`` (see the module docstring)."""
    return real_data_dir()


@pytest.fixture(scope="session")
def data_dir(real_data) -> Path:
    """The same folder as :func:`real_data`, under the name the older tests use."""
    return real_data
