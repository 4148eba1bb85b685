"""Simulated pseudoranges of a moving receiver: visibility, canyon obstruction, noise, multipath, atmosphere.

Per satellite ``n`` of system ``s`` and epoch ``k`` (Groves 2013, 9.3 and 10.4)::

    rho = |r_sat - r_rx| + c dt_rx(k) + b_s + sigma_el eps + m(k) + (I_z + T_z) / sin(el)

* geometry: satellites from :mod:`chronofuse.gnss.constellation`, or GPS satellites from a real broadcast
  ephemeris (:mod:`chronofuse.gnss.ephemeris`); the signal's travel time and the Earth's
  rotation during it are left out on both sides (the solvers here use the same model), so the simulation
  tests estimators, not signal corrections (those are tested on real RINEX in :mod:`chronofuse.gnss.spp`);
* receiver clock ``c dt_rx``: the two-state clock of :mod:`chronofuse.models.clock` (white and random-walk
  FM); inter-system bias ``b_s`` (s > 0): constant per trial, drawn from ``N(0, isb_sigma_m^2)``;
* code noise ``sigma_zenith_m / sin(el)`` white; multipath ``m``: a first-order Gauss–Markov per channel
  (``multipath_sigma_m``, ``multipath_tau_s``), larger in a canyon;
* residual ionosphere and troposphere after broadcast models: zenith residuals per trial and satellite
  (drawn ``N(0, zenith^2)``), mapped by ``1 / sin(el)``;
* visibility: elevation above ``elevation_mask_deg``; in an urban canyon a satellite at azimuth ``az`` is
  also blocked below ``atan(H |sin(az - heading)| / (W / 2))`` (buildings of height ``H`` on both sides of a
  street of width ``W`` along the vehicle's heading); a tunnel blocks every satellite during its outages.
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


def broadcast_satellites(nav: GpsNavigation, start_gps_ns: int, t_s) -> Satellites:
    """GPS satellites from a real broadcast ephemeris at ``start_gps_ns + t_s`` (IS-GPS-200 orbits); the
    satellites with no healthy record within four hours of the start are left out."""
    gps_ns = int(start_gps_ns) + seconds_to_ns(np.asarray(t_s, dtype=np.float64))
    names = sorted(set(nav.satellites))
    eph = select_ephemeris(nav, names, gps_ns)
    keep = eph.valid.all(axis=0)
    if not keep.any():
        raise InputDataError("no GPS satellite has a healthy ephemeris over the whole run", nav.source)
    position = satellite_position_ecef(eph, gps_ns)[:, keep]
    ids = tuple(n for n, k in zip(names, keep) if k)
    return Satellites(position_m=position, system=np.zeros(len(ids), dtype=np.intp), ids=ids, systems=("gps",))


def simulate_pseudoranges(receiver_m, heading_rad, t_s, satellites: Satellites, env: SignalEnvironment, *,
                          seed=0) -> RangeObservations:
    """Pseudoranges of receivers at ECEF ``receiver_m`` (trials, epochs, 3) heading ``heading_rad`` (trials,
    epochs) at times ``t_s`` (epochs,) from ``satellites`` (:func:`model_satellites` or
    :func:`broadcast_satellites`); trial ``i`` draws from ``child_seed(seed, i)``."""
    receiver = np.asarray(receiver_m, dtype=np.float64)
    t = np.asarray(t_s, dtype=np.float64)
    trials, epochs = receiver.shape[:2]
    sat, system, ids = satellites.position_m, satellites.system, satellites.ids
    n_systems = len(satellites.systems)
    n_sat = sat.shape[1]
    el, az, rng_m = _look_angles(receiver, sat)
    visible = el > math.radians(env.elevation_mask_deg)
    if env.building_height_m > 0.0:
        across = np.abs(np.sin(az - np.asarray(heading_rad)[..., None]))
        visible &= el > np.arctan(env.building_height_m * across / (env.street_width_m / 2.0))
    for start, end in env.outages_s:
        visible[:, (t >= start) & (t < end)] = False
    dt = float(np.median(np.diff(t))) if t.size > 1 else 1.0
    base = root_seed(seed)
    rho = np.empty((trials, epochs, n_sat))
    clock = np.empty((trials, epochs))
    isb = np.zeros((trials, n_systems))
    sin_el = np.maximum(np.sin(el), math.sin(math.radians(5.0)))
    sigma = env.sigma_zenith_m / sin_el
    for i in range(trials):
        rng = child_rng(base, i)
        z = rng.standard_normal((3, epochs))
        clock[i] = SPEED_OF_LIGHT_M_PER_S * two_state_clock_phase_s(z[0], z[1], z[2], h0=env.clock_h0,
                                                                      hm2=env.clock_hm2, dt_s=dt)
        isb[i, 1:] = env.isb_sigma_m * rng.standard_normal(n_systems - 1)
        multipath = gauss_markov(rng.standard_normal((n_sat, epochs + 1)), env.multipath_sigma_m,
                                 env.multipath_tau_s, dt).T
        zenith = env.iono_zenith_m * rng.standard_normal(n_sat) + env.tropo_zenith_m * rng.standard_normal(n_sat)
        noise = sigma[i] * rng.standard_normal((epochs, n_sat))
        rho[i] = (rng_m[i] + clock[i][:, None] + isb[i, system][None, :] + noise + multipath
                  + zenith[None, :] / sin_el[i])
    rho[~visible] = np.nan
    return RangeObservations(pseudorange_m=rho, sigma_m=np.hypot(sigma, env.multipath_sigma_m), satellite_m=sat,
                             system=system, ids=ids, elevation_rad=el, clock_m=clock, isb_m=isb[:, 1:], t_s=t)
