"""A simulated drive: the vehicle's truth, its IMU, and the GNSS fixes the filters take.

The drive is a city loop at ``speed_m_per_s``: straight legs joined by 90-degree turns, each turn made of
one-second pieces of constant acceleration perpendicular to the velocity (the one trajectory model,
:func:`chronofuse.models.kinematics.manoeuvre`, whose segments have constant acceleration). The GNSS
receiver sits at the IMU (no lever arm); its fixes come from :func:`chronofuse.gnss.lsq_position.least_squares_position`
on :func:`chronofuse.gnss.simulate.simulate_pseudoranges` in the scenario's signal environment.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pymap3d

from chronofuse.gnss.lsq_position import least_squares_position
from chronofuse.gnss.ephemeris import GpsNavigation
from chronofuse.positioning import MAX_SPEED_M_PER_S, SYSTEMS
from chronofuse.gnss.simulate import ENVIRONMENTS, broadcast_satellites, model_satellites, simulate_pseudoranges
from chronofuse.models.imu import ImuModel, imu_grade, simulate_imu
from chronofuse.models.kinematics import Trajectory, manoeuvre
from chronofuse.positioning.truth import NavigationTruth, imu_truth, navigation_truth
from chronofuse.seeding import child_seed, root_seed
from chronofuse.validation import InputDataError, InputError, check_choice, check_scalar

__all__ = ["DriveData", "city_loop", "simulate_drive", "DEFAULT_ORIGIN", "SYSTEMS", "MAX_SPEED_M_PER_S"]

#: Wuhan, 30.5 N 114.3 E, 30 m: under the BDS GEO and IGSO arcs.
DEFAULT_ORIGIN = np.array([math.radians(30.5), math.radians(114.3), 30.0])
_ENU_TO_NED = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])


def city_loop(duration_s: float, speed_m_per_s: float = 12.0, leg_s: float = 60.0, turn_s: float = 8.0) -> Trajectory:
    """Legs of ``leg_s`` joined by right turns of ``turn_s`` (1-s constant-acceleration pieces), from the origin
    heading north, for at least ``duration_s``."""
    check_scalar(speed_m_per_s, "speed_m_per_s", min_val=0.0, include_min=False, max_val=MAX_SPEED_M_PER_S)
    starts, accels = [], []
    t, heading = 0.0, 0.0
    rate = (math.pi / 2) / turn_s
    while t < duration_s + leg_s:
        starts.append(t)
        accels.append([0.0, 0.0, 0.0])
        t += leg_s
        for _ in range(int(turn_s)):
            mid = heading + rate * 0.5  # perpendicular to the velocity at the piece's midpoint
            a = speed_m_per_s * rate
            starts.append(t)
            accels.append([-a * math.sin(mid), a * math.cos(mid), 0.0])
            heading += rate
            t += 1.0
    return manoeuvre(np.zeros(3), [speed_m_per_s, 0.0, 0.0], np.array(starts), np.array(accels))


@dataclass(frozen=True)
class DriveData:
    """One simulated drive for ``trials`` trials.

    ``truth`` at the GNSS epochs (:class:`NavigationTruth` sampled every ``gnss_interval_s``, the first row the
    start); IMU blocks ``gyro_rad_per_s``, ``accel_m_per_s2`` (trials, epochs, samples, 3) measured between
    epochs; GNSS ``fix_lat_lon_h`` (trials, epochs, 3), NaN without a fix, its ``fix_cov_ned_m2`` (trials,
    epochs, 3, 3) and ``gdop`` (trials, epochs); ``imu_rate_hz``; the pseudoranges the fixes came from,
    for tight coupling: ``pseudorange_m`` and ``sigma_m`` (trials, epochs, S), ``satellite_m`` (epochs, S, 3)
    ECEF and ``system`` (S,)."""

    truth: NavigationTruth
    gyro_rad_per_s: np.ndarray
    accel_m_per_s2: np.ndarray
    fix_lat_lon_h: np.ndarray
    fix_cov_ned_m2: np.ndarray
    gdop: np.ndarray
    imu_rate_hz: float
    pseudorange_m: np.ndarray | None = None
    sigma_m: np.ndarray | None = None
    satellite_m: np.ndarray | None = None
    system: np.ndarray | None = None


def simulate_drive(scenario: str, systems: str, imu: str | ImuModel, duration_s: float, trials: int, *, seed=0,
                   imu_rate_hz: float = 100.0, speed_m_per_s: float = 12.0, first_trial: int = 0,
                   nav: GpsNavigation | None = None, environment=None) -> DriveData:
    """Simulate ``trials`` drives of ``duration_s`` in ``scenario`` (a key of
    :data:`chronofuse.gnss.simulate.ENVIRONMENTS`) with ``systems`` ("gps" or "gps+bds") and the IMU ``imu`` (a
    grade name or an :class:`~chronofuse.models.imu.ImuModel`).

    Trial ``i`` draws from ``child_seed(seed, first_trial + i, ...)``, so a run split into chunks of trials gives
    the same numbers as one run. With ``nav`` (a real GPS broadcast ephemeris) the GPS satellites are where it
    puts them, the drive starting at the file's first clock reference time; ``environment`` (a
    :class:`~chronofuse.gnss.simulate.SignalEnvironment`) replaces the scenario's signal environment; it must then hold every system
    asked for (it is refused, naming the file, for "gps+bds": our navigation reader takes GPS records only).
    """
    check_choice(scenario, "scenario", ENVIRONMENTS)
    check_choice(systems, "systems", SYSTEMS)
    check_scalar(imu_rate_hz, "imu_rate_hz", min_val=10.0)
    check_scalar(duration_s, "duration_s", min_val=1.0)
    check_scalar(trials, "trials", min_val=1, integer=True)
    samples = int(round(imu_rate_hz))
    epochs = int(duration_s)
    motion = navigation_truth(city_loop(duration_s, speed_m_per_s), DEFAULT_ORIGIN, float(epochs), imu_rate_hz)
    gyro_true, accel_true = imu_truth(motion)
    model = imu if isinstance(imu, ImuModel) else imu_grade(imu)
    base = root_seed(seed)
    gyro = np.empty((trials, epochs, samples, 3))
    accel = np.empty_like(gyro)
    for i in range(trials):
        meas = simulate_imu(model, gyro_true[0], accel_true[0], imu_rate_hz,
                            seed=child_seed(base, first_trial + i, 0), bias_rate_hz=1.0)
        gyro[i] = meas.gyro_rad_per_s[0].reshape(epochs, samples, 3)
        accel[i] = meas.accel_m_per_s2[0].reshape(epochs, samples, 3)
    at_epochs = slice(samples, None, samples)  # the state at the end of each IMU block
    lat_lon_h = motion.lat_lon_h[0, at_epochs]
    receiver = np.stack(pymap3d.geodetic2ecef(lat_lon_h[:, 0], lat_lon_h[:, 1], lat_lon_h[:, 2], deg=False), -1)
    v = motion.v_ned_m_per_s[0, at_epochs]
    heading = np.arctan2(v[:, 1], v[:, 0])
    t = np.arange(1, epochs + 1, dtype=np.float64)
    if nav is None:
        satellites = model_satellites(SYSTEMS[systems], t)
    elif systems != "gps":
        raise InputError(f"no {' or '.join(s.upper() for s in SYSTEMS[systems][1:])} satellite in the "
                         "navigation file (only its GPS records are read): set {systems} to gps, or give no {nav}",
                         nav.source, fields=("systems", "nav"))
    else:
        satellites = broadcast_satellites(nav, int(nav.toc_gps_ns.min()), t)
    fixes = np.empty((trials, epochs, 3))
    cov = np.empty((trials, epochs, 3, 3))
    gdop = np.empty((trials, epochs))
    rho = np.empty((trials, epochs, satellites.position_m.shape[1]))
    sigma = np.empty_like(rho)
    for i in range(trials):
        env = ENVIRONMENTS[scenario] if environment is None else environment
        obs = simulate_pseudoranges(receiver[None], heading[None], t, satellites, env,
                                    seed=child_seed(base, first_trial + i, 1))
        rho[i], sigma[i] = obs.pseudorange_m[0], obs.sigma_m[0]
        fix = least_squares_position(obs.satellite_m, obs.pseudorange_m[0], obs.sigma_m[0], obs.system,
                                     receiver[0] + 1e3)
        lat, lon, h = pymap3d.ecef2geodetic(fix.position_m[:, 0], fix.position_m[:, 1], fix.position_m[:, 2], deg=False)
        fixes[i] = np.stack([lat, lon, h], -1)
        cov[i] = _ENU_TO_NED @ fix.cov_enu_m2 @ _ENU_TO_NED.T
        gdop[i] = fix.gdop
    truth = NavigationTruth(t_s=motion.t_s[::samples], lat_lon_h=motion.lat_lon_h[:, ::samples],
                            v_ned_m_per_s=motion.v_ned_m_per_s[:, ::samples], c_bn=motion.c_bn[:, ::samples],
                            rate_hz=1.0)
    return DriveData(truth=truth, gyro_rad_per_s=gyro, accel_m_per_s2=accel, fix_lat_lon_h=fixes,
                     fix_cov_ned_m2=np.where(np.isfinite(cov), cov, np.eye(3)), gdop=gdop,
                     imu_rate_hz=float(imu_rate_hz), pseudorange_m=rho, sigma_m=sigma,
                     satellite_m=satellites.position_m, system=satellites.system)
