"""The simulated error budget held against the real stations: the same day, place and satellites, simulated.

For a real station (:mod:`chronofuse.experiments.real_stations`) the simulation puts a static receiver at
its published coordinate, takes the satellites of its broadcast ephemeris at the file's epochs and the
Klobuchar coefficients of its navigation file (the ionosphere of that day), and draws the error budget of
:mod:`chronofuse.gnss.simulate` (``open-sky``) trial by trial; the fixes are the same weighted least squares.
The real statistics carry a block-bootstrap interval (blocks of one hour: the errors are correlated over tens
of minutes, so single epochs are not independent), the simulated ones the interval over trials.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pymap3d

from chronofuse.experiments.real_stations import RealStation
from chronofuse.gnss.lsq_position import least_squares_position
from chronofuse.gnss.point_positioning import enu_errors_m, point_positions
from chronofuse.gnss.simulate import ENVIRONMENTS, SignalEnvironment, broadcast_satellites, simulate_pseudoranges
from chronofuse.seeding import child_rng, root_seed
from chronofuse.timescale import NS_PER_S, week_tow

__all__ = ["horizontal95_ci_block_bootstrap", "real_horizontal_errors", "simulated_station", "station_budget_check"]


def horizontal95_ci_block_bootstrap(horizontal_m: np.ndarray, block: int, *, resamples: int = 2000, level=0.95,
                                    seed=0) -> tuple[float, float, float]:
    """95th percentile of ``horizontal_m`` (epochs,) and its moving-block bootstrap interval (Kuensch 1989):
    blocks of ``block`` consecutive epochs drawn with replacement. Returns ``(value, low, high)``."""
    h = np.asarray(horizontal_m, dtype=np.float64)
    h = h[np.isfinite(h)]
    n_blocks = max(1, h.size // block)
    rng = child_rng(root_seed(seed), 0)
    starts = rng.integers(0, h.size - block + 1, size=(resamples, n_blocks))
    idx = (starts[..., None] + np.arange(block)).reshape(resamples, -1)
    values = np.percentile(h[idx], 95, axis=1)
    a = (1.0 - level) / 2.0
    return float(np.percentile(h, 95)), float(np.quantile(values, a)), float(np.quantile(values, 1 - a))


def real_horizontal_errors(station: RealStation, systems=("G",)) -> np.ndarray:
    """Horizontal errors (m, (epochs,)) of our fixes of the station's real file against its coordinate."""
    fixes = point_positions(station.observations(), station.navigation(), systems)
    enu = enu_errors_m(fixes.position_m, station.reference_arp_m)
    return np.hypot(enu[:, 0], enu[:, 1])


def simulated_station(station: RealStation, trials: int, *, env: SignalEnvironment | None = None, seed=0,
                      systems=("G",), step: int = 1) -> np.ndarray:
    """Horizontal errors (m, (trials, epochs)) of simulated fixes at the station (module docstring); ``step``
    thins the file's epochs (2: every minute)."""
    obs, nav = station.observations(), station.navigation()
    env = env or ENVIRONMENTS["open-sky"]
    if nav.klobuchar_alpha is not None:
        env = dataclasses.replace(env, klobuchar_alpha=tuple(nav.klobuchar_alpha), klobuchar_beta=tuple(nav.klobuchar_beta))
    gps_ns = obs.gps_ns[::step]
    t = (gps_ns - gps_ns[0]) / NS_PER_S
    sats = broadcast_satellites(nav, int(gps_ns[0]), t, systems)
    receiver = station.reference_arp_m
    tow = float(week_tow(gps_ns[:1])[1][0]) / NS_PER_S
    rx = np.broadcast_to(receiver, (trials, t.size, 3))
    ranges = simulate_pseudoranges(rx, np.zeros((trials, t.size)), t, sats, env, seed=seed, start_tow_s=tow)
    fix = least_squares_position(ranges.satellite_m, ranges.pseudorange_m, ranges.sigma_m, ranges.system,
                                 receiver + 100.0)
    lat, lon, h = pymap3d.ecef2geodetic(*receiver, deg=True)
    d = fix.position_m - receiver
    e, n, _ = pymap3d.uvw2enu(d[..., 0], d[..., 1], d[..., 2], lat, lon, deg=True)
    return np.hypot(e, n)


def station_budget_check(station: RealStation, *, trials: int = 8, seed: int = 0, step: int = 2) -> dict:
    """Real and simulated GPS-only horizontal 95 % at one station, each with its 95 % interval."""
    real = real_horizontal_errors(station)
    value, low, high = horizontal95_ci_block_bootstrap(real[::step], block=int(3600 / (30 * step)), seed=seed)
    sim = simulated_station(station, trials, seed=seed, step=step)
    per_trial = np.nanpercentile(sim, 95, axis=1)
    mean = float(per_trial.mean())
    half = float(1.96 * per_trial.std(ddof=1) / np.sqrt(trials)) if trials > 1 else float("nan")
    spread = (float(np.quantile(per_trial, 0.025)), float(np.quantile(per_trial, 0.975)))
    return {"station": station.name, "real_horizontal95_m": value, "real_ci_m": [low, high],
            "simulated_horizontal95_m": mean, "simulated_ci_m": [mean - half, mean + half],
            "simulated_trial_range_m": list(spread), "trials": trials}
