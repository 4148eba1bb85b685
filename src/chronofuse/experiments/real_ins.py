"""GNSS/INS on real files: an IMU log aligned with a RINEX observation file, loosely or tightly coupled.

The single-point pass (:func:`chronofuse.gnss.point_positioning.point_positions`) comes first: its fixes
feed the loosely coupled filter (:class:`chronofuse.positioning.loose.LooselyCoupled`, each fix with the
covariance of its least-squares solution), and its corrected pseudoranges (satellite clock, ionosphere,
troposphere removed; the satellites at emission, rotated for the light time: the measurement model of
:mod:`chronofuse.positioning.tight`) feed the tightly coupled one
(:class:`chronofuse.positioning.tight.TightlyCoupled`), so that one to three satellites still correct the
INS where no fix exists. ``smooth`` adds the Rauch-Tung-Striebel pass over the filter's error states.

Alignment (:func:`align_imu`): the observation epochs are placed on their regular grid (the median interval;
a missing epoch is a grid epoch without a measurement); block ``k`` holds the IMU samples at
``t_{k-1} + j dt``, ``j = 1 .. interval / dt`` (``dt`` the log's interval), each matched to the log's sample
within ``dt / 2`` of it. Samples the log lacks (a gap) are held from the last sample before, and reported
(a warning). The INS runs over the grid epochs the log covers; a log that covers none (another day,
another receiver) is refused naming it.

Start (a coarse static alignment): position and receiver clock from the first single-point fix on the
covered span, velocity zero, roll and pitch from the mean specific force of the :data:`ALIGNMENT_S` seconds
of the log from that fix's epoch (the INS start), heading by gyrocompassing from the mean angular rate over
the same samples
(meaningful only when the gyro biases are well below the Earth rate; the heading's initial 1-sigma is
:data:`HEADING_SIGMA_RAD`); the gyro biases are taken as the mean rate less the Earth rate in that attitude
(left: at most the Earth rate, 7.3e-5 rad/s, where an industrial gyro's turn-on bias is 3.5e-3 rad/s), the
accelerometer bias along the vertical as the mean specific force less normal gravity (left: the local
gravity anomaly, about 0.1 mg); both are removed from the samples and the filters estimate the rest. The
antenna must be at rest over those seconds: :func:`check_at_rest` refuses, naming the log, a window whose
mean rate exceeds the Earth rate by more than 3 gyro turn-on biases of the grade (at least 1e-4 rad/s; for
industrial about 0.01 rad/s), whose mean specific force is more than 0.5 m/s^2 (or 5 accelerometer turn-on
biases) from normal gravity (a moving body, or accelerometers in g), or whose samples scatter by more than
10 times the grade's white noise (at least 1e-3 rad/s and 0.05 m/s^2). A log below :data:`MIN_RATE_HZ` is
refused naming it and its rate.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, replace

import numpy as np
import pymap3d

from chronofuse.timescale import NS_PER_S, gps_ns_to_datetime64
from chronofuse.validation import InputDataError, InputWarning, invalid

__all__ = ["COUPLINGS", "ALIGNMENT_S", "HEADING_SIGMA_RAD", "MIN_RATE_HZ", "alignment_window", "check_at_rest", "AlignedImu", "align_imu", "static_alignment",
           "ins_positions", "InsSolution", "as_point_positions", "ins_statistics", "ins_from_files"]

#: The couplings :func:`ins_positions` offers.
COUPLINGS = ("loose", "tight")
#: Seconds of the log's start averaged for the static alignment.
ALIGNMENT_S = 10.0
#: Initial 1-sigma of the heading (rad): gyrocompassing with an industrial gyro's bias is not a heading.
HEADING_SIGMA_RAD = 0.5
_ENU_TO_NED = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])


def _when(gps_ns) -> str:
    return str(gps_ns_to_datetime64(np.int64(gps_ns)))[:19].replace("T", " ")


@dataclass(frozen=True)
class AlignedImu:
    """The log cut into the grid's blocks: ``grid_ns`` (epochs,) the regular epoch grid of the covered span,
    ``observed`` (epochs,) the index of each grid epoch in the observations (-1: no epoch there), ``gyro``
    and ``accel`` (epochs, samples, 3) (block 0 unused: the start), ``held`` (epochs,) samples held per
    block, ``gaps`` a list of ``(first missing sample ns, samples missing)``."""

    grid_ns: np.ndarray
    observed: np.ndarray
    gyro: np.ndarray
    accel: np.ndarray
    held: np.ndarray
    gaps: list


def align_imu(log, epochs_gps_ns, obs_source: str = "") -> AlignedImu:
    """Place the observation epochs on their grid and cut ``log`` (:class:`chronofuse.io.imu_log.ImuLog`)
    into its blocks (module docstring). Raises :class:`InputDataError` naming the log when it covers no
    interval of the epochs or its interval does not divide theirs; warns on a gap and on a partial cover."""
    t = np.asarray(epochs_gps_ns, dtype=np.int64)
    if t.size < 2:
        raise InputDataError("GNSS/INS needs at least two observation epochs", obs_source or None)
    step = int(np.median(np.diff(t)))
    off = (t - t[0]) % step
    if (off != 0).any():
        k = int(np.flatnonzero(off)[0])
        raise InputDataError(f"epoch {_when(t[k])} is off the observations' {step / NS_PER_S:g} s grid",
                             obs_source or None)
    dt = int(round(NS_PER_S / log.rate_hz))
    samples = int(round(step / dt))
    if samples < 1 or abs(samples * dt - step) > dt // 100:
        raise InputDataError(f"the observation interval {step / NS_PER_S:g} s is not a whole number of IMU "
                             f"samples ({dt / NS_PER_S:g} s)", log.source)
    grid = t[0] + step * np.arange((t[-1] - t[0]) // step + 1, dtype=np.int64)
    lo, hi = int(log.gps_ns[0]) - dt // 2, int(log.gps_ns[-1]) + dt // 2
    # the grid epochs within the log: the first is the start (no block), each later one's interval is inside
    inside = np.flatnonzero((grid >= lo) & (grid <= hi))
    if inside.size < 2:
        raise InputDataError(f"the IMU samples ({_when(log.gps_ns[0])} to {_when(log.gps_ns[-1])} GPS) do not "
                             f"overlap the observation epochs ({_when(t[0])} to {_when(t[-1])} GPS"
                             + (f" of {obs_source}" if obs_source else "") + "): a log of another day or receiver?",
                             log.source)
    grid = grid[inside[0]:inside[-1] + 1]
    observed = np.full(grid.size, -1, dtype=np.intp)
    where = np.searchsorted(t, grid)
    hit = (where < t.size) & (t[np.minimum(where, t.size - 1)] == grid)
    observed[hit] = where[hit]
    n_obs = int(hit.sum())
    if n_obs < t.size:
        warnings.warn(InputWarning(f"{log.source}: the IMU log covers {n_obs} of the {t.size} observation epochs "
                                   f"({_when(grid[0])} to {_when(grid[-1])} GPS); the GNSS/INS solution is on those "
                                   "only"), stacklevel=2)
    times = grid[:, None] - step + dt * np.arange(1, samples + 1)[None, :]
    i = np.searchsorted(log.gps_ns, times - dt // 2, side="left")
    found = (i < log.gps_ns.size) & (np.abs(log.gps_ns[np.minimum(i, log.gps_ns.size - 1)] - times) <= dt // 2)
    found[0] = True  # block 0 is the start, never integrated
    # a missing sample is held from the last sample before it
    idx = np.where(found, np.minimum(i, log.gps_ns.size - 1), np.maximum(i - 1, 0))
    missing = ~found.ravel()
    gaps = []
    if missing.any():
        flat = times.ravel()
        runs = np.flatnonzero(np.diff(np.r_[0, missing.astype(np.int8), 0]))
        for a, b in zip(runs[::2], runs[1::2]):
            gaps.append((int(flat[a]), int(b - a)))
        longest = max(gaps, key=lambda g: g[1])
        warnings.warn(InputWarning(
            f"{log.source}: {len(gaps)} gap{'s' if len(gaps) != 1 else ''} in the IMU samples ({int(missing.sum())} "
            f"missing at {log.rate_hz:g} Hz), the longest {longest[1] * dt / NS_PER_S:g} s from {_when(longest[0])} "
            "GPS: the INS held the last sample through them"), stacklevel=2)
    return AlignedImu(grid_ns=grid, observed=observed, gyro=log.gyro_rad_per_s[idx], accel=log.accel_m_per_s2[idx],
                      held=(~found).sum(-1), gaps=gaps)


#: The lowest IMU rate the filters integrate (Hz).
MIN_RATE_HZ = 10.0
#: At-rest test of the alignment window (:func:`check_at_rest`): the mean rate may exceed the Earth rate by
#: this many times the grade's gyro turn-on bias (1-sigma), and by at least :data:`REST_RATE_FLOOR_RAD_PER_S`.
REST_BIAS_SIGMAS = 3.0
REST_RATE_FLOOR_RAD_PER_S = 1e-4
#: ... the mean specific force's magnitude may differ from normal gravity by this (m/s^2), or by 5 times the
#: grade's accelerometer turn-on bias where that is more.
REST_GRAVITY_M_PER_S2 = 0.5
#: ... and the samples' standard deviation (each axis) may reach this many times the grade's white noise at
#: the log's rate, and at least the floors (a rate, rad/s; a specific force, m/s^2).
REST_NOISE_TIMES = 10.0
REST_STD_FLOORS = (1e-3, 0.05)


def alignment_window(log, start_ns=None) -> slice:
    """The samples of the static alignment: :data:`ALIGNMENT_S` s of ``log`` from ``start_ns`` (the INS
    start; None: the log's first sample)."""
    first = 0 if start_ns is None else int(np.searchsorted(log.gps_ns, int(start_ns) - int(NS_PER_S / log.rate_hz) // 2))
    first = min(first, log.gps_ns.size - 1)
    n = max(1, int(round(ALIGNMENT_S * log.rate_hz)))
    return slice(first, min(log.gps_ns.size, first + n))


def check_at_rest(log, imu, lat_rad: float, height_m: float, start_ns=None) -> None:
    """Raise :class:`InputDataError` naming the log when its alignment window (:func:`alignment_window`) is
    not at rest for an IMU of model ``imu``: a mean rate beyond the Earth rate plus :data:`REST_BIAS_SIGMAS`
    turn-on biases (a turning body), a mean specific force whose magnitude is not normal gravity (a moving
    body, or accelerometers in g), or samples scattered beyond the noise (a rolling or vibrating body)."""
    from chronofuse.positioning.earth import OMEGA_IE_RAD_PER_S, normal_gravity_m_per_s2

    win = alignment_window(log, start_ns)
    w, f = log.gyro_rad_per_s[win], log.accel_m_per_s2[win]
    when = f"the {ALIGNMENT_S:g} s from {_when(log.gps_ns[win.start])} GPS"
    rest = "the INS start needs the IMU at rest"
    rate = float(np.linalg.norm(w.mean(0)))
    rate_limit = OMEGA_IE_RAD_PER_S + max(REST_BIAS_SIGMAS * imu.gyro.turn_on_bias, REST_RATE_FLOOR_RAD_PER_S)
    if not rate <= rate_limit:
        raise InputDataError(f"mean angular rate {rate:.3g} rad/s over {when}, beyond the {rate_limit:.3g} rad/s of "
                             f"a body at rest for the grade's gyro bias: {rest}", log.source)
    g = normal_gravity_m_per_s2(lat_rad, height_m)
    force = float(np.linalg.norm(f.mean(0)))
    g_limit = max(REST_GRAVITY_M_PER_S2, 5.0 * imu.accel.turn_on_bias)
    if not abs(force - g) <= g_limit:
        hint = " (accelerometers in g under _m_per_s2 columns?)" if 0.5 < force < 1.5 else ""
        raise InputDataError(f"mean specific force {force:.4g} m/s^2 over {when}, not normal gravity {g:.4g} "
                             f"+- {g_limit:g} m/s^2{hint}: {rest}", log.source)
    for name, x, sensor, floor, unit in (("angular rate", w, imu.gyro, REST_STD_FLOORS[0], "rad/s"),
                                         ("specific force", f, imu.accel, REST_STD_FLOORS[1], "m/s^2")):
        std = float(x.std(0).max()) if x.shape[0] > 1 else 0.0
        limit = max(REST_NOISE_TIMES * sensor.white_density * math.sqrt(log.rate_hz), floor)
        if not std <= limit:
            raise InputDataError(f"the {name} varies by {std:.3g} {unit} (standard deviation) over {when}, beyond "
                                 f"the {limit:.3g} {unit} of the grade's noise: {rest} (rolling or moving?)",
                                 log.source)


def static_alignment(log, lat_rad: float, height_m: float,
                     start_ns=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(c_bn, gyro_bias, accel_bias)`` of a body at rest over :data:`ALIGNMENT_S` s of the log from
    ``start_ns`` (None: its first sample; :func:`alignment_window`): roll and
    pitch from the mean specific force, heading from the mean angular rate (gyrocompassing), the gyro biases
    as the mean rate less the Earth rate in that attitude, the accelerometer bias along the vertical as the
    mean specific force's magnitude less normal gravity (the horizontal ones are absorbed by the levelling)."""
    from chronofuse.positioning.earth import earth_rate_ned, normal_gravity_m_per_s2
    from chronofuse.positioning.ins import euler_to_dcm

    win = alignment_window(log, start_ns)
    f = log.accel_m_per_s2[win].mean(0)
    w = log.gyro_rad_per_s[win].mean(0)
    roll = math.atan2(-f[1], -f[2])
    pitch = math.atan2(f[0], math.hypot(f[1], f[2]))
    level = euler_to_dcm(roll, pitch, 0.0)  # body to a level frame of heading 0
    w_level = level @ w  # Earth rate in the level frame: Omega cos L (cos psi, -sin psi, .) for heading psi
    yaw = math.atan2(-w_level[1], w_level[0]) if math.cos(lat_rad) > 1e-3 else 0.0
    c_bn = euler_to_dcm(roll, pitch, yaw)
    gyro_bias = w - c_bn.T @ earth_rate_ned(lat_rad)
    norm = float(np.linalg.norm(f))
    accel_bias = f * (1.0 - normal_gravity_m_per_s2(lat_rad, height_m) / norm)
    return c_bn, gyro_bias, accel_bias


@dataclass(frozen=True)
class InsSolution:
    """``filtered`` and ``smoothed`` (None without smoothing): ECEF positions (obs epochs, 3), NaN outside the
    covered span; ``clock_m``, ``isb_m``, ``n_used`` of the tight filter (None for loose); ``aligned`` the
    :class:`AlignedImu`; ``start_index`` the observation epoch of the start."""

    filtered: np.ndarray
    smoothed: np.ndarray | None
    clock_m: np.ndarray | None
    isb_m: np.ndarray | None
    n_used: np.ndarray | None
    aligned: AlignedImu
    start_index: int


def _ecef(lat_lon_h: np.ndarray) -> np.ndarray:
    x, y, z = pymap3d.geodetic2ecef(lat_lon_h[..., 0], lat_lon_h[..., 1], lat_lon_h[..., 2], deg=False)
    return np.stack([x, y, z], -1)


def _fix_covariances(fixes, rows) -> np.ndarray:
    """NED covariance (rows, 3, 3) of each fix's least-squares solution (identity where there is none)."""
    from chronofuse.gnss.lsq_position import least_squares_position

    p = fixes.position_m[rows]
    ok = np.isfinite(p[:, 0])
    sigma = np.where(np.isfinite(fixes.sigma_m[rows]), fixes.sigma_m[rows], np.inf)
    fix = least_squares_position(fixes.satellite_m[rows], fixes.corrected_m[rows], sigma, fixes.system_index,
                                 np.where(ok[:, None], p, 0.0), iterations=1)
    cov = _ENU_TO_NED @ fix.cov_enu_m2 @ _ENU_TO_NED.T
    good = ok & np.isfinite(cov).all((-1, -2))
    return np.where(good[:, None, None], cov, np.eye(3))


def ins_positions(fixes, log, *, coupling: str = "loose", grade: str = "industrial", smooth: bool = False,
                  obs_source: str = "") -> InsSolution:
    """The GNSS/INS solution at the epochs of ``fixes`` (a :class:`PointPositions`) with the IMU ``log`` of
    grade ``grade`` (:data:`chronofuse.models.imu.IMU_GRADES`), ``coupling`` one of :data:`COUPLINGS`
    (module docstring). Raises :class:`InputDataError` when the log does not overlap the epochs or no fix
    exists on the covered span to start from."""
    from chronofuse.models.imu import IMU_GRADES, imu_grade

    if coupling not in COUPLINGS:
        raise invalid("coupling", coupling, f"one of {', '.join(COUPLINGS)}")
    if grade not in IMU_GRADES:
        raise invalid("ins", grade, f"one of {', '.join(IMU_GRADES)}")
    imu = imu_grade(grade)
    if not log.rate_hz >= MIN_RATE_HZ:
        raise InputDataError(f"the IMU log's rate is {log.rate_hz:g} Hz: the INS needs at least {MIN_RATE_HZ:g} Hz",
                             log.source)
    al = align_imu(log, fixes.gps_ns, obs_source)
    rows = np.where(al.observed >= 0, al.observed, 0)
    have = (al.observed >= 0) & np.isfinite(fixes.position_m[rows, 0])
    if not have.any():
        raise InputDataError("no single-point fix on the epochs the IMU log covers: nothing to start the INS from",
                             obs_source or None)
    a = int(np.flatnonzero(have)[0])  # the start: the first fix on the covered span
    grid = al.grid_ns[a:]
    obs_rows = al.observed[a:]
    start_row = int(obs_rows[0])
    x0 = fixes.position_m[start_row]
    lat, lon, h = pymap3d.ecef2geodetic(*x0, deg=False)
    start = np.array([lat, lon, h])
    check_at_rest(log, imu, lat, h, grid[0])
    c_bn, bg0, ba0 = static_alignment(log, lat, h, grid[0])
    # the filters estimate what is left of the biases
    gyro, accel = (al.gyro[a + 1:] - bg0)[None], (al.accel[a + 1:] - ba0)[None]
    epochs = grid.size - 1
    taken = obs_rows[1:] >= 0
    src = np.where(taken, obs_rows[1:], 0)
    sigma_psi = np.array([0.01, 0.01, HEADING_SIGMA_RAD])
    clock = isb = n_used = None
    if coupling == "loose":
        from chronofuse.positioning.loose import LooselyCoupled
        from chronofuse.positioning.loose import smooth as rts

        p = np.where(taken[:, None], fixes.position_m[src], np.nan)
        la, lo, hh = pymap3d.ecef2geodetic(p[:, 0], p[:, 1], p[:, 2], deg=False)
        z = np.stack([la, lo, hh], -1)[None]
        cov = np.where(taken[:, None, None], _fix_covariances(fixes, src), np.eye(3))[None]
        filt = LooselyCoupled(imu, start, np.zeros(3), c_bn, log.rate_hz, sigma_r_m=5.0, sigma_v_m_per_s=0.1,
                              sigma_psi_rad=sigma_psi).fit()
        res = filt.run(z, gyro_rad_per_s=gyro, accel_m_per_s2=accel, fix_cov_ned_m2=cov)
        filtered = res.lat_lon_h[0]
        smoothed = rts(res)[0] if smooth else None
    else:
        from chronofuse.positioning.tight import TightlyCoupled, smooth as rts

        rho = np.where(taken[:, None], fixes.corrected_m[src], np.nan)
        sat = np.where(taken[:, None, None], fixes.satellite_m[src], 0.0)
        sig = np.where(np.isfinite(fixes.sigma_m[src]) & taken[:, None], fixes.sigma_m[src], 1e6)
        filt = TightlyCoupled(imu, start, np.zeros(3), c_bn, log.rate_hz, n_systems=len(fixes.systems),
                              start_clock_m=float(fixes.clock_m[start_row]), sigma_r_m=5.0, sigma_v_m_per_s=0.1,
                              sigma_psi_rad=sigma_psi, sigma_clock_m=30.0).fit()
        res = filt.run(rho[None], gyro_rad_per_s=gyro, accel_m_per_s2=accel, satellite_m=sat, sigma_m=sig[None],
                       system=fixes.system_index)
        filtered = res.lat_lon_h[0]
        smoothed = rts(res)[0] if smooth else None
    out = np.full(fixes.position_m.shape, np.nan)
    out[start_row] = x0
    out[src[taken]] = _ecef(filtered[taken])
    out_s = None
    if smoothed is not None:
        out_s = out.copy()
        out_s[src[taken]] = _ecef(smoothed[taken])
    if coupling == "tight":
        clock = np.full(out.shape[0], np.nan)
        isb = np.full((out.shape[0], len(fixes.systems) - 1), np.nan)
        n_used = np.zeros(out.shape[0], dtype=int)
        clock[start_row] = fixes.clock_m[start_row]
        clock[src[taken]] = res.clock_m[0][taken]
        isb[src[taken]] = res.isb_m[0][taken]
        n_used[src[taken]] = res.n_used[0][taken]
    return InsSolution(filtered=out, smoothed=out_s, clock_m=clock, isb_m=isb, n_used=n_used, aligned=al,
                       start_index=start_row)


def as_point_positions(fixes, positions_m, solution: InsSolution):
    """``fixes`` with the GNSS/INS positions (and the tight filter's clock, biases and satellites used), for
    :func:`chronofuse.experiments.real_positioning.write_positions_csv`."""
    changes = {"position_m": positions_m}
    if solution.clock_m is not None:
        changes.update(clock_m=solution.clock_m, isb_m=solution.isb_m, n_used=solution.n_used)
    return replace(fixes, **changes)


def ins_statistics(fixes, solution: InsSolution, reference_m) -> dict:
    """Statistics (:func:`chronofuse.gnss.point_positioning.position_statistics`) of the single-point fixes,
    the GNSS/INS and (when smoothed) the smoothed solution against ``reference_m``, on the same epochs: those
    the GNSS/INS solution covers."""
    from chronofuse.gnss.point_positioning import position_statistics

    on = np.isfinite(solution.filtered[:, 0])
    out = {"spp": position_statistics(fixes.position_m[on], reference_m),
           "ins": position_statistics(solution.filtered[on], reference_m)}
    if solution.smoothed is not None:
        out["smoothed"] = position_statistics(solution.smoothed[on], reference_m)
    return out


def ins_from_files(obs_path, nav_paths, imu_path, systems, *, coupling: str = "loose", grade: str = "industrial",
                   smooth: bool = False, options=None, start_s=None, end_s=None, reference_m=None) -> tuple:
    """Single-point fixes (:func:`chronofuse.experiments.real_positioning.position_from_files`), then the
    GNSS/INS solution with the IMU log ``imu_path`` (:func:`chronofuse.io.imu_log.read_imu_csv`, gaps
    allowed and warned of). Returns ``(fixes, InsSolution, summary)``; the summary is the single-point one
    with an ``ins`` entry (coupling, grade, the log, its cover and gaps, and with ``reference_m`` the
    statistics of :func:`ins_statistics`)."""
    from chronofuse.experiments.real_positioning import position_from_files
    from chronofuse.io.imu_log import read_imu_csv

    if coupling not in COUPLINGS:
        raise invalid("coupling", coupling, f"one of {', '.join(COUPLINGS)}")
    log = read_imu_csv(imu_path, allow_gaps=True)
    fixes, summary = position_from_files(obs_path, nav_paths, systems, options=options, start_s=start_s,
                                         end_s=end_s, reference_m=reference_m)
    solution = ins_positions(fixes, log, coupling=coupling, grade=grade, smooth=smooth, obs_source=str(obs_path))
    al = solution.aligned
    entry = {"imu": str(imu_path), "coupling": coupling, "grade": grade, "smooth": bool(smooth),
             "imu_rate_hz": float(log.rate_hz), "imu_samples": int(log.gps_ns.size),
             "epochs": int(np.isfinite(solution.filtered[:, 0]).sum()),
             "gaps": len(al.gaps), "samples_held": int(al.held.sum()),
             "longest_gap_s": max((g[1] for g in al.gaps), default=0) / log.rate_hz}
    if reference_m is not None:
        entry["statistics"] = ins_statistics(fixes, solution, np.asarray(summary["reference_position_m"]))
    summary["ins"] = entry
    return fixes, solution, summary
