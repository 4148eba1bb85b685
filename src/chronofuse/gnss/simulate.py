"""Simulated pseudoranges of a moving receiver: visibility, canyon obstruction and reflections, and an error
budget a GNSS engineer would recognise.

Per satellite ``n`` of system ``s`` and epoch ``k`` (Groves 2013, 9.3-9.4 and 10.4)::

    rho = |r_sat - r_rx| + c dt_rx(k) + b_s + e_code + m(k) + F_I(el) I_n(k) + M_T(el) T_n(k) + d_NLOS

* geometry: satellites from :mod:`chronofuse.gnss.constellation`, or from a real broadcast ephemeris
  (:mod:`chronofuse.gnss.ephemeris`); the signal's travel time and the Earth's rotation during it are left
  out on both sides (the solvers here use the same model), so the simulation tests estimators, not signal
  corrections (those are tested on real RINEX in :mod:`chronofuse.gnss.point_positioning`);
* receiver clock ``c dt_rx``: the two-state clock of :mod:`chronofuse.models.clock`; inter-system bias
  ``b_s`` (s > 0) constant per trial, drawn from ``N(0, isb_sigma_m^2)``;
* code noise ``e_code``: white, ``sigma_zenith_m / sin(el)``;
* multipath ``m``: a first-order Gauss-Markov process per channel (correlation time ``multipath_tau_s``)
  whose 1-sigma falls with elevation as ``multipath_floor_m + multipath_low_m exp(-el / 10 deg)`` (the
  shape of the RTCA DO-229D airborne multipath model, Appendix J, whose values 0.13 m + 0.53 m are the
  open-sky defaults);
* residual ionosphere after the broadcast Klobuchar model: per satellite (each its own pierce point) a
  Gauss-Markov process of correlation time ``iono_tau_s`` (30 min: the residual follows the travelling
  ionospheric structures of tens of minutes, Klobuchar 1987 and Groves 2013 9.3.2) with a vertical
  1-sigma of ``iono_zenith_m`` plus ``iono_residual_fraction`` times the Klobuchar vertical delay (the
  broadcast model removes about half of the delay RMS, Klobuchar 1987; the real stations fit a constant
  residual better than a proportional one, docs/positioning), mapped by the thin-shell obliquity
  ``F_I = 1 / sqrt(1 - (R cos el / (R + 350 km))^2)``;
* residual troposphere after Saastamoinen: per satellite a Gauss-Markov zenith residual (``tropo_zenith_m``,
  ``tropo_tau_s`` = 1 h: the wet delay changes over hours), mapped by ``1 / sin(el)``;
* visibility: elevation above ``elevation_mask_deg``; in an urban canyon a satellite at azimuth ``az`` is
  blocked below ``atan(H |sin(az - heading)| / (W / 2))`` (buildings of height ``H`` on both sides of a street
  of width ``W`` along the heading); a blocked satellite is still received, by its reflection off the
  building across the street, a fraction ``nlos_probability`` of the time (per satellite, in spells of
  ``nlos_tau_s``), with the image-geometry extra path ``d_NLOS = 2 (W / 2) cos(el) |sin(az - heading)|``
  (Groves 2013, 10.4.1) and the sigma of a direct signal: the receiver cannot tell;
* a tunnel blocks every satellite during its outages.

Every error term is drawn from its own grandchild seed, so adding a term never changes another's numbers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pymap3d

from chronofuse.constants import SPEED_OF_LIGHT_M_PER_S
from chronofuse.gnss.constellation import constellation, satellite_positions_ecef
from chronofuse.gnss.ephemeris import GpsNavigation, satellite_position_ecef, select_ephemeris
from chronofuse.models.clock import two_state_clock_phase_s
from chronofuse.models.environment import SignalEnvironment, signal_environments
from chronofuse.models.noise import gauss_markov
from chronofuse.seeding import child_rng, root_seed
from chronofuse.timescale import seconds_to_ns
from chronofuse.validation import InputDataError

__all__ = ["SignalEnvironment", "ENVIRONMENTS", "RangeObservations", "Satellites", "model_satellites",
           "broadcast_satellites", "simulate_pseudoranges"]


#: The pseudorange views of the one environment registry (:mod:`chronofuse.models.environment`), by name.
ENVIRONMENTS: dict[str, SignalEnvironment] = signal_environments()


@dataclass(frozen=True)
class RangeObservations:
    """Pseudoranges ``pseudorange_m`` (trials, epochs, S), NaN where not received; ``sigma_m`` (trials,
    epochs, S) the code-noise 1-sigma a receiver would report; ``satellite_m`` (epochs, S, 3) ECEF;
    ``system`` (S,) 0 GPS / 1 BDS; ``elevation_rad`` (trials, epochs, S); truth ``clock_m`` (trials, epochs)
    and ``isb_m`` (trials,); ``t_s`` (epochs,)."""

    pseudorange_m: np.ndarray
    sigma_m: np.ndarray
    satellite_m: np.ndarray
    system: np.ndarray
    ids: tuple[str, ...]
    elevation_rad: np.ndarray
    clock_m: np.ndarray
    isb_m: np.ndarray
    t_s: np.ndarray


def _look_angles(receiver_m: np.ndarray, satellite_m: np.ndarray):
    """Elevation and azimuth (rad) of satellites (epochs, S, 3) from receivers (trials, epochs, 3)."""
    lat, lon, _ = pymap3d.ecef2geodetic(receiver_m[..., 0], receiver_m[..., 1], receiver_m[..., 2], deg=False)
    d = satellite_m[None] - receiver_m[:, :, None, :]
    e, n, u = pymap3d.uvw2enu(d[..., 0], d[..., 1], d[..., 2], lat[..., None], lon[..., None], deg=False)
    return np.arctan2(u, np.hypot(e, n)), np.arctan2(e, n), np.sqrt(e * e + n * n + u * u)


@dataclass(frozen=True)
class Satellites:
    """Where the satellites are at each epoch: ``position_m`` (epochs, S, 3) ECEF, ``system`` (S,) the index
    of each satellite's system in ``systems`` (0 is the reference clock's), ``ids`` (S,) names."""

    position_m: np.ndarray
    system: np.ndarray
    ids: tuple[str, ...]
    systems: tuple[str, ...]


def model_satellites(systems: tuple[str, ...], t_s) -> Satellites:
    """The documented constellation models (:mod:`chronofuse.gnss.constellation`) of ``systems`` at ``t_s``."""
    t = np.asarray(t_s, dtype=np.float64)
    cons = [constellation(s) for s in systems]
    return Satellites(position_m=np.concatenate([satellite_positions_ecef(c, t) for c in cons], axis=1),
                      system=np.concatenate([np.full(len(c), j) for j, c in enumerate(cons)]),
                      ids=tuple(i for c in cons for i in c.ids), systems=tuple(systems))


def broadcast_satellites(nav: GpsNavigation, start_gps_ns: int, t_s, systems=("G",)) -> Satellites:
    """Satellites from a real broadcast ephemeris at ``start_gps_ns + t_s`` (each system's own orbits) of the
    system letters ``systems`` (the first is the reference clock's). A satellite is where a healthy record
    within four hours puts it, and absent (NaN) at epochs without one (a station's own navigation file
    holds the records of the satellites it tracked); satellites never covered are left out."""
    gps_ns = int(start_gps_ns) + seconds_to_ns(np.asarray(t_s, dtype=np.float64))
    names = sorted({n for n in nav.satellites if n[0] in systems}, key=lambda n: (systems.index(n[0]), n))
    eph = select_ephemeris(nav, names, gps_ns)
    keep = eph.valid.any(axis=0)
    if not keep.any():
        raise InputDataError("no satellite has a healthy ephemeris during the run", nav.source)
    position = np.where(eph.valid[..., None], satellite_position_ecef(eph, gps_ns), np.nan)[:, keep]
    ids = tuple(n for n, k in zip(names, keep) if k)
    labels = {"G": "gps", "C": "bds", "E": "gal", "J": "qzss"}
    return Satellites(position_m=position, system=np.array([systems.index(n[0]) for n in ids], dtype=np.intp),
                      ids=ids, systems=tuple(labels[c] for c in systems))


_SHELL_HEIGHT_M = 350e3
_EARTH_RADIUS_M = 6371e3


def ionosphere_obliquity(elevation_rad):
    """Thin-shell mapping of a vertical ionospheric delay to the slant (shell at 350 km, IS-GPS-200's
    Klobuchar geometry): ``1 / sqrt(1 - (R cos el / (R + h))^2)``."""
    x = _EARTH_RADIUS_M * np.cos(elevation_rad) / (_EARTH_RADIUS_M + _SHELL_HEIGHT_M)
    return 1.0 / np.sqrt(1.0 - x * x)


def _klobuchar_vertical_m(env: SignalEnvironment, receiver_m, el, az, t_s, start_tow_s: float) -> np.ndarray:
    """The Klobuchar vertical delay (m) at each receiver, epoch and satellite (the slant delay divided by the
    model's own obliquity)."""
    from chronofuse.gnss.atmosphere import klobuchar_delay_at_s

    lat, lon, _ = pymap3d.ecef2geodetic(receiver_m[..., 0], receiver_m[..., 1], receiver_m[..., 2], deg=False)
    tow = start_tow_s + np.asarray(t_s)[None, :, None]
    slant = klobuchar_delay_at_s(np.asarray(env.klobuchar_alpha), np.asarray(env.klobuchar_beta), lat[..., None],
                                 lon[..., None], el, az, tow)
    obliquity = 1.0 + 16.0 * (0.53 - el / math.pi) ** 3
    return SPEED_OF_LIGHT_M_PER_S * slant / obliquity


def simulate_pseudoranges(receiver_m, heading_rad, t_s, satellites: Satellites, env: SignalEnvironment, *,
                          seed=0, start_tow_s: float = 43_200.0) -> RangeObservations:
    """Pseudoranges of receivers at ECEF ``receiver_m`` (trials, epochs, 3) heading ``heading_rad`` (trials,
    epochs) at times ``t_s`` (epochs,) from ``satellites`` (:func:`model_satellites` or
    :func:`broadcast_satellites`); ``start_tow_s``: GPS time of week of ``t_s = 0`` (the ionosphere's local
    time). Trial ``i`` draws from ``child_seed(seed, i)``, each error term from its own grandchild."""
    receiver = np.asarray(receiver_m, dtype=np.float64)
    t = np.asarray(t_s, dtype=np.float64)
    trials, epochs = receiver.shape[:2]
    sat, system, ids = satellites.position_m, satellites.system, satellites.ids
    n_systems = len(satellites.systems)
    n_sat = sat.shape[1]
    el, az, rng_m = _look_angles(receiver, sat)
    visible = el > math.radians(env.elevation_mask_deg)
    blocked = np.zeros_like(visible)
    across = np.abs(np.sin(az - np.asarray(heading_rad)[..., None]))
    if env.building_height_m > 0.0:
        blocked = visible & ~(el > np.arctan(env.building_height_m * across / (env.street_width_m / 2.0)))
    in_tunnel = np.zeros(t.shape, dtype=bool)
    for start, end in env.outages_s:
        in_tunnel |= (t >= start) & (t < end)
    dt = float(np.median(np.diff(t))) if t.size > 1 else 1.0
    base = root_seed(seed)
    rho = np.empty((trials, epochs, n_sat))
    clock = np.empty((trials, epochs))
    isb = np.zeros((trials, n_systems))
    el_safe = np.maximum(el, math.radians(5.0))
    sin_el = np.sin(el_safe)
    sigma_code = env.sigma_zenith_m / sin_el
    sigma_mp = env.multipath_sigma_m(el_safe)
    vertical_iono = _klobuchar_vertical_m(env, receiver, el_safe, az, t, start_tow_s)
    nlos_delay = 2.0 * (env.street_width_m / 2.0) * np.cos(el_safe) * across
    received = visible & ~blocked
    for i in range(trials):
        draw = lambda k, shape: child_rng(base, i, k).standard_normal(shape)  # noqa: E731
        z = draw(0, (3, epochs))
        clock[i] = SPEED_OF_LIGHT_M_PER_S * two_state_clock_phase_s(z[0], z[1], z[2], h0=env.clock_h0,
                                                                      hm2=env.clock_hm2, dt_s=dt)
        isb[i, 1:] = env.isb_sigma_m * draw(1, n_systems - 1)
        multipath = gauss_markov(draw(2, (n_sat, epochs + 1)), 1.0, env.multipath_tau_s, dt).T * sigma_mp[i]
        vertical_sigma = env.iono_zenith_m + env.iono_residual_fraction * vertical_iono[i]
        iono = (gauss_markov(draw(3, (n_sat, epochs + 1)), 1.0, env.iono_tau_s, dt).T
                * vertical_sigma * ionosphere_obliquity(el_safe[i]))
        tropo = gauss_markov(draw(4, (n_sat, epochs + 1)), env.tropo_zenith_m, env.tropo_tau_s, dt).T / sin_el[i]
        noise = sigma_code[i] * draw(5, (epochs, n_sat))
        rho[i] = (rng_m[i] + clock[i][:, None] + isb[i, system][None, :] + noise + multipath + iono + tropo)
        if env.nlos_probability > 0.0:
            # a reflection is received while a per-satellite Gauss-Markov state sits below the quantile
            state = gauss_markov(draw(6, (n_sat, epochs + 1)), 1.0, env.nlos_tau_s, dt).T
            reflected = blocked[i] & (state < _normal_quantile(env.nlos_probability))
            rho[i] = np.where(reflected, rho[i] + nlos_delay[i], rho[i])
            received[i] |= reflected
    received[:, in_tunnel] = False
    rho[~received] = np.nan
    return RangeObservations(pseudorange_m=rho, sigma_m=np.hypot(sigma_code, sigma_mp), satellite_m=sat,
                             system=system, ids=ids, elevation_rad=el, clock_m=clock, isb_m=isb[:, 1:], t_s=t)


def _normal_quantile(p: float) -> float:
    from scipy.stats import norm

    return float(norm.ppf(p))
