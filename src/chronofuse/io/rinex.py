"""RINEX 2/3 GPS observation (pseudoranges) and navigation (broadcast ephemeris) files, read with georinex.

Time scale. RINEX GPS observation and GPS navigation epochs are GPS time (no leap seconds), not UTC.
georinex labels them as ``datetime64[ns]`` without a scale; we keep them as GPS time and store absolute
epochs as int64 nanoseconds since the GPS epoch 1980-01-06 00:00:00 (``*_gps_ns``), never as one float64.

Bad input. A file georinex cannot read raises :class:`InputDataError` naming the file; a file with no
observation epoch (or no GPS ephemeris) too. Epoch records that are in the file but that georinex could not
read (a corrupt epoch line, a wrong observation count) are counted, not dropped silently: we count the
epoch header lines in the file's text (RINEX 2: ``yy mm dd hh mm ss.sssssss flag nsat``, flag 0 or 1;
RINEX 3: lines starting with ``>``) and compare with the epochs georinex returns. georinex's own logged
complaints are kept in ``problems``.
"""

from __future__ import annotations

import logging
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from chronofuse.timescale import datetime64_to_gps_ns
from chronofuse.validation import InputDataError


# Preferred L1 pseudorange codes, best first (RINEX 3 C1C, RINEX 2 C1, then P1 codes).
L1_PSEUDORANGE_CODES = ("C1C", "C1", "C1W", "C1P", "P1")

_RINEX2_EPOCH = re.compile(r"^ [ \d]\d [ \d]\d [ \d]\d [ \d]\d [ \d]\d.{11}  [01][ \d]{2}\d")
_RINEX3_EPOCH = re.compile(r"^>")

# Broadcast-ephemeris fields taken from georinex's navigation Dataset (IS-GPS-200 names in comments).
_NAV_FIELDS = {
    "af0_s": "SVclockBias",
    "af1_s_per_s": "SVclockDrift",
    "af2_s_per_s2": "SVclockDriftRate",
    "crs_m": "Crs",
    "delta_n_rad_per_s": "DeltaN",
    "m0_rad": "M0",
    "cuc_rad": "Cuc",
    "eccentricity": "Eccentricity",
    "cus_rad": "Cus",
    "sqrt_a_sqrt_m": "sqrtA",
    "toe_s": "Toe",
    "cic_rad": "Cic",
    "omega0_rad": "Omega0",
    "cis_rad": "Cis",
    "i0_rad": "Io",
    "crc_m": "Crc",
    "omega_rad": "omega",
    "omega_dot_rad_per_s": "OmegaDot",
    "idot_rad_per_s": "IDOT",
    "week": "GPSWeek",
    "health": "health",
    "tgd_s": "TGD",
}


@dataclass(frozen=True)
class GpsObservations:
    """GPS pseudoranges of one RINEX observation file.

    Attributes
    ----------
    gps_ns : ndarray of int64, shape (epochs,)
        Epochs as GPS time, ns since 1980-01-06 (receiver time tags, as written).
    satellites : list of str, length sats
        ``"G05"`` style names.
    pseudorange_m : ndarray of float64, shape (epochs, sats)
        L1 pseudorange (m), NaN where not observed.
    code : str
        Which observation code ``pseudorange_m`` holds (e.g. ``"C1"``).
    approx_position_m : ndarray of float64, shape (3,) or None
        ``APPROX POSITION XYZ`` (ECEF, m) from the header.
    interval_s : float or None
        ``INTERVAL`` from the header (None when absent; then the median epoch spacing is used by callers).
    n_unreadable_epochs : int
        Epoch records in the file that georinex could not read.
    problems : list of str
        georinex's logged complaints about the file.
    source : str
    """

    gps_ns: np.ndarray
    satellites: list[str]
    pseudorange_m: np.ndarray
    code: str
    approx_position_m: np.ndarray | None
    interval_s: float | None
    n_unreadable_epochs: int
    problems: list[str] = field(default_factory=list)
    source: str = ""


@dataclass(frozen=True)
class GpsNavigation:
    """GPS broadcast ephemerides of one RINEX navigation file, one row per record (IS-GPS-200 Table 20-III).

    ``satellites`` is a list of ``records`` names; ``toc_gps_ns`` (int64, (records,)) is the clock reference
    time as GPS ns since 1980-01-06; ``params`` maps each name of :data:`_NAV_FIELDS` (SI units in the name,
    angles in rad) to a (records,) float64 array; ``klobuchar_alpha``/``klobuchar_beta`` are the header's
    ``ION ALPHA``/``ION BETA`` (4,) each, or None.
    """

    satellites: list[str]
    toc_gps_ns: np.ndarray
    params: dict[str, np.ndarray]
    klobuchar_alpha: np.ndarray | None
    klobuchar_beta: np.ndarray | None
    source: str = ""


def to_gps_ns(times) -> np.ndarray:
    """GPS-time labels (``datetime64``) -> int64 ns since the GPS epoch; no leap seconds (GPS scale)."""
    return datetime64_to_gps_ns(times)


class _LogCollector(logging.Handler):
    def __init__(self):
        super().__init__(level=logging.WARNING)
        self.messages: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.messages.append(record.getMessage())


def _load(path: Path, **kwargs):
    """``georinex.load`` with its logged complaints collected and its exceptions named by file."""
    import georinex

    collector = _LogCollector()
    root = logging.getLogger()
    root.addHandler(collector)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            data = georinex.load(path, **kwargs)
    except Exception as err:  # georinex raises many kinds (ValueError, KeyError, IndexError...) on bad files
        raise InputDataError(f"georinex cannot read this RINEX file: {type(err).__name__}: {err}", str(path)) from err
    finally:
        root.removeHandler(collector)
    return data, collector.messages


def count_epoch_records(path) -> int:
    """Observation epoch records in the file's text (see the module docstring), header excluded."""
    text = Path(path).read_text(errors="replace").splitlines()
    version = text[0][:9].strip() if text else ""
    try:
        major = int(float(version))
    except ValueError:
        return 0
    body = False
    pattern = _RINEX3_EPOCH if major >= 3 else _RINEX2_EPOCH
    count = 0
    for line in text:
        if not body:
            body = "END OF HEADER" in line
            continue
        if pattern.match(line):
            count += 1
    return count


def read_gps_observations(path, *, codes=L1_PSEUDORANGE_CODES) -> GpsObservations:
    """Read the GPS L1 pseudoranges of a RINEX 2 or 3 observation file (the first code of ``codes`` present).

    Raises :class:`InputDataError` naming the file when georinex cannot read it, it has no epoch, or no
    GPS pseudorange of the codes asked for.
    """
    path = Path(path)
    if not path.is_file():
        raise InputDataError("no such file", str(path))
    obs, problems = _load(path, use={"G"})
    if not hasattr(obs, "data_vars") or obs.attrs.get("rinextype") != "obs":
        raise InputDataError("not a RINEX observation file", str(path))
    if obs.sizes.get("time", 0) == 0 or obs.sizes.get("sv", 0) == 0:
        raise InputDataError("no GPS observation epoch in the file", str(path))
    code = next((c for c in codes if c in obs.data_vars), None)
    if code is None:
        raise InputDataError(f"no L1 pseudorange ({', '.join(codes)}) among {sorted(obs.data_vars)}", str(path))
    rho = obs[code].transpose("time", "sv").values.astype(np.float64)
    keep = np.isfinite(rho).any(axis=0)
    sats = [str(s) for s, k in zip(obs.sv.values, keep) if k]
    position = obs.attrs.get("position")
    interval = obs.attrs.get("interval")
    interval_s = float(interval) if interval is not None and np.isfinite(interval) and interval > 0 else None
    declared = count_epoch_records(path)
    return GpsObservations(
        gps_ns=to_gps_ns(obs.time.values),
        satellites=sats,
        pseudorange_m=rho[:, keep],
        code=code,
        approx_position_m=None if position is None else np.asarray(position, dtype=np.float64),
        interval_s=interval_s,
        n_unreadable_epochs=max(declared - obs.sizes["time"], 0),
        problems=problems,
        source=str(path),
    )


def read_gps_navigation(path) -> GpsNavigation:
    """Read the GPS broadcast ephemerides of a RINEX 2 or 3 navigation file.

    Raises :class:`InputDataError` naming the file when georinex cannot read it or it holds no GPS record.
    """
    path = Path(path)
    if not path.is_file():
        raise InputDataError("no such file", str(path))
    nav, _ = _load(path, use={"G"})
    if not hasattr(nav, "data_vars") or nav.attrs.get("rinextype") != "nav":
        raise InputDataError("not a RINEX navigation file", str(path))
    if nav.sizes.get("time", 0) == 0 or "sqrtA" not in nav.data_vars:
        raise InputDataError("no GPS ephemeris record in the file", str(path))
    sqrt_a = nav["sqrtA"].transpose("time", "sv").values
    ti, si = np.nonzero(np.isfinite(sqrt_a))
    if ti.size == 0:
        raise InputDataError("no GPS ephemeris record in the file", str(path))
    params = {}
    for name, var in _NAV_FIELDS.items():
        values = nav[var].transpose("time", "sv").values[ti, si] if var in nav.data_vars else np.zeros(ti.size)
        params[name] = np.asarray(values, dtype=np.float64)
    iono = nav.attrs.get("ionospheric_corr_GPS")
    alpha = beta = None
    if iono is not None and np.size(iono) == 8:
        iono = np.asarray(iono, dtype=np.float64)
        alpha, beta = iono[:4].copy(), iono[4:].copy()
    return GpsNavigation(
        satellites=[str(s) for s in nav.sv.values[si]],
        toc_gps_ns=to_gps_ns(nav.time.values[ti]),
        params=params,
        klobuchar_alpha=alpha,
        klobuchar_beta=beta,
        source=str(path),
    )
