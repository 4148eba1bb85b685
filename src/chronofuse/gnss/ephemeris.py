"""GPS broadcast ephemeris: satellite positions and clocks, vectorised over (epochs, sats).

IS-GPS-200 (rev. N) section 20.3.3.4.3, Table 20-IV (user algorithm for ephemeris determination): Kepler
propagation from ``toe`` with the mean-motion correction ``delta_n``, the second-harmonic corrections
(``Cuc, Cus, Crc, Crs, Cic, Cis``), the rate of inclination and of right ascension, Earth rotation to ECEF
(WGS 84). Section 20.3.3.3.3.1 (satellite clock): ``dt_sv = af0 + af1 (t - toc) + af2 (t - toc)^2 + dt_r``,
relativistic ``dt_r = F e sqrt(A) sin(E_k)`` with ``F = -2 sqrt(mu) / c^2``, and ``- T_GD`` for an L1-only
user (20.3.3.3.3.2).

Times are GPS time; absolute epochs are int64 ns since 1980-01-06 (``*_gps_ns``) and offsets from them are
float seconds (``*_s``), so no absolute epoch is ever one float64.

Signal transit. The emission time is either solved from the pseudorange (the satellite time of emission is
``t_rx_tag - rho / c``, exact whatever the receiver clock, then the satellite clock is removed) or by the
light-time iteration ``tau = |R3(omega_e tau) r_sat(t_rx - tau) - r_rx| / c`` for a known true receive time.
Either way the satellite position is rotated by ``omega_e tau`` (Earth rotation during transit, the Sagnac
correction), so the range is computed in the ECEF frame of the receive time.

Other systems. Galileo and BeiDou broadcast the same Keplerian elements (Galileo OS SIS ICD 5.1.1; BDS ICD
B1I 5.2.4.12) with their own GM and Earth rate (:mod:`chronofuse.gnss.systems`), carried per record in
``params`` (``gm_m3_per_s2``, ``omega_e_rad_per_s``; GPS values when absent). A BeiDou GEO (``geo`` = 1)
is propagated in an inertial-like frame and turned to ECEF by ``R_Z(omega_e t_k) R_X(-5 deg)`` (BDS ICD B1I
Table 5-11). ``group_delay_s`` (GPS TGD, Galileo BGD(E1, E5a), BeiDou TGD1) is what a single-frequency user
of the code read removes. Times: every record's ``toe``/``toc`` are kept as GPS-time ns (BDT = GPST - 14 s),
so ``t_k`` is the same in either scale; ``toe_s`` stays on the system's own week, as the right ascension
``OMEGA0`` refers to it.

The record type :class:`GpsNavigation` is defined here and built from files by ``chronofuse.io.rinex``, so
the signal models never import the file readers.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from chronofuse.constants import SPEED_OF_LIGHT_M_PER_S
from chronofuse.timescale import NS_PER_S, SECONDS_PER_WEEK, gps_ns_from_week_tow, seconds_to_ns

GM_M3_PER_S2 = 3.986005e14  # WGS 84 value of IS-GPS-200
OMEGA_EARTH_RAD_PER_S = 7.2921151467e-5  # WGS 84 Earth rotation rate
RELATIVISTIC_F_S_PER_SQRT_M = -4.442807633e-10  # F = -2 sqrt(mu) / c^2 (IS-GPS-200 20.3.3.3.3.1)

_KEPLER_ITERATIONS = 10
_LIGHT_TIME_ITERATIONS = 6

#: The broadcast parameters of one GPS LNAV record (IS-GPS-200 Table 20-III), SI units in the names, angles
#: in rad; ``week`` the full GPS week of ``toe``, ``health`` the SV health word (0: healthy), ``accuracy_m``
#: the user range accuracy (URA) of the record.
EPHEMERIS_FIELDS = (
    "af0_s", "af1_s_per_s", "af2_s_per_s2", "crs_m", "delta_n_rad_per_s", "m0_rad", "cuc_rad", "eccentricity",
    "cus_rad", "sqrt_a_sqrt_m", "toe_s", "cic_rad", "omega0_rad", "cis_rad", "i0_rad", "crc_m", "omega_rad",
    "omega_dot_rad_per_s", "idot_rad_per_s", "week", "health", "tgd_s", "accuracy_m",
)  # fmt: skip


@dataclass(frozen=True)
class GpsNavigation:
    """GPS broadcast ephemerides, one row per record (IS-GPS-200 Table 20-III); built from a RINEX
    navigation file by :func:`chronofuse.io.rinex.read_gps_navigation`.

    ``satellites`` is a list of ``records`` names; ``toc_gps_ns`` (int64, (records,)) is the clock reference
    time as GPS ns since 1980-01-06; ``params`` maps each name of :data:`EPHEMERIS_FIELDS` to a (records,)
    float64 array; ``klobuchar_alpha``/``klobuchar_beta`` are the broadcast ionosphere coefficients (4,)
    each (RINEX ``ION ALPHA``/``ION BETA``), or None; ``bds_klobuchar_alpha``/``bds_klobuchar_beta`` the
    BeiDou ones (``BDSA``/``BDSB``, RINEX 4 ``ION C.. D1D2``) and ``nequick_gal`` Galileo's NeQuick ``ai0,
    ai1, ai2`` (``GAL``, ``ION E.. IFNV``), each kept when the file has them, else None.
    """

    satellites: list[str]
    toc_gps_ns: np.ndarray
    params: dict[str, np.ndarray]
    klobuchar_alpha: np.ndarray | None
    klobuchar_beta: np.ndarray | None
    source: str = ""
    #: ``toe`` of each record on GPS time (int64 ns); None: from ``week``/``toe_s`` (GPS records).
    toe_gps_ns: np.ndarray | None = None
    #: Records of systems not read (GLONASS, SBAS ...), counted.
    n_skipped_records: int = 0
    bds_klobuchar_alpha: np.ndarray | None = None
    bds_klobuchar_beta: np.ndarray | None = None
    nequick_gal: np.ndarray | None = None

    def toe_from_week(self) -> np.ndarray:
        """``toe`` on GPS time (int64 ns) from ``week`` and ``toe_s`` (GPS and Galileo weeks)."""
        return gps_ns_from_week_tow(self.params["week"].astype(np.int64), seconds_to_ns(self.params["toe_s"]))

    @property
    def systems(self) -> list[str]:
        """System letters of the records, in the order G, E, C, J."""
        present = {s[0] for s in self.satellites}
        return [c for c in "GECJ" if c in present]


@dataclass(frozen=True)
class BroadcastEphemeris:
    """Broadcast parameters chosen per (epoch, satellite); every array has shape (epochs, sats).

    ``params`` holds the fields of :class:`GpsNavigation` (NaN where no usable record),
    ``toe_gps_ns`` and ``toc_gps_ns`` the absolute reference times (int64 ns, 0 where none), ``valid`` (bool)
    whether a healthy record within ``max_age_s`` of the epoch was found.
    """

    params: dict[str, np.ndarray]
    toe_gps_ns: np.ndarray
    toc_gps_ns: np.ndarray
    valid: np.ndarray

    def epochs(self, rows) -> BroadcastEphemeris:
        """The same ephemeris for the epochs ``rows`` only (a slice or an index array)."""
        return BroadcastEphemeris(
            params={k: v[rows] for k, v in self.params.items()},
            toe_gps_ns=self.toe_gps_ns[rows],
            toc_gps_ns=self.toc_gps_ns[rows],
            valid=self.valid[rows],
        )


def _week_time(seconds: np.ndarray) -> np.ndarray:
    """Fold a time difference into (-half week, half week] (IS-GPS-200 20.3.3.4.3, the ``tk`` rule)."""
    return seconds - SECONDS_PER_WEEK * np.round(seconds / SECONDS_PER_WEEK)


_VALID_FROM_TOE = ("E", "C")
_FUTURE_TOLERANCE_S = 900.0

#: How far from its ``toe`` a broadcast record is used, per system (s): RTKLIB 2.4.3's ``MAXDTOE`` (GPS),
#: ``MAXDTOE_QZS``, ``MAXDTOE_GAL`` and ``MAXDTOE_CMP`` (``ephemeris.c``, ``seleph``), the limits of the
#: solutions we compare with. GPS and QZSS: 2 h, half the 4 h curve fit interval centred on ``toe``
#: (IS-GPS-200 20.3.4.4); Galileo 4 h; BeiDou 6 h. A record further away gives no satellite, whatever
#: else the files hold (a navigation file of the next day covers none of the epochs).
MAX_DTOE_S = {"G": 7200.0, "J": 7200.0, "E": 14400.0, "C": 21600.0}


def select_ephemeris(nav: GpsNavigation, satellites, gps_ns, *, max_age_s: float | None = None) -> BroadcastEphemeris:
    """For each epoch (``gps_ns``, int64 (epochs,)) and satellite (names, (sats,)) the healthy record with
    the nearest ``toe``; not valid when none is within ``max_age_s`` (None: the system's
    :data:`MAX_DTOE_S`, 2 h for GPS). A GPS record's toe is the middle of its 4 h fit interval
    (IS-GPS-200 20.3.4.4); Galileo's and BeiDou's are at the start of their validity, so for them a record
    whose toe is more than 15 min ahead of the epoch is used only when no other is in reach."""
    gps_ns = np.asarray(gps_ns, dtype=np.int64)
    epochs, sats = gps_ns.size, len(satellites)
    p = nav.params
    toe_ns = nav.toe_gps_ns if nav.toe_gps_ns is not None else nav.toe_from_week()
    healthy = (p["health"] == 0) & np.isfinite(p["sqrt_a_sqrt_m"]) & (p["sqrt_a_sqrt_m"] > 0)
    index = np.full((epochs, sats), -1, dtype=np.int64)
    names = np.asarray(nav.satellites)
    for j, sat in enumerate(satellites):
        rows = np.flatnonzero((names == sat) & healthy)
        if rows.size == 0:
            continue
        limit_s = MAX_DTOE_S.get(str(sat)[:1], MAX_DTOE_S["G"]) if max_age_s is None else max_age_s
        signed_s = (gps_ns[:, None] - toe_ns[rows][None, :]) / NS_PER_S
        age_s = np.abs(signed_s)
        if str(sat)[:1] in _VALID_FROM_TOE:
            # Galileo and BeiDou records are valid from their toe on: one more than 15 min ahead of the epoch
            # is taken only when no other record is within reach (measured on the ESBC day: 2 h before its
            # toe a Galileo record is 18 m off the precise orbit, against 0.9 m from its toe on)
            age_s = np.where(signed_s < -_FUTURE_TOLERANCE_S, age_s + 2.0 * limit_s, age_s)
        best = np.argmin(age_s, axis=1)
        ok = np.abs(signed_s[np.arange(epochs), best]) <= limit_s
        index[ok, j] = rows[best[ok]]
    valid = index >= 0
    safe = np.where(valid, index, 0)
    params = {k: np.where(valid, v[safe], np.nan) for k, v in p.items()}
    return BroadcastEphemeris(
        params=params,
        toe_gps_ns=np.where(valid, toe_ns[safe], 0),
        toc_gps_ns=np.where(valid, nav.toc_gps_ns[safe], 0),
        valid=valid,
    )


def _constant(eph: BroadcastEphemeris, name: str, default: float):
    value = eph.params.get(name)
    return default if value is None else np.where(np.isfinite(value), value, default)


def _eccentric_anomaly(eph: BroadcastEphemeris, tk_s: np.ndarray) -> np.ndarray:
    """``E_k`` from Kepler's equation ``M_k = E_k - e sin E_k`` (fixed-point iteration, converged to 1e-15)."""
    p = eph.params
    a = p["sqrt_a_sqrt_m"] ** 2
    n = np.sqrt(_constant(eph, "gm_m3_per_s2", GM_M3_PER_S2) / a**3) + p["delta_n_rad_per_s"]
    mk = p["m0_rad"] + n * tk_s
    ek = mk.copy()
    for _ in range(_KEPLER_ITERATIONS):
        ek = mk + p["eccentricity"] * np.sin(ek)
    return ek


def satellite_position_ecef(eph: BroadcastEphemeris, gps_ns, offset_s=0.0) -> np.ndarray:
    """ECEF position (m) at ``gps_ns + offset_s`` (GPS time): IS-GPS-200 Table 20-IV.

    ``gps_ns`` int64 (epochs,); ``offset_s`` float, scalar or (epochs, sats). Returns (epochs, sats, 3), NaN
    where the ephemeris is not valid.
    """
    p = eph.params
    tk = _week_time((np.asarray(gps_ns, dtype=np.int64)[:, None] - eph.toe_gps_ns) / NS_PER_S + offset_s)
    a = p["sqrt_a_sqrt_m"] ** 2
    e = p["eccentricity"]
    ek = _eccentric_anomaly(eph, tk)
    nu = np.arctan2(np.sqrt(1.0 - e**2) * np.sin(ek), np.cos(ek) - e)  # true anomaly
    phi = nu + p["omega_rad"]  # argument of latitude
    s2, c2 = np.sin(2.0 * phi), np.cos(2.0 * phi)
    u = phi + p["cus_rad"] * s2 + p["cuc_rad"] * c2
    r = a * (1.0 - e * np.cos(ek)) + p["crs_m"] * s2 + p["crc_m"] * c2
    i = p["i0_rad"] + p["idot_rad_per_s"] * tk + p["cis_rad"] * s2 + p["cic_rad"] * c2
    x_orb, y_orb = r * np.cos(u), r * np.sin(u)
    toe = p["toe_s"]
    we = _constant(eph, "omega_e_rad_per_s", OMEGA_EARTH_RAD_PER_S)
    omega = p["omega0_rad"] + (p["omega_dot_rad_per_s"] - we) * tk - we * toe
    co, so, ci = np.cos(omega), np.sin(omega), np.cos(i)
    ecef = np.stack([x_orb * co - y_orb * ci * so, x_orb * so + y_orb * ci * co, y_orb * np.sin(i)], axis=-1)
    geo = p.get("geo")
    if geo is None or not np.any(geo == 1.0):
        return ecef
    # BeiDou GEO (BDS ICD B1I Table 5-11): node angle without the Earth rate in tk, then R_Z(we tk) R_X(-5 deg).
    omega_g = p["omega0_rad"] + p["omega_dot_rad_per_s"] * tk - we * toe
    cg, sg = np.cos(omega_g), np.sin(omega_g)
    xg, yg, zg = x_orb * cg - y_orb * ci * sg, x_orb * sg + y_orb * ci * cg, y_orb * np.sin(i)
    c5, s5 = np.cos(np.radians(-5.0)), np.sin(np.radians(-5.0))
    y5, z5 = c5 * yg + s5 * zg, -s5 * yg + c5 * zg
    cz, sz = np.cos(we * tk), np.sin(we * tk)
    geo_ecef = np.stack([cz * xg + sz * y5, -sz * xg + cz * y5, z5], axis=-1)
    return np.where((geo == 1.0)[..., None], geo_ecef, ecef)


def satellite_clock_s(eph: BroadcastEphemeris, gps_ns, offset_s=0.0, *, l1_tgd: bool = True) -> np.ndarray:
    """Satellite clock offset ``dt_sv`` (s) at ``gps_ns + offset_s``: polynomial + relativistic ``- T_GD``.

    IS-GPS-200 20.3.3.3.3.1 (``dt_sv = af0 + af1 dt + af2 dt^2 + F e sqrt(A) sin E_k``) and 20.3.3.3.3.2
    (``(dt_sv)_L1 = dt_sv - T_GD``, applied when ``l1_tgd``). Shape (epochs, sats).
    """
    p = eph.params
    ref = np.asarray(gps_ns, dtype=np.int64)[:, None]
    dt = _week_time((ref - eph.toc_gps_ns) / NS_PER_S + offset_s)
    tk = _week_time((ref - eph.toe_gps_ns) / NS_PER_S + offset_s)
    ek = _eccentric_anomaly(eph, tk)
    f_rel = -2.0 * np.sqrt(_constant(eph, "gm_m3_per_s2", GM_M3_PER_S2)) / SPEED_OF_LIGHT_M_PER_S**2
    rel = f_rel * p["eccentricity"] * p["sqrt_a_sqrt_m"] * np.sin(ek)
    clock = p["af0_s"] + p["af1_s_per_s"] * dt + p["af2_s_per_s2"] * dt**2 + rel
    delay = p["group_delay_s"] if "group_delay_s" in p else p["tgd_s"]
    return clock - delay if l1_tgd else clock


def rotate_earth(position_m: np.ndarray, angle_rad: np.ndarray) -> np.ndarray:
    """Rotate ECEF positions (..., 3) about the z axis by ``-angle`` (R3(omega_e tau)): the emission-time
    ECEF frame expressed in the receive-time ECEF frame (Sagnac correction)."""
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    x, y, z = position_m[..., 0], position_m[..., 1], position_m[..., 2]
    return np.stack([c * x + s * y, -s * x + c * y, z], axis=-1)


@dataclass(frozen=True)
class SignalGeometry:
    """Satellite-to-receiver geometry per (epoch, sat): ``satellite_m`` (epochs, sats, 3) at emission in the
    receive-time ECEF frame, ``range_m`` geometric range, ``transit_s`` light time, ``clock_s`` satellite
    clock offset (L1, with T_GD), ``emission_offset_s`` emission time minus the epoch tag (s)."""

    satellite_m: np.ndarray
    range_m: np.ndarray
    transit_s: np.ndarray
    clock_s: np.ndarray
    emission_offset_s: np.ndarray


def _transit(eph, gps_ns, offset_s, receiver_m) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Satellite position rotated by the light time from its emission at ``gps_ns + offset_s`` to the receiver."""
    sat = satellite_position_ecef(eph, gps_ns, offset_s)
    tau = np.linalg.norm(sat - receiver_m, axis=-1) / SPEED_OF_LIGHT_M_PER_S
    for _ in range(_LIGHT_TIME_ITERATIONS):
        rotated = rotate_earth(sat, OMEGA_EARTH_RAD_PER_S * tau)
        tau = np.linalg.norm(rotated - receiver_m, axis=-1) / SPEED_OF_LIGHT_M_PER_S
    rotated = rotate_earth(sat, OMEGA_EARTH_RAD_PER_S * tau)
    return rotated, np.linalg.norm(rotated - receiver_m, axis=-1), tau


def geometry_from_pseudorange(eph: BroadcastEphemeris, gps_ns, pseudorange_m, receiver_m) -> SignalGeometry:
    """Geometry with the emission time from the pseudorange (exact for any receiver clock error).

    The satellite's time of emission is ``t_tag - rho / c``; GPS time of emission is that minus ``dt_sv``
    (evaluated there; a second pass makes it self-consistent to < 1e-15 s). ``gps_ns`` int64 (epochs,),
    ``pseudorange_m`` (epochs, sats), ``receiver_m`` (3,).
    """
    receiver_m = np.asarray(receiver_m, dtype=np.float64)
    sv_time_offset = -np.asarray(pseudorange_m, dtype=np.float64) / SPEED_OF_LIGHT_M_PER_S
    clock = satellite_clock_s(eph, gps_ns, sv_time_offset)
    clock = satellite_clock_s(eph, gps_ns, sv_time_offset - clock)
    offset = sv_time_offset - clock
    sat, rng, tau = _transit(eph, gps_ns, offset, receiver_m)
    return SignalGeometry(sat, rng, tau, clock, offset)


def geometry_from_light_time(eph: BroadcastEphemeris, gps_ns, receiver_m) -> SignalGeometry:
    """Geometry for a known true receive time ``gps_ns``: the light-time iteration
    ``tau_{i+1} = |R3(omega_e tau_i) r_sat(t - tau_i) - r_rx| / c`` (converges to < 1e-12 s in a few steps)."""
    receiver_m = np.asarray(receiver_m, dtype=np.float64)
    gps_ns = np.asarray(gps_ns, dtype=np.int64)
    tau = np.full(eph.valid.shape, 0.075)
    for _ in range(_LIGHT_TIME_ITERATIONS):
        sat = rotate_earth(satellite_position_ecef(eph, gps_ns, -tau), OMEGA_EARTH_RAD_PER_S * tau)
        tau = np.linalg.norm(sat - receiver_m, axis=-1) / SPEED_OF_LIGHT_M_PER_S
    sat = rotate_earth(satellite_position_ecef(eph, gps_ns, -tau), OMEGA_EARTH_RAD_PER_S * tau)
    rng = np.linalg.norm(sat - receiver_m, axis=-1)
    clock = satellite_clock_s(eph, gps_ns, -tau)
    return SignalGeometry(sat, rng, tau, clock, -tau)


__all__ = [
    "EPHEMERIS_FIELDS",
    "GM_M3_PER_S2",
    "OMEGA_EARTH_RAD_PER_S",
    "RELATIVISTIC_F_S_PER_SQRT_M",
    "BroadcastEphemeris",
    "GpsNavigation",
    "SignalGeometry",
    "geometry_from_light_time",
    "geometry_from_pseudorange",
    "rotate_earth",
    "satellite_clock_s",
    "satellite_position_ecef",
    "select_ephemeris",
    "MAX_DTOE_S",
]
