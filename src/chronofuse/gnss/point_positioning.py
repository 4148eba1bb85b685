"""Multi-GNSS single-point positioning from code pseudoranges and broadcast ephemerides, batched over epochs.

Per epoch, weighted least squares (Misra & Enge 2011, 6.1; Groves 2013, 9.4.1) on::

    rho_n = |R3(omega_e tau) r_sat,n - r| + c dt_rx + b_s(n) - c dt_sat,n + k_s I_n + T_n + e_n

* ``r_sat`` at emission, ``dt_sat`` with relativity and the system's group delay
  (:mod:`chronofuse.gnss.ephemeris`), the light time from the pseudorange and Sagnac rotation;
* one receiver clock ``c dt_rx`` and one inter-system bias ``b_s`` per system after the first (GPS-BDT and
  GPS-GST offsets plus receiver delays); a system absent at an epoch holds its bias (:mod:`.lsq_position`);
* ``I_n``: the broadcast Klobuchar L1 delay, ``k_s = (f_L1 / f_s)^2`` for B1I; ``T_n``: Saastamoinen with a
  standard atmosphere (:mod:`chronofuse.gnss.atmosphere`);
* weights ``1 / sigma_n^2`` with RTKLIB's single-point error model (``pntpos.c``): code
  ``0.3^2 (1 + 1 / sin el)`` + code bias ``0.3^2`` + ionosphere ``(0.5 I)^2`` + troposphere
  ``(0.3 / (sin el + 0.1))^2`` + the broadcast orbit and clock accuracy ``URA^2`` (SISA for Galileo) (m^2);
* elevation mask; outlier exclusion: while the weighted residuals fail the chi-square test at
  ``1 - outlier_probability`` with ``n - m`` degrees of freedom, the satellite whose removal leaves the
  smallest residual sum of squares is left out (each candidate tried, as RTKLIB's RAIM FDE does) and the
  epoch solved again (at most ``max_exclusions`` per epoch);
* epochs with GDOP above ``max_gdop`` (30, RTKLIB's default) or too few satellites give no fix (NaN).

The solve starts at the header's approximate position when given (a starting point only, never a
constraint) or at the Earth's centre, where the first passes leave the atmosphere out.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np
import pymap3d
from scipy import stats

from chronofuse.constants import SPEED_OF_LIGHT_M_PER_S
from chronofuse.gnss.atmosphere import klobuchar_delay_at_s, saastamoinen_delay_at_m
from chronofuse.gnss.ephemeris import GpsNavigation, geometry_from_pseudorange, select_ephemeris
from chronofuse.gnss.lsq_position import least_squares_position
from chronofuse.gnss.systems import SYSTEM_CONSTANTS
from chronofuse.timescale import NS_PER_S, week_tow
from chronofuse.timescale import gps_ns_to_datetime64
from chronofuse.validation import InputDataError, InputWarning, check_scalar, invalid

__all__ = ["IONOSPHERE_MODELS", "TROPOSPHERE_MODELS", "PointPositions", "SppOptions", "point_positions", "enu_errors_m", "position_statistics",
           "pseudoranges_for"]


#: The delay models :class:`SppOptions` accepts.
IONOSPHERE_MODELS = ("klobuchar", "none")
TROPOSPHERE_MODELS = ("saastamoinen", "none")


@dataclass(frozen=True)
class SppOptions:
    """Settings of :func:`point_positions` (units in the names)."""

    elevation_mask_deg: float = 10.0
    ionosphere: str = "klobuchar"  # or "none"
    troposphere: str = "saastamoinen"  # or "none"
    outlier_probability: float = 1e-3
    max_exclusions: int = 3
    max_gdop: float = 30.0

    def __post_init__(self):
        check_scalar(self.elevation_mask_deg, "elevation_mask_deg", min_val=0.0, max_val=90.0)
        check_scalar(self.outlier_probability, "outlier_probability", min_val=0.0, max_val=1.0)
        check_scalar(self.max_exclusions, "max_exclusions", min_val=0, integer=True)
        if self.ionosphere not in IONOSPHERE_MODELS:
            raise invalid("ionosphere", self.ionosphere, f"one of {', '.join(IONOSPHERE_MODELS)}")
        if self.troposphere not in TROPOSPHERE_MODELS:
            raise invalid("troposphere", self.troposphere, f"one of {', '.join(TROPOSPHERE_MODELS)}")


@dataclass(frozen=True)
class PointPositions:
    """Fixes per epoch: ``gps_ns`` (epochs,), ``position_m`` (epochs, 3) ECEF (NaN: no fix), ``clock_m``
    (epochs,) ``c dt_rx`` against the first system's time, ``isb_m`` (epochs, systems - 1), ``n_used``,
    ``n_excluded``, ``gdop``/``pdop``/``hdop``/``vdop`` (epochs,); ``systems`` (letters), ``codes`` (letter ->
    observable used), ``satellites`` and ``residual_m`` (epochs, sats) of the satellites used (NaN else)."""

    gps_ns: np.ndarray
    position_m: np.ndarray
    clock_m: np.ndarray
    isb_m: np.ndarray
    n_used: np.ndarray
    n_excluded: np.ndarray
    gdop: np.ndarray
    pdop: np.ndarray
    hdop: np.ndarray
    vdop: np.ndarray
    systems: tuple[str, ...]
    codes: dict[str, str]
    satellites: list[str]
    residual_m: np.ndarray
    elevation_rad: np.ndarray
    source: str = ""
    problems: list[str] = field(default_factory=list)
    #: The last pass's inputs, for integrity monitoring on the same measurements (epochs, sats): pseudoranges
    #: corrected for satellite clock, ionosphere and troposphere (NaN: not usable), their 1-sigma (m), the
    #: satellites' ECEF positions at emission (epochs, sats, 3) and each satellite's system index (sats,).
    corrected_m: np.ndarray | None = None
    sigma_m: np.ndarray | None = None
    satellite_m: np.ndarray | None = None
    system_index: np.ndarray | None = None


def pseudoranges_for(obs, systems) -> tuple[list[str], np.ndarray, np.ndarray, dict[str, str]]:
    """``(satellites, pseudorange_m (epochs, sats), system index (sats,), codes)`` of ``obs`` (a
    :class:`chronofuse.io.rinex_obs.GnssObservations`) for the system letters ``systems``: per system the
    first code of :data:`chronofuse.gnss.systems.SYSTEM_CONSTANTS` with data. Raises
    :class:`InputDataError` naming the file when a system has none."""
    sats, cols, index, codes = [], [], [], {}
    for j, letter in enumerate(systems):
        mask = obs.system_mask(letter)
        code = next((c for c in SYSTEM_CONSTANTS[letter].codes
                     if c in obs.values and np.isfinite(obs.values[c][:, mask]).any()), None)
        if code is None:
            raise InputDataError(f"no {SYSTEM_CONSTANTS[letter].name.upper()} pseudorange "
                                 f"({', '.join(SYSTEM_CONSTANTS[letter].codes)}) in the observations", obs.source)
        codes[letter] = code
        for k in np.flatnonzero(mask):
            sats.append(obs.satellites[k])
            cols.append(obs.values[code][:, k])
            index.append(j)
    return sats, np.stack(cols, axis=1), np.asarray(index, dtype=np.intp), codes


def _lat_lon_h(position_m: np.ndarray):
    lat, lon, h = pymap3d.ecef2geodetic(position_m[..., 0], position_m[..., 1], position_m[..., 2], deg=False)
    return np.asarray(lat), np.asarray(lon), np.asarray(h)


def _elevation_azimuth(receiver_m: np.ndarray, satellite_m: np.ndarray):
    """Elevation and azimuth (rad) of satellites (epochs, S, 3) from receivers (epochs, 3)."""
    lat, lon, _ = _lat_lon_h(receiver_m)
    d = satellite_m - receiver_m[:, None, :]
    e, n, u = pymap3d.uvw2enu(d[..., 0], d[..., 1], d[..., 2], lat[:, None], lon[:, None], deg=False)
    return np.arctan2(u, np.hypot(e, n)), np.mod(np.arctan2(e, n), 2 * math.pi)


def _best_exclusion(satellite_m, corrected_m, sigma_m, usable, sys_index, x0_m) -> np.ndarray:
    """For each epoch (rows of the arguments), the satellite whose removal leaves the smallest weighted
    residual sum of squares: every candidate is left out in turn and the epoch solved again (solution
    separation; the largest single residual can point at a good satellite when the fault is pulled into
    the clock). Returns the column index per epoch."""
    rows, sats = corrected_m.shape
    trial = np.broadcast_to(corrected_m[:, None, :], (rows, sats, sats)).copy()
    trial[:, np.arange(sats), np.arange(sats)] = np.nan
    sigma = np.broadcast_to(sigma_m[:, None, :], trial.shape)
    fix = least_squares_position(satellite_m[:, None], trial, sigma, sys_index, x0_m[:, None, :], iterations=3)
    isb = np.concatenate([np.zeros(fix.clock_m.shape + (1,)), fix.isb_m], axis=-1)[..., sys_index]
    pred = np.linalg.norm(satellite_m[:, None] - fix.position_m[..., None, :], axis=-1) + fix.clock_m[..., None] + isb
    ssr = np.nansum(((trial - pred) / sigma) ** 2, axis=-1)
    ssr = np.where(usable & np.isfinite(fix.position_m[..., 0]), ssr, np.inf)
    return np.argmin(ssr, axis=-1)


def _day(gps_ns) -> str:
    return str(gps_ns_to_datetime64(np.asarray([gps_ns], dtype=np.int64))[0])[:16].replace("T", " ")


def _no_cover_message(nav: GpsNavigation, systems, gps_ns) -> str:
    """Why no satellite has an ephemeris: the span of the records against that of the epochs."""
    from chronofuse.gnss.ephemeris import MAX_DTOE_S

    toe = nav.toe_gps_ns if nav.toe_gps_ns is not None else nav.toe_from_week()
    mine = np.isin(np.asarray([s[:1] for s in nav.satellites]), list(systems))
    toe = toe[mine] if mine.any() else toe
    limits = ", ".join(f"{SYSTEM_CONSTANTS[s].name.upper()} {MAX_DTOE_S.get(s, 7200.0) / 3600:g} h" for s in systems)
    return (f"no ephemeris covers the observation epochs ({_day(gps_ns[0])} to {_day(gps_ns[-1])} GPS time): the "
            f"records' toe run from {_day(toe.min())} to {_day(toe.max())}, and a record serves within {limits} "
            "of its toe (a navigation file of another day?)")


def _no_klobuchar_warning(nav: GpsNavigation) -> InputWarning:
    others = [name for name, v in (("BeiDou Klobuchar", nav.bds_klobuchar_alpha), ("Galileo NeQuick", nav.nequick_gal))
              if v is not None]
    held = f" (only {' and '.join(others)} coefficients, not used)" if others else ""
    return InputWarning(f"{nav.source}: no GPS Klobuchar coefficients (header IONOSPHERIC CORR GPSA/GPSB or a RINEX 4 "
                        f"ION G.. LNAV record){held}: no ionospheric delay removed, although {{ionosphere}} == "
                        "'klobuchar' (RTKLIB applies its built-in 2004 coefficients instead)", fields=("ionosphere",))


def point_positions(obs, nav: GpsNavigation, systems=("G",), options: SppOptions | None = None) -> PointPositions:
    """Single-point fixes of every epoch of ``obs`` (module docstring) with ``nav``'s ephemerides of the
    systems ``systems`` (letters, the first is the clock reference).

    Raises :class:`InputDataError` naming the navigation file(s) when no record is within its system's
    validity (:data:`chronofuse.gnss.ephemeris.MAX_DTOE_S`) of any epoch; warns
    (:class:`~chronofuse.validation.InputWarning`) when the Klobuchar model is asked for and ``nav`` has no GPS
    coefficients (none is then applied)."""
    opt = options or SppOptions()
    systems = tuple(systems)
    missing = [s for s in systems if s not in nav.systems]
    if missing:
        raise InputDataError(f"no {', '.join(SYSTEM_CONSTANTS[s].name.upper() for s in missing)} ephemeris record "
                             f"in the navigation data (it has {', '.join(nav.systems) or 'none'})", nav.source)
    sats, rho, sys_index, codes = pseudoranges_for(obs, systems)
    gps_ns = obs.gps_ns
    epochs = gps_ns.size
    eph = select_ephemeris(nav, sats, gps_ns)
    if not eph.valid.any():
        raise InputDataError(_no_cover_message(nav, systems, gps_ns), nav.source)
    if opt.ionosphere == "klobuchar" and nav.klobuchar_alpha is None:
        warnings.warn(_no_klobuchar_warning(nav), stacklevel=2)
    rho = np.where(eph.valid, rho, np.nan)
    scale = np.array([(SYSTEM_CONSTANTS["G"].frequency_hz / SYSTEM_CONSTANTS[s].frequency_hz) ** 2
                      for s in systems])[sys_index]
    tow_s = week_tow(gps_ns)[1][:, None] / NS_PER_S
    accuracy = eph.params.get("accuracy_m")
    ura_m2 = 0.0 if accuracy is None else np.where(np.isfinite(accuracy) & (accuracy > 0), accuracy, 0.0) ** 2
    mask_rad = math.radians(opt.elevation_mask_deg)
    approx = obs.header.approx_position_m if getattr(obs, "header", None) is not None else None
    x = np.broadcast_to(approx if approx is not None else np.zeros(3), (epochs, 3)).astype(np.float64).copy()
    excluded = np.zeros(rho.shape, dtype=bool)
    near = approx is not None
    fix = None
    for it in range(10):
        receiver = np.where(np.isfinite(x), x, 0.0)
        geo = geometry_from_pseudorange(eph, gps_ns, np.nan_to_num(rho, nan=2.2e7), receiver[:, None, :])
        el, az = _elevation_azimuth(receiver, geo.satellite_m)
        lat, lon, h = _lat_lon_h(receiver)
        near = near or bool(np.all(np.abs(h) < 1e5))
        iono = np.zeros_like(rho)
        tropo = np.zeros_like(rho)
        if near and opt.ionosphere == "klobuchar" and nav.klobuchar_alpha is not None:
            iono = SPEED_OF_LIGHT_M_PER_S * klobuchar_delay_at_s(nav.klobuchar_alpha, nav.klobuchar_beta, lat[:, None],
                                                                 lon[:, None], el, az, tow_s) * scale
        if near and opt.troposphere == "saastamoinen":
            tropo = saastamoinen_delay_at_m(lat[:, None], h[:, None], el)
        corrected = rho + SPEED_OF_LIGHT_M_PER_S * geo.clock_s - iono - tropo
        usable = np.isfinite(corrected) & ~excluded & (~near | (el >= mask_rad))
        sin_el = np.maximum(np.sin(el), 0.05)
        var = (0.09 * (1.0 + 1.0 / sin_el) + 0.09 + (0.5 * iono) ** 2 + (0.3 / (sin_el + 0.1)) ** 2
               + ura_m2)
        sigma = np.where(usable, np.sqrt(var), np.inf)
        start = np.where(np.isfinite(x), x, 0.0)
        fix = least_squares_position(geo.satellite_m, np.where(usable, corrected, np.nan), sigma, sys_index, start,
                                     iterations=8 if it == 0 else 3)
        x_new = np.where(np.isfinite(fix.position_m), fix.position_m, x)
        step = np.nanmax(np.abs(x_new - x)) if np.isfinite(x_new - x).any() else 0.0
        x = x_new
        if not near:
            continue
        # outlier screen on the converged passes
        pred = (np.linalg.norm(geo.satellite_m - fix.position_m[:, None, :], axis=-1) + fix.clock_m[:, None]
                + np.concatenate([np.zeros((epochs, 1)), fix.isb_m], axis=1)[:, sys_index])
        resid = np.where(usable, corrected - pred, np.nan)
        if step < 1e-3 or it >= 6:
            normalized = resid / np.sqrt(var)
            n_sys = np.stack([(usable & (sys_index == j)).any(-1) for j in range(len(systems))], -1).sum(-1)
            dof = usable.sum(-1) - 3 - n_sys
            chi2 = np.nansum(normalized**2, axis=-1)
            limit = stats.chi2.ppf(1.0 - opt.outlier_probability, np.maximum(dof, 1))
            fail = (dof > 0) & (chi2 > limit) & np.isfinite(fix.position_m[:, 0]) & (excluded.sum(-1) < opt.max_exclusions)
            if not fail.any() or opt.max_exclusions == 0:
                break
            rows = np.flatnonzero(fail)
            worst = _best_exclusion(geo.satellite_m[rows], np.where(usable, corrected, np.nan)[rows],
                                    np.sqrt(var)[rows], usable[rows], sys_index, fix.position_m[rows])
            excluded[rows, worst] = True
    assert fix is not None
    if not near:  # no fix came within 100 km of the Earth's surface: nothing to screen or correct
        raise InputDataError("no epoch gives a fix near the Earth: the navigation data do not cover the observation "
                             "times (another day?) and the header has no usable APPROX POSITION XYZ",
                             getattr(obs, "source", "") or None)
    position = np.where(np.isfinite(fix.position_m) & (fix.gdop <= opt.max_gdop)[:, None], fix.position_m, np.nan)
    ok = np.isfinite(position[:, 0])
    return PointPositions(gps_ns=gps_ns, position_m=position, clock_m=np.where(ok, fix.clock_m, np.nan),
                          isb_m=np.where(ok[:, None], fix.isb_m, np.nan), n_used=np.where(ok, fix.n_used, 0),
                          n_excluded=excluded.sum(-1), gdop=np.where(ok, fix.gdop, np.nan),
                          pdop=np.where(ok, fix.pdop, np.nan), hdop=np.where(ok, fix.hdop, np.nan),
                          vdop=np.where(ok, fix.vdop, np.nan), systems=systems, codes=codes, satellites=sats,
                          residual_m=np.where(ok[:, None], resid, np.nan), elevation_rad=el,
                          source=getattr(obs, "source", ""), corrected_m=np.where(usable, corrected, np.nan),
                          sigma_m=np.where(usable, np.sqrt(var), np.nan), satellite_m=geo.satellite_m,
                          system_index=np.asarray(sys_index))


def enu_errors_m(position_m: np.ndarray, reference_m) -> np.ndarray:
    """East, north, up (m) of ECEF positions (..., 3) from the reference ECEF point (3,)."""
    ref = np.asarray(reference_m, dtype=np.float64)
    lat, lon, h = pymap3d.ecef2geodetic(*ref, deg=True)
    d = np.asarray(position_m, dtype=np.float64) - ref
    e, n, u = pymap3d.uvw2enu(d[..., 0], d[..., 1], d[..., 2], lat, lon, deg=True)
    return np.stack([e, n, u], axis=-1)


def position_statistics(position_m: np.ndarray, reference_m) -> dict:
    """Error statistics of fixes against a reference position: ``horizontal95_m`` (= CEP95, the radius holding
    95 % of the fixes), ``cep50_m``, ``vertical95_m`` (95th percentile of |up|), the mean east/north/up
    (bias) and RMS, ``availability`` (fraction of epochs with a fix), ``epochs``."""
    enu = enu_errors_m(position_m, reference_m)
    ok = np.isfinite(enu).all(-1)
    horizontal = np.hypot(enu[ok, 0], enu[ok, 1])
    up = np.abs(enu[ok, 2])
    pct = lambda v, q: float(np.percentile(v, q)) if v.size else float("nan")  # noqa: E731
    return {
        "epochs": int(ok.size), "fixes": int(ok.sum()), "availability": float(ok.mean()) if ok.size else 0.0,
        "horizontal95_m": pct(horizontal, 95), "cep50_m": pct(horizontal, 50), "cep95_m": pct(horizontal, 95),
        "vertical95_m": pct(up, 95),
        "horizontal_rms_m": float(np.sqrt(np.mean(horizontal**2))) if horizontal.size else float("nan"),
        "mean_enu_m": [float(v) for v in enu[ok].mean(0)] if ok.any() else [float("nan")] * 3,
    }
