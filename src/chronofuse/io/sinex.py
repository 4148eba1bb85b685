"""Station coordinates of a SINEX solution file (IGS/EUREF combined or analysis-centre solutions).

SINEX 2.02 (IERS/IGS, 2006), block ``SOLUTION/ESTIMATE``: one line per parameter, fields ``index``,
``type`` (``STAX``/``STAY``/``STAZ`` for the station position in metres), ``code`` (4-character site),
``PT``, ``SOLN``, ``REF_EPOCH`` (``yy:ddd:sssss``), ``unit``, ``S``, estimate, standard deviation. The position
is that of the marker; ``SITE/ECCENTRICITY`` gives the antenna reference point above it (up, north, east),
the same offsets as a RINEX header's ``ANTENNA: DELTA H/E/N``.
"""

from __future__ import annotations

import gzip
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from chronofuse.validation import InputDataError

__all__ = ["SinexStation", "read_sinex_stations"]


@dataclass(frozen=True)
class SinexStation:
    """One site: ``position_m`` (3,) ECEF of the marker, ``sigma_m`` (3,), ``epoch`` (``yy:ddd:sssss``),
    ``eccentricity_une_m`` (3,) of the antenna reference point (zeros when the file gives none)."""

    code: str
    position_m: np.ndarray
    sigma_m: np.ndarray
    epoch: str
    eccentricity_une_m: np.ndarray


def _lines(path: Path) -> list[str]:
    try:
        with (gzip.open(path, "rt", errors="replace") if path.suffix == ".gz" else open(path, errors="replace")) as f:
            return f.read().splitlines()
    except (OSError, EOFError) as exc:
        raise InputDataError(f"cannot read file: {exc}", str(path)) from exc


def read_sinex_stations(path) -> dict[str, SinexStation]:
    """Every site with all of ``STAX``, ``STAY``, ``STAZ`` in ``SOLUTION/ESTIMATE`` (module docstring).

    Raises :class:`InputDataError` naming the file when it is not SINEX (first line ``%=SNX``) or has no
    station position."""
    path = Path(path)
    if not path.is_file():
        raise InputDataError("no such file", str(path))
    lines = _lines(path)
    if not lines or not lines[0].startswith("%=SNX"):
        raise InputDataError("not a SINEX file (no %=SNX first line)", str(path))
    block = None
    est: dict[str, dict[str, tuple[float, float, str]]] = {}
    ecc: dict[str, np.ndarray] = {}
    for number, line in enumerate(lines, start=1):
        if line.startswith("+"):
            block = line[1:].strip()
            continue
        if line.startswith("-"):
            block = None
            continue
        if line.startswith("*") or block is None:
            continue
        parts = line.split()
        try:
            if block == "SOLUTION/ESTIMATE" and len(parts) >= 10 and parts[1] in ("STAX", "STAY", "STAZ"):
                est.setdefault(parts[2], {})[parts[1]] = (float(parts[8]), float(parts[9]), parts[5])
            elif block == "SITE/ECCENTRICITY" and len(parts) >= 9 and parts[6] == "UNE":
                ecc[parts[0]] = np.array([float(v) for v in parts[7:10]])
        except ValueError:
            raise InputDataError(f"line {number}: unreadable {block} record", str(path)) from None
    out = {}
    for code, comp in est.items():
        if len(comp) < 3:
            continue
        xyz = [comp[k] for k in ("STAX", "STAY", "STAZ")]
        out[code] = SinexStation(code=code, position_m=np.array([v[0] for v in xyz]),
                                 sigma_m=np.array([v[1] for v in xyz]), epoch=xyz[0][2],
                                 eccentricity_une_m=ecc.get(code, np.zeros(3)))
    if not out:
        raise InputDataError("no station position (STAX/STAY/STAZ) in SOLUTION/ESTIMATE", str(path))
    return out
