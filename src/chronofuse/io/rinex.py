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

Channel clock biases. :func:`channel_clock_biases` reads an observation and a navigation file, puts the
epochs on the sampling grid (:mod:`chronofuse.io.grid`) and computes the per-satellite receiver clock
biases of :mod:`chronofuse.gnss.observables` there. The record types it fills (:class:`GpsNavigation`,
:class:`ChannelClockBiases`) are defined in ``chronofuse.gnss``, which never reads files.
"""

from __future__ import annotations

import logging
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from chronofuse.gnss.ephemeris import EPHEMERIS_FIELDS, GpsNavigation
from chronofuse.gnss.observables import ChannelClockBiases, channel_biases
from chronofuse.io.grid import grid_slots, place_on_grid
from chronofuse.timescale import NS_PER_S, datetime64_to_gps_ns
from chronofuse.validation import InputDataError, check_array, check_choice


# Preferred L1 pseudorange codes, best first (RINEX 3 C1C, RINEX 2 C1, then P1 codes).
L1_PSEUDORANGE_CODES = ("C1C", "C1", "C1W", "C1P", "P1")

#: Every GPS code (pseudorange) observable kept beside the L1 one, for identification on each of them
#: (RINEX 2 names, then RINEX 3's L1/L2/L5 codes).
CODE_OBSERVABLES = ("C1", "P1", "P2", "C2", "C5", "C1C", "C1W", "C1P", "C2W", "C2P", "C2L", "C2X", "C2S", "C5Q",
                    "C5X")

_RINEX2_EPOCH = re.compile(r"^ [ \d]\d [ \d]\d [ \d]\d [ \d]\d [ \d]\d.{11}  [01][ \d]{2}\d")
_RINEX3_EPOCH = re.compile(r"^>")

# An epoch tag may be this fraction of the interval off its grid slot (receiver clock steering).
_GRID_TOLERANCE = 0.01

# georinex's navigation Dataset variable for each broadcast-ephemeris field (IS-GPS-200 names).
_GEORINEX_NAV_NAMES = {
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
    "accuracy_m": "SVacc",
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
    other_codes_m: dict = field(default_factory=dict)

    def code_pseudorange_m(self, code: str | None = None) -> np.ndarray:
        """The (epochs, sats) pseudoranges of ``code`` (None: the L1 code in ``pseudorange_m``)."""
        if code is None or code == self.code:
            return self.pseudorange_m
        if code not in self.other_codes_m:
            raise InputDataError(f"no {code} pseudorange (codes: {', '.join(self.codes)})", self.source)
        return self.other_codes_m[code]

    @property
    def codes(self) -> list[str]:
        """Every code observable held: the L1 one first."""
        return [self.code, *self.other_codes_m]


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


def _major_version(path: Path) -> int:
    """The RINEX major version of a plain file's first line (0 when unreadable)."""
    with open(path, "rb") as f:
        head = f.readline(200)
    try:
        return int(float(head[:9]))
    except ValueError:
        return 0


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
    """Read the GPS L1 pseudoranges of a RINEX 2 or 3 observation file (the first code of ``codes`` present),
    plain, gzip or Hatanaka-compressed (restored to a temporary plain file first). A pseudorange written as
    0.000 is missing (RINEX 3.05 section 5.7), as a blank one is.

    Raises :class:`InputDataError` naming the file when georinex cannot read it, it has no epoch, or no
    GPS pseudorange of the codes asked for.
    """
    import dataclasses
    import tempfile

    from chronofuse.io.rinex_text import first_line, rinex_bytes

    path = Path(path)
    if not path.is_file():
        raise InputDataError("no such file", str(path))
    with open(path, "rb") as f:
        magic = f.read(2)
    if magic in (b"\x1f\x8b", b"\x1f\x9d") or "CRINEX VERS" in first_line(path):
        with tempfile.TemporaryDirectory() as tmp:
            plain = Path(tmp) / (path.name.split(".")[0] + ".obs")
            plain.write_bytes(rinex_bytes(path))
            obs = _read_gps_observations(plain, codes)
        return dataclasses.replace(obs, source=str(path))
    return _read_gps_observations(path, codes)


def _read_gps_observations(path: Path, codes) -> GpsObservations:
    try:
        obs, problems = _load(path, use={"G"})
        cut = 0
    except InputDataError:
        obs, problems, cut = _load_without_last_epoch(path)
    empty = not hasattr(obs, "sizes") or obs.sizes.get("time", 0) == 0 or obs.sizes.get("sv", 0) == 0
    if not empty and obs.attrs.get("rinextype") != "obs":
        raise InputDataError("not a RINEX observation file", str(path))
    if empty:
        systems = _observed_systems(path)
        raise InputDataError("no GPS observation epoch in the file (it holds "
                             f"{', '.join(systems) if systems else 'no satellite'}; identification needs GPS "
                             "pseudoranges and a GPS navigation file)", str(path))
    code = next((c for c in codes if c in obs.data_vars), None)
    if code is None:
        raise InputDataError(f"no L1 pseudorange ({', '.join(codes)}) among {sorted(obs.data_vars)}", str(path))
    rho = obs[code].transpose("time", "sv").values.astype(np.float64)
    rho[rho == 0.0] = np.nan  # 0.000 is the format's "not observed"
    keep = np.isfinite(rho).any(axis=0)
    sats = [str(s) for s, k in zip(obs.sv.values, keep) if k]
    position = obs.attrs.get("position")
    interval = obs.attrs.get("interval")
    interval_s = float(interval) if interval is not None and np.isfinite(interval) and interval > 0 else None
    declared = count_epoch_records(path)
    gps_ns = to_gps_ns(obs.time.values)
    if _major_version(path) < 3:  # georinex's RINEX 2 seconds went through a float: the epoch lines' own digits
        from chronofuse.io.rinex_obs import exact_rinex2_times

        gps_ns = exact_rinex2_times(gps_ns, path.read_bytes().splitlines(), str(path))
    return GpsObservations(
        gps_ns=gps_ns,
        satellites=sats,
        pseudorange_m=rho[:, keep],
        code=code,
        approx_position_m=None if position is None else np.asarray(position, dtype=np.float64),
        interval_s=interval_s,
        n_unreadable_epochs=max(declared - obs.sizes["time"], cut),
        problems=problems,
        source=str(path),
        other_codes_m={c: _missing_zero(obs[c].transpose("time", "sv").values.astype(np.float64)[:, keep])
                       for c in CODE_OBSERVABLES if c != code and c in obs.data_vars
                       and np.isfinite(obs[c].values).any()},
    )


def _missing_zero(values: np.ndarray) -> np.ndarray:
    values[values == 0.0] = np.nan
    return values


_SYSTEM_NAMES = {"G": "GPS", "R": "GLONASS", "E": "Galileo", "C": "BeiDou", "J": "QZSS", "S": "SBAS", "I": "NavIC"}


def _observed_systems(path: Path) -> list[str]:
    """The satellite systems named in the file's epoch records (RINEX 2 satellite lists, RINEX 3 data lines)."""
    found = set()
    body = False
    for line in Path(path).read_text(errors="replace").splitlines():
        if not body:
            body = "END OF HEADER" in line
            continue
        if _RINEX2_EPOCH.match(line):
            found.update(c for c in line[32:68:3] if c in _SYSTEM_NAMES)
        elif line[:1] in _SYSTEM_NAMES and line[1:3].strip().isdigit():
            found.add(line[0])
    return [_SYSTEM_NAMES[c] for c in sorted(found)]


def _load_without_last_epoch(path: Path):
    """Read a file whose last epoch record is cut short (a recording stopped mid-write): georinex raises on
    it, so the text up to the last epoch header is read instead and that epoch counted as unreadable.
    Raises the original error when the file still cannot be read."""
    import tempfile

    text = path.read_text(errors="replace").splitlines(keepends=True)
    body = next((i for i, line in enumerate(text) if "END OF HEADER" in line), None)
    version = text[0][:9].strip() if text else ""
    try:
        pattern = _RINEX3_EPOCH if int(float(version)) >= 3 else _RINEX2_EPOCH
    except ValueError:
        pattern = None
    last = None if body is None or pattern is None else next(
        (i for i in range(len(text) - 1, body, -1) if pattern.match(text[i])), None)
    if last is None:
        return (*_load(path, use={"G"}), 0)
    with tempfile.TemporaryDirectory() as tmp:
        trimmed = Path(tmp) / path.name
        trimmed.write_text("".join(text[:last]))
        try:
            obs, problems = _load(trimmed, use={"G"})
        except InputDataError:
            return (*_load(path, use={"G"}), 0)
        obs.load()
    return obs, problems + ["last epoch record cut short: not read"], 1


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
    for name in EPHEMERIS_FIELDS:
        var = _GEORINEX_NAV_NAMES[name]
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


def channel_clock_biases(
    obs_path, nav_path, position_ecef_m, *, elevation_mask_deg: float = 15.0, epoch_time: str = "grid",
    code: str | None = None, observations: GpsObservations | None = None, navigation: GpsNavigation | None = None,
) -> ChannelClockBiases:
    """Per-satellite clock biases ``b_n(k)`` (:func:`chronofuse.gnss.observables.channel_biases`) from a
    RINEX observation file and a GPS navigation file for a static receiver at ``position_ecef_m`` (3,) (m, ECEF).

    Epochs are put on the grid of the header's ``INTERVAL`` (else the smallest epoch spacing), within 1 % of
    the interval; grid epochs without data are NaN rows counted in ``n_skipped_epochs``.

    ``epoch_time`` is the receive time the geometry uses: ``"grid"`` (the nominal grid epoch, default) or
    ``"tag"`` (the epoch as written). The Trimble 5700 files here tag epochs 1-2 ms off the grid (receiver
    millisecond clock steering) while their pseudoranges agree better with the grid: measured, the
    second-difference noise of the channel residuals drops on 17 of 20 channels with ``"grid"`` (e.g.
    G11 at 0759: 2.3 -> 1.4 ns) and the clean-data false alarms of station 0759 go from four channels
    to one. ``gps_epoch_ns`` holds the times used. ``code``: the code observable (None: the L1 code;
    e.g. ``"P2"``: the L1 signal model is applied to it, and the L2 ionosphere and inter-frequency bias
    it misses are slow, which the second difference removes); ``observations``/``navigation``: files
    already read. Raises :class:`InputDataError` naming the file
    when an epoch is off the grid.
    """
    check_choice(epoch_time, "epoch_time", ("grid", "tag"))
    position = check_array(position_ecef_m, "position_ecef_m", ndim=1)
    if position.shape != (3,):
        raise ValueError(f"position_ecef_m has shape {position.shape}, must be (3,)")
    obs = read_gps_observations(obs_path) if observations is None else observations
    nav = read_gps_navigation(nav_path) if navigation is None else navigation
    gps = obs.gps_ns
    if obs.interval_s is not None:
        step_ns = int(round(obs.interval_s * NS_PER_S))
    elif gps.size > 1:
        step_ns = int(np.diff(gps).min())
    else:
        raise InputDataError("one epoch and no INTERVAL in the header: the sampling interval is unknown",
                             str(obs_path))
    # Receivers that steer their clock in millisecond steps tag epochs a few ms off the nominal grid
    # (the Trimble 5700 files here): snap to the nearest grid slot, keep the true tag for the geometry.
    index, bad = grid_slots((gps - gps[0]).astype(np.float64), float(step_ns), _GRID_TOLERANCE)
    if bad >= 0:
        raise InputDataError(f"epoch {bad + 1} is not on the {step_ns / NS_PER_S:g} s grid (or not increasing)",
                             str(obs_path))
    epochs = int(index[-1]) + 1
    if epoch_time == "grid":
        gps = gps[0] + index * step_ns
    bias, elevation = channel_biases(nav, obs.satellites, gps, obs.code_pseudorange_m(code), position,
                                     elevation_mask_deg=elevation_mask_deg)
    tags = gps[0] + np.arange(epochs, dtype=np.int64) * step_ns
    tags[index] = gps
    return ChannelClockBiases(
        t_s=np.arange(epochs) * (step_ns / NS_PER_S),
        gps_epoch_ns=tags,
        satellites=list(obs.satellites),
        bias_s=place_on_grid(index, bias),
        interval_s=step_ns / NS_PER_S,
        n_skipped_epochs=epochs - gps.size,
        n_unreadable_epochs=obs.n_unreadable_epochs,
        elevation_rad=place_on_grid(index, elevation),
    )
