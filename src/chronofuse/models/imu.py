"""Inertial measurement unit truth model: a gyroscope triad and an accelerometer triad with their errors.

Each axis measures ``m = (1 + s) u + M u + b(t) + n`` where ``u`` is the true angular rate (rad/s) or
specific force (m/s^2), ``s`` a scale-factor error, ``M`` a small-angle misalignment (off-diagonal,
per trial), ``b(t)`` the bias and ``n`` white noise. Every output sample is the average of the
continuous signal over its sample interval (what an IMU's integrated delta-angle / delta-velocity
divided by the interval is), so the Allan deviation of a static IMU shows the datasheet's terms
exactly (IEEE Std 952-1997 Annex C; El-Sheimy, Hou and Niu 2008, Table 1):

* white noise of density ``N`` (angle random walk, rad/s/sqrt(Hz) = rad/sqrt(s); velocity random walk,
  m/s^2/sqrt(Hz)): ``sigma(tau) = N / sqrt(tau)``, so ``sigma(1 s) = N``;
* bias instability ``B`` (flicker rate noise of one-sided PSD ``S(f) = B^2 / (pi f)``): a flat floor
  ``sigma = B sqrt(2 ln 2 / pi) = 0.664 B``;
* bias random walk ``K`` (rate random walk, rad/s/sqrt(s) or m/s^2/sqrt(s)): ``sigma(tau) = K sqrt(tau / 3)``;
* a turn-on bias, constant over a run, drawn per trial (it does not show in the Allan deviation).

In the notation of fractional-frequency noise (``chronofuse.models.oscillator``) these are white FM with
``h0 = 2 N^2``, flicker FM with ``h_-1 = B^2 / pi`` and random-walk FM with ``h_-2 = K^2 / (2 pi^2)``,
generated the same exact way: white and random walk as the interval average of a Wiener process
(``models.clock.two_state_clock_phase_s`` differenced), flicker by Kasdin–Walter with the
interval-averaging gain ``models.noise.flicker_fm_gain``.

Grades: :data:`IMU_GRADES` (``consumer``, ``industrial``, ``tactical``), each with its source; values not
taken from a datasheet are marked "assumed".
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from chronofuse.models.clock import two_state_clock_phase_s
from chronofuse.models.noise import KasdinWalterFilter, flicker_fm_gain, tabulated_gain
from chronofuse.seeding import child_rng, root_seed
from chronofuse.validation import InputError, check_array, check_choice, check_scalar

__all__ = [
    "SensorErrors",
    "ImuModel",
    "IMU_GRADES",
    "imu_grade",
    "ImuTruth",
    "simulate_imu",
    "DEG",
    "DEG_PER_H",
    "G0_M_PER_S2",
]

#: One degree in radians.
DEG = math.pi / 180.0
#: One degree per hour in rad/s.
DEG_PER_H = DEG / 3600.0
#: Standard gravity (m/s^2), the unit of "mg" and "ug" in datasheets.
G0_M_PER_S2 = 9.80665
_FT = 0.3048
_SQRT_H = 60.0  # sqrt(3600 s)

# Which grandchild seed each error term draws from (per trial), so adding a term never changes another.
_TERM_KEYS = {"white": 0, "flicker": 1, "constants": 2}


@dataclass(frozen=True)
class SensorErrors:
    """Errors of one sensor triad (three identical axes), in SI units of the measured quantity ``u``.

    Attributes
    ----------
    white_density : float
        White-noise density ``N``, [u]/sqrt(Hz) (ARW in rad/sqrt(s) for a gyro, VRW in m/s/sqrt(s) for an
        accelerometer). ``sigma(1 s) = N``.
    bias_instability : float
        IEEE 952 bias instability ``B``, [u]; Allan floor ``0.664 B``.
    bias_random_walk : float
        Rate/acceleration random walk ``K``, [u]/sqrt(s); ``sigma(tau) = K sqrt(tau/3)``.
    turn_on_bias : float
        1-sigma of the constant bias drawn per trial, [u].
    scale_factor : float
        1-sigma of the scale-factor error per axis (dimensionless; 1e-6 = 1 ppm).
    misalignment_rad : float
        1-sigma of each off-diagonal small-angle misalignment, rad.
    """

    white_density: float
    bias_instability: float = 0.0
    bias_random_walk: float = 0.0
    turn_on_bias: float = 0.0
    scale_factor: float = 0.0
    misalignment_rad: float = 0.0

    def __post_init__(self):
        for name in ("white_density", "bias_instability", "bias_random_walk", "turn_on_bias", "scale_factor",
                     "misalignment_rad"):
            check_scalar(getattr(self, name), name, min_val=0.0)

    def allan_deviation(self, tau_s) -> np.ndarray:
        """The theoretical Allan deviation of a static triad axis, [u], shape of ``tau_s`` (IEEE 952 C.1).

        ``sigma^2 = N^2 / tau + (2 ln2 / pi) B^2 + K^2 tau / 3``.
        """
        tau = np.asarray(tau_s, dtype=np.float64)
        return np.sqrt(self.white_density**2 / tau + 2.0 * math.log(2.0) / math.pi * self.bias_instability**2
                       + self.bias_random_walk**2 * tau / 3.0)


@dataclass(frozen=True)
class ImuModel:
    """A gyroscope triad (rad/s) and an accelerometer triad (m/s^2), with where the numbers come from."""

    name: str
    gyro: SensorErrors
    accel: SensorErrors
    source: str

    def __post_init__(self):
        if not isinstance(self.gyro, SensorErrors) or not isinstance(self.accel, SensorErrors):
            raise TypeError("gyro and accel must be SensorErrors")


IMU_GRADES: dict[str, ImuModel] = {
    "consumer": ImuModel(
        name="consumer",
        gyro=SensorErrors(white_density=0.005 * DEG, bias_instability=20.0 * DEG_PER_H,
                          bias_random_walk=2e-5 * DEG, turn_on_bias=0.5 * DEG,
                          scale_factor=0.01, misalignment_rad=1e-3),
        accel=SensorErrors(white_density=400e-6 * G0_M_PER_S2, bias_instability=0.1e-3 * G0_M_PER_S2,
                           bias_random_walk=2e-6 * G0_M_PER_S2, turn_on_bias=20e-3 * G0_M_PER_S2,
                           scale_factor=0.01, misalignment_rad=1e-3),
        source="InvenSense MPU-6000/6050 product specification rev. 3.4: gyro rate noise 0.005 deg/s/sqrt(Hz), "
               "accel 400 ug/sqrt(Hz), zero-rate offset +-20 deg/s (we take 0.5 deg/s after calibration: "
               "assumed), accel zero-g offset +-50 mg (20 mg: assumed); bias instability, bias random walk, "
               "scale factor 1 % and misalignment 1 mrad: assumed (typical of Allan analyses of this class)",
    ),
    "industrial": ImuModel(
        name="industrial",
        gyro=SensorErrors(white_density=0.007 * DEG, bias_instability=10.0 * DEG_PER_H,
                          bias_random_walk=1e-5 * DEG, turn_on_bias=0.2 * DEG,
                          scale_factor=1e-3, misalignment_rad=0.5e-3),
        accel=SensorErrors(white_density=120e-6 * G0_M_PER_S2, bias_instability=0.03e-3 * G0_M_PER_S2,
                           bias_random_walk=1e-6 * G0_M_PER_S2, turn_on_bias=5e-3 * G0_M_PER_S2,
                           scale_factor=1e-3, misalignment_rad=0.5e-3),
        source="Xsens MTi-1 series datasheet: gyro noise density 0.007 deg/s/sqrt(Hz), in-run bias stability "
               "10 deg/h; accel noise density 120 ug/sqrt(Hz), in-run bias stability 0.03 mg; turn-on bias, "
               "bias random walk, scale factor 0.1 % and misalignment 0.5 mrad: assumed",
    ),
    "tactical": ImuModel(
        name="tactical",
        gyro=SensorErrors(white_density=0.125 * DEG / _SQRT_H, bias_instability=0.35 * DEG_PER_H,
                          bias_random_walk=1e-7 * DEG, turn_on_bias=1.0 * DEG_PER_H,
                          scale_factor=150e-6, misalignment_rad=0.1e-3),
        accel=SensorErrors(white_density=0.065 * _FT / _SQRT_H, bias_instability=0.05e-3 * G0_M_PER_S2,
                           bias_random_walk=1e-7 * G0_M_PER_S2, turn_on_bias=1e-3 * G0_M_PER_S2,
                           scale_factor=300e-6, misalignment_rad=0.1e-3),
        source="Honeywell HG1700 brochure (N61-1619-000-001), 1 sigma: ARW 0.125 deg/sqrt(h), gyro bias "
               "1 deg/h, VRW 0.065 ft/s/sqrt(h), accel bias 1 mg, gyro scale factor 150 ppm, accel scale "
               "factor 300 ppm; in-run bias instabilities (0.35 deg/h, 0.05 mg), bias random walks and "
               "misalignment 0.1 mrad: assumed",
    ),
}


def imu_grade(name: str) -> ImuModel:
    """The preset of :data:`IMU_GRADES` called ``name``."""
    check_choice(name, "grade", IMU_GRADES)
    return IMU_GRADES[name]


@dataclass(frozen=True)
class ImuTruth:
    """A simulated IMU run: measurements and the errors that made them.

    Shapes: ``gyro_rad_per_s`` and ``accel_m_per_s2`` (trials, steps, 3); ``gyro_bias_rad_per_s`` and
    ``accel_bias_m_per_s2`` (trials, steps, 3) the total time-varying bias; ``gyro_matrix`` and
    ``accel_matrix`` (trials, 3, 3) ``I + diag(s) + M``; ``rate_hz`` the output rate.
    """

    gyro_rad_per_s: np.ndarray
    accel_m_per_s2: np.ndarray
    gyro_bias_rad_per_s: np.ndarray
    accel_bias_m_per_s2: np.ndarray
    gyro_matrix: np.ndarray
    accel_matrix: np.ndarray
    rate_hz: float


def _bias_series(err: SensorErrors, trials: int, steps: int, dt_s: float, base: np.random.SeedSequence,
                 sensor: int, hold: int) -> np.ndarray:
    """Time-varying bias + white noise of three axes, (trials, steps, 3), interval-averaged."""
    out = np.zeros((trials, 3, steps))
    h0, hm2 = 2.0 * err.white_density**2, err.bias_random_walk**2 / (2.0 * math.pi**2)
    if h0 > 0.0 or hm2 > 0.0:
        for i in range(trials):
            rng = child_rng(base, i, sensor, _TERM_KEYS["white"])
            z = rng.standard_normal((3, 3, steps + 1))
            phase = two_state_clock_phase_s(z[0], z[1], z[2], h0=h0, hm2=hm2, dt_s=dt_s)
            out[i] = np.diff(phase, axis=-1) / dt_s
    if err.bias_instability > 0.0:
        # Flicker at the bias rate (every ``hold`` samples), held: averages over whole bias intervals are
        # those of interval-averaged flicker, so the Allan floor holds from a few bias intervals on.
        slow = -(-steps // hold)
        kw = KasdinWalterFilter(-1.0, slow, gain=tabulated_gain(flicker_fm_gain))
        row = np.empty(slow)
        for i in range(trials):
            rng = child_rng(base, i, sensor, _TERM_KEYS["flicker"])
            for axis in range(3):
                row[:] = 0.0
                kw.add_row(row, rng, err.bias_instability)  # sqrt(pi h_-1) = B
                out[i, axis] += np.repeat(row, hold)[:steps]
    return np.moveaxis(out, 1, 2)


def _constants(err: SensorErrors, trials: int, base: np.random.SeedSequence, sensor: int):
    """Per-trial turn-on bias (trials, 3) and error matrix ``I + diag(s) + M`` (trials, 3, 3)."""
    bias = np.empty((trials, 3))
    matrix = np.empty((trials, 3, 3))
    off = ~np.eye(3, dtype=bool)
    for i in range(trials):
        rng = child_rng(base, i, sensor, _TERM_KEYS["constants"])
        bias[i] = err.turn_on_bias * rng.standard_normal(3)
        m = np.eye(3) + np.diag(err.scale_factor * rng.standard_normal(3))
        m[off] = err.misalignment_rad * rng.standard_normal(6)
        matrix[i] = m
    return bias, matrix


def simulate_imu(model: ImuModel, angular_rate_rad_per_s, specific_force_m_per_s2, rate_hz: float, *,
                 trials: int = 1, seed=0, bias_rate_hz: float | None = None) -> ImuTruth:
    """Measurements of an IMU following the true motion, shape (trials, steps, 3) each.

    Parameters
    ----------
    model : ImuModel
        Error model (e.g. ``imu_grade("tactical")``).
    angular_rate_rad_per_s, specific_force_m_per_s2 : array of shape (steps, 3) or (trials, steps, 3)
        True body-frame angular rate and specific force, each the average over its sample interval.
    rate_hz : float
        Output rate, Hz (> 0).
    trials : int
        Independent realisations of the errors (the truth is shared when it has shape (steps, 3)).
    seed : int or numpy.random.SeedSequence
        Trial ``i`` draws from ``child_seed(seed, i, ...)``: it does not depend on ``trials``.
    bias_rate_hz : float, optional
        Rate at which the bias-instability (flicker) process is generated and then held; ``rate_hz / bias_rate_hz``
        must be a whole number. Default: ``rate_hz`` (exact at every tau). A slower rate (1 Hz for a 100 Hz
        IMU) costs a hundredth of the time and keeps the Allan floor from a few ``1 / bias_rate_hz`` on, where the
        bias instability shows (below it the white noise dominates).
    """
    check_scalar(rate_hz, "rate_hz", min_val=0.0, include_min=False)
    check_scalar(trials, "trials", min_val=1, integer=True)
    omega = check_array(angular_rate_rad_per_s, "angular_rate_rad_per_s", ndim=(2, 3))
    force = check_array(specific_force_m_per_s2, "specific_force_m_per_s2", ndim=(2, 3))
    for name, a in (("angular_rate_rad_per_s", omega), ("specific_force_m_per_s2", force)):
        if a.ndim not in (2, 3) or a.shape[-1] != 3 or (a.ndim == 3 and a.shape[0] != trials):
            raise ValueError(f"{name} has shape {a.shape}, must be (steps, 3) or ({trials}, steps, 3)")
    if omega.shape[-2] != force.shape[-2]:
        raise ValueError(f"angular rate has {omega.shape[-2]} steps and specific force {force.shape[-2]}")
    steps, dt = omega.shape[-2], 1.0 / rate_hz
    hold = 1 if bias_rate_hz is None else int(round(rate_hz / bias_rate_hz))
    if bias_rate_hz is not None and (hold < 1 or abs(hold * bias_rate_hz - rate_hz) > 1e-9 * rate_hz):
        raise InputError(f"bias_rate_hz == {bias_rate_hz}, must divide {{rate_hz}} == {rate_hz} a whole number of times",
                         fields=("rate_hz",))
    base = root_seed(seed)
    sensors = []
    for k, (err, truth) in enumerate(((model.gyro, omega), (model.accel, force))):
        turn_on, matrix = _constants(err, trials, base, k)
        bias = _bias_series(err, trials, steps, dt, base, k, hold) + turn_on[:, None, :]
        if truth.ndim == 2:  # one truth shared by every trial
            measured = np.einsum("nij,tj->nti", matrix, truth)
        else:
            measured = np.einsum("nij,ntj->nti", matrix, truth)
        sensors.append((measured + bias, bias, matrix))
    (gyro, gyro_bias, gyro_m), (accel, accel_bias, accel_m) = sensors
    return ImuTruth(gyro_rad_per_s=gyro, accel_m_per_s2=accel, gyro_bias_rad_per_s=gyro_bias,
                    accel_bias_m_per_s2=accel_bias, gyro_matrix=gyro_m, accel_matrix=accel_m, rate_hz=float(rate_hz))
