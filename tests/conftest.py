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


# The real IGS stations live in ``_helpers`` (a module name no sub-folder's conftest shadows, so test modules
# can import it at collection time under pytest-xdist).
from _helpers import IGS_DIR, igs_station_catalogue  # noqa: E402,F401


@pytest.fixture(scope="session")
def igs_stations():
    """The real IGS stations by name (:class:`chronofuse.experiments.real_stations.RealStation`): each has
    ``obs_path``, ``nav_paths``, ``reference_m`` (published marker), ``reference_arp_m``, ``make``,
    ``observations()`` and ``navigation()`` (read once per process)."""
    return igs_station_catalogue()


def _install_debian_package(program: str, package: str) -> str:
    """The path of ``program``, installing Debian's ``package`` with apt-get when it is missing (CI runs as
    root on a clean machine: a test never skips because a part is missing)."""
    import fcntl
    import shutil
    import subprocess

    found = shutil.which(program)
    if found is None:
        env = {"DEBIAN_FRONTEND": "noninteractive", "PATH": "/usr/sbin:/usr/bin:/sbin:/bin"}
        with open("/tmp/chronofuse-apt.lock", "w") as lock:  # xdist workers install one at a time
            fcntl.flock(lock, fcntl.LOCK_EX)
            if shutil.which(program) is None:
                subprocess.run(["apt-get", "update", "-qq"], check=False, env=env, capture_output=True)
                subprocess.run(["apt-get", "install", "-y", "-qq", package], check=True, env=env, capture_output=True)
        found = shutil.which(program)
    if found is None:
        raise RuntimeError(f"{program} is still missing after apt-get install {package}")
    return found


@pytest.fixture(scope="session")
def rnx2rtkp():
    """RTKLIB's rnx2rtkp (Debian package rtklib), installed if missing."""
    return _install_debian_package("rnx2rtkp", "rtklib")
