"""Test helpers shared across the suite (importable as ``_helpers``: tests/ is on pythonpath)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

# The one Stable32 table reader, the library's (re-exported: the tests import it from here).
from chronofuse.io.stable32 import read_stable32_table  # noqa: F401


def assert_close_printed(ours, table, rel_digits: int = 5, name: str = ""):
    """Assert equality to the printed precision of a Stable32 table (5 significant digits: rel 1e-4/2 rounding)."""
    ours = np.asarray(ours, dtype=float)
    table = np.asarray(table, dtype=float)
    # A value printed as d.dddde-xx is within half a unit of its last digit.
    tol = 0.5 * 10.0 ** (np.floor(np.log10(np.abs(table))) - (rel_digits - 1))
    bad = np.abs(ours - table) > tol * 1.0001
    assert not bad.any(), f"{name}: ours {ours[bad]} vs table {table[bad]} (tol {tol[bad]})"


_REPO = Path(__file__).resolve().parents[1]


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


#: The two real Trimble 5700 stations of RTKLIB's sample data (RINEX 2.10, 120 epochs at 30 s, C1 and P2,
#: with their broadcast navigation files): the ``trimble`` fixture of tests/integrity reads them.
TRIMBLE_STATIONS = ("07590920", "30400920")


#: The real IGS stations (24 h, 30 s, multi-GNSS RINEX 3 with same-day navigation and published coordinates):
#: ``tests/data/rinex/igs`` and its ``stations.toml``; see that folder's README.md.
IGS_DIR = _REPO / "tests" / "data" / "rinex" / "igs"


def igs_station_catalogue():
    """``{name: RealStation}`` of the shipped IGS stations (for module-level parametrisation)."""
    from chronofuse.experiments.real_stations import load_stations

    return load_stations(IGS_DIR)


def command_tree() -> dict:
    """Every leaf subcommand of the program, ``"swarm sweep"`` -> its click command (from the full tree)."""
    import typer

    from chronofuse.cli.main import build_app

    def leaves(group, path=()):
        for name, sub in getattr(group, "commands", {}).items():
            if hasattr(sub, "commands"):
                yield from leaves(sub, (*path, name))
            else:
                yield " ".join((*path, name)), sub

    return dict(leaves(typer.main.get_command(build_app())))


def option_type(param) -> type:
    """An option's value type: ``float`` for ``float | None``, ``Path`` for ``list[Path]`` (a repeatable one)."""
    import types
    import typing

    kind = param.type_descriptor.annotation
    while typing.get_origin(kind) in (typing.Union, types.UnionType, list):
        kind = next(a for a in typing.get_args(kind) if a is not type(None))
    return kind
