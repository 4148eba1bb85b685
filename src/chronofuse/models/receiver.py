"""GNSS timing-receiver truth model (SPEC section 2.2) and its scenarios.

What one receiver produces, every pulse ``k`` (times ``t_k = k dt``, ``dt = 1 / rate_hz``)
-------------------------------------------------------------------------------------------
The receiver's navigation solution estimates its own clock bias ``b_hat = b + e + s``, where ``b`` is
the true bias of its free-running oscillator against GNSS system time, ``s`` a spoofer's drag-off
(zero unless spoofed) and ``e`` the timing error of the solution::

    e_k = (G_k / gdop_median) sigma_w w_k       white noise, scaled with the geometry (TDOP ~ GDOP)
        + m_k                                   multipath, first-order Gauss-Markov (sigma_mp, tau_mp)
        + a_k                                   slow wander, first-order Gauss-Markov (sigma_wd, tau_wd)
        + o_k                                   single-pulse outliers (prob. per pulse, N(0, sigma_o))
        + sum_{i<=k} j_i                        persistent jumps (prob. per second, N(0, sigma_j))

A first-order Gauss-Markov process is the AR(1) recursion ``x_k = phi x_{k-1} + sigma sqrt(1 - phi^2)
w_k``, ``phi = exp(-dt / tau)``, started from its stationary law, so that ``E[x_k x_{k+n}] = sigma^2
exp(-n dt / tau)`` exactly (R. G. Brown and P. Y. C. Hwang, *Introduction to Random Signals and Applied
Kalman Filtering*, 4th ed., ch. 2); it is run with :func:`scipy.signal.lfilter`.

The 1PPS edge can only leave on a tick of the receiver's own clock (period ``T = 1 / tick_hz``). The
receiver aims at local time ``L* = t_k + b_hat_k`` and emits on the nearest tick, at local times
``T (theta + n)`` (``theta``: the tick phase, uniform per receiver), so the edge carries the sawtooth
``q_k = T (round(u_k) - u_k)``, ``u_k = L*_k / T - theta``, within ``[-T/2, T/2]``. Hence

- ``pps_error_s = e + s + q`` (edge time minus true GNSS time; positive = late), NaN without a pulse;
- ``qerr_s = -q`` rounded to 1 ps, the quantization error the receiver announces in advance, with the
  sign of u-blox UBX-TIM-TP ``qErr``: a time-interval counter started by the reference and stopped by
  the receiver's pulse reads ``pps_error_s``, and *adding* ``qErr`` to that reading removes the
  sawtooth (A. Wallin, "uBlox F9T qErr correction", anderswallin.net, 2019: "the qErr is applied with
  a + sign to the measured time-interval"). So ``pps_error_s + qerr_s = e + s`` to within 0.5 ps;
- ``clock_bias_s = b_hat`` (what NAV-CLOCK reports and an integrity monitor watches), NaN without a fix.
  ``b`` is a free-running TCXO: a constant frequency offset (uniform within ``+-clock_freq_offset_max``),
  white FM (``h0``) and random-walk FM (``h_-2``), as the clock model of SPEC section 4
  (phase increments of variance ``h0 dt / 2``; frequency increments of variance ``2 pi^2 h_-2 dt``).

Geometry: a unit-variance Gauss-Markov latent ``z_k`` (time constant ``gdop_tau_s``) gives
``GDOP = max(1, gdop_median exp(gdop_log_sigma z))`` (log-normal) and the number of satellites used
``n_sats = clip(round(n_sats_median - n_sats_spread z), 4, n_sats_max)`` (fewer satellites, worse
geometry). There is no fix during an outage (Poisson starts at ``outage_rate_hz``, geometric lengths of
mean ``outage_mean_s``), in a jamming window, or when GDOP exceeds ``gdop_fix_max``; without a fix the
receiver outputs no 1PPS (``pps_error_s``, ``qerr_s``, ``clock_bias_s`` and ``gdop`` are NaN) and
reports 0 to 3 satellites (0 when jammed).

Calibration of ``open-sky`` against the real GPS-vs-maser record
----------------------------------------------------------------
Data: ``stability/gps/gps_1pps_phase_data.txt.gz`` (241,218 s of a GPS receiver's 1PPS against a
hydrogen maser, marked "AW 2016 March" in its header, via allantools' test suite) and Stable32's
tables for it.

1. Is the sawtooth in the record? No, at the 48 MHz level it cannot be: a 48 MHz sawtooth alone is
   uniform with rms ``T / sqrt(12) = 6.0 ns`` and would give ADEV(1 s) of about
   ``sqrt(3) 6.0 ns = 10.4 ns``, while the record has 6.12 ns. Its short-term noise is also Gaussian
   (Pearson kurtosis of the second difference 2.97; an i.i.d. uniform sawtooth gives 2.4), its
   spectrum above 0.1 Hz is flat at ``2.4e-17 s^2/Hz`` with no line (a sawtooth from a steady
   oscillator offset is a line), and the variance of the first difference over 300 s windows is
   nearly constant (relative spread 0.11, against 0.08 for chi-square scatter alone). The record
   therefore behaves like a qErr-corrected 1PPS (or a receiver with a far finer pulse quantization),
   and what is compared with it is ``pps_error_s + qerr_s``. The raw ``pps_error_s`` of the model
   keeps its 48 MHz sawtooth on top, so its ADEV(1 s) is about twice the record's (tested).
2. Fit. The Allan variance of a sum of independent stationary processes with autocovariance
   ``R(n)`` is ``AVAR(n tau0) = [6 R(0) - 8 R(n) + 2 R(2n)] / (2 n^2 tau0^2)`` (second difference of
   the phase, NIST SP 1065 eq. (7)); white noise adds ``sigma^2`` to ``R(0)``, a Gauss-Markov process
   adds ``sigma^2 exp(-n tau0 / tau)``. The record shows no outliers or jumps (its largest
   ``|x_{k+1} - x_k|`` is 25 ns, 4.9 sigma of the difference: the Gaussian extreme for 2.4e5 samples)
   and no outages. Least squares on ``log(model / table)`` over Stable32's overlapping-ADEV octave
   table, tau = 1 .. 8192 s (14 points), gave:

   - white noise only + one Gauss-Markov: sigma_w 3.47 ns, 6.23 ns / 28.5 s; worst misfit 16 %;
   - white + two Gauss-Markov (kept): ``white_sigma_s = 3.33 ns``, multipath ``5.26 ns, 15.1 s``,
     slow wander ``5.32 ns, 1530 s``; worst misfit 3.4 % on the octave table; on the decade ADEV
     table the model is within 0.94..1.14 of Stable32 at tau = 1 .. 1e4 s.

   The white level agrees with the flat high-frequency spectrum (``2.4e-17 s^2/Hz`` one-sided gives
   ``sigma = 3.46 ns``) and with the lag-1 correlation of the first difference (-0.44). The open-sky
   GDOP gain raises the effective white variance by ``exp(2 * 0.08^2)``, 0.6 % in rms, inside the
   fit's rounding. The fit is of second-order statistics only; it says nothing about the sawtooth,
   which step 1 set aside. :func:`corrected_pps_adev` is this analytic ADEV.
   ``tests/models/test_receiver.py`` redoes the fit (the preset must be its optimum to 1 %) and checks
   that simulated open-sky ``pps_error_s + qerr_s`` has ADEV within a factor 1.2 of the decade table
   at tau = 1, 10, 100, 1000, 1e4 s (measured: 0.98..1.02).

Epochs are integers: ``gps_s`` counts GPS seconds since 1980-01-06T00:00:00 (int64), and
``utc_s = gps_s - leap_s`` is the POSIX-style UTC label (an inserted leap second repeats the label of
the following midnight). The default start, :data:`DEFAULT_START_GPS_S`, is 2025-01-01T00:00:00 UTC,
when GPS - UTC = 18 s.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.signal import lfilter

from chronofuse.models.clock import two_state_clock_phase_s
from chronofuse.seeding import child_rng, root_seed
from chronofuse.timescale import NS_PER_S, gps_minus_utc_s, utc_to_gps_ns
from chronofuse.validation import check_choice, check_scalar

__all__ = [
    "DEFAULT_START_GPS_S",
    "GPS_MINUS_UTC_S",
    "ReceiverModel",
    "Scenario",
    "SCENARIOS",
    "scenario",
    "ReceiverTruth",
    "simulate_receivers",
    "gauss_markov",
    "sawtooth_s",
    "corrected_pps_adev",
]

#: 2025-01-01T00:00:00 UTC in GPS seconds since 1980-01-06 (16,432 days plus 18 leap seconds).
DEFAULT_START_GPS_S = int(utc_to_gps_ns(np.datetime64("2025-01-01T00:00:00")) // NS_PER_S)
#: GPS - UTC in seconds at the default start (18 s since 2017-01-01), from the leap-second table.
GPS_MINUS_UTC_S = int(gps_minus_utc_s(DEFAULT_START_GPS_S * NS_PER_S))

SPOOF_SHAPES = ("ramp", "quadratic")


@dataclass(frozen=True)
class ReceiverModel:
    """Physical parameters of one GNSS timing receiver (all receivers of a run share them).

    Defaults are the ``open-sky`` fit to the GPS-vs-maser record (see the module docstring).

    Parameters
    ----------
    white_sigma_s : white timing noise of the solution at ``gdop_median`` (s), >= 0.
    tick_hz : receiver clock that quantizes the 1PPS edge (Hz), > 0; sawtooth period ``1 / tick_hz``.
    multipath_sigma_s, multipath_tau_s : Gauss-Markov multipath: rms (s) and correlation time (s).
    wander_sigma_s, wander_tau_s : slow Gauss-Markov wander (atmosphere, long-period multipath).
    outlier_prob : probability that one pulse is an outlier, in [0, 1].
    outlier_sigma_s : rms of an outlier (s).
    jump_prob : probability per second of a persistent time step, in [0, 1].
    jump_sigma_s : rms of one step (s).
    outage_rate_hz : rate of fix-loss starts (1/s); outage_mean_s: their mean length (s).
    gdop_median, gdop_log_sigma, gdop_tau_s : log-normal GDOP: median, rms of ln GDOP, time constant.
    gdop_fix_max : no fix above this GDOP.
    n_sats_median, n_sats_spread, n_sats_max : satellites used (see the module docstring).
    clock_freq_offset_max : bound of the oscillator's fractional frequency offset (uniform).
    clock_initial_bias_max_s : bound of the initial clock bias (uniform, s).
    clock_h0 : white FM level h0 of the receiver oscillator (s, i.e. 1/Hz).
    clock_hm2 : random-walk FM level h_-2 (1/s, i.e. Hz).
    """

    white_sigma_s: float = 3.33e-9
    tick_hz: float = 48e6
    multipath_sigma_s: float = 5.26e-9
    multipath_tau_s: float = 15.1
    wander_sigma_s: float = 5.32e-9
    wander_tau_s: float = 1530.0
    outlier_prob: float = 0.0
    outlier_sigma_s: float = 50e-9
    jump_prob: float = 0.0
    jump_sigma_s: float = 20e-9
    outage_rate_hz: float = 0.0
    outage_mean_s: float = 30.0
    gdop_median: float = 1.5
    gdop_log_sigma: float = 0.08
    gdop_tau_s: float = 1800.0
    gdop_fix_max: float = 20.0
    n_sats_median: float = 11.0
    n_sats_spread: float = 1.0
    n_sats_max: int = 32
    clock_freq_offset_max: float = 5e-7
    clock_initial_bias_max_s: float = 1e-6
    clock_h0: float = 2e-19
    clock_hm2: float = 1e-23

    def __post_init__(self):
        for name in ("white_sigma_s", "multipath_sigma_s", "wander_sigma_s", "outlier_sigma_s",
                     "jump_sigma_s", "outage_rate_hz", "gdop_log_sigma", "n_sats_spread",
                     "clock_freq_offset_max", "clock_initial_bias_max_s", "clock_h0", "clock_hm2"):
            check_scalar(getattr(self, name), name, min_val=0.0)
        for name in ("tick_hz", "multipath_tau_s", "wander_tau_s", "outage_mean_s", "gdop_tau_s"):
            check_scalar(getattr(self, name), name, min_val=0.0, include_min=False)
        for name in ("outlier_prob", "jump_prob"):
            check_scalar(getattr(self, name), name, min_val=0.0, max_val=1.0)
        check_scalar(self.gdop_median, "gdop_median", min_val=1.0)
        check_scalar(self.gdop_fix_max, "gdop_fix_max", min_val=1.0)
        check_scalar(self.n_sats_max, "n_sats_max", min_val=4, integer=True)
        check_scalar(self.n_sats_median, "n_sats_median", min_val=4, max_val=self.n_sats_max)


@dataclass(frozen=True)
class Scenario:
    """A named receiver environment: a :class:`ReceiverModel` plus jamming and spoofing events.

    Parameters
    ----------
    name : short name, e.g. ``"urban-canyon"``.
    model : the receivers' :class:`ReceiverModel`.
    description : one line for humans.
    jamming_start_s, jamming_duration_s : window ``[start, start + duration)`` (s since the run's
        start) with no fix and no 1PPS; ``None`` for none.
    spoof_start_s : start of the drag-off (s since the run's start); ``None`` for none.
    spoof_shape : ``"ramp"``: ``s(t) = spoof_rate (t - t0)`` (spoof_rate in s/s);
        ``"quadratic"``: ``s(t) = spoof_rate (t - t0)^2 / 2`` (spoof_rate in s/s^2); zero before ``t0``.
    spoof_rate : see ``spoof_shape``; positive drags the receivers' time late.
    affected_receivers : indices of the receivers that are jammed/spoofed; ``None`` means all.
    """

    name: str
    model: ReceiverModel
    description: str = ""
    jamming_start_s: float | None = None
    jamming_duration_s: float = 0.0
    spoof_start_s: float | None = None
    spoof_shape: str = "ramp"
    spoof_rate: float = 0.0
    affected_receivers: tuple[int, ...] | None = None

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name:
            raise ValueError(f"name == {self.name!r}, must be a non-empty string")
        if not isinstance(self.model, ReceiverModel):
            raise TypeError(f"model == {self.model!r}, must be a ReceiverModel")
        if self.jamming_start_s is not None:
            check_scalar(self.jamming_start_s, "jamming_start_s", min_val=0.0)
        check_scalar(self.jamming_duration_s, "jamming_duration_s", min_val=0.0)
        if self.spoof_start_s is not None:
            check_scalar(self.spoof_start_s, "spoof_start_s", min_val=0.0)
        check_choice(self.spoof_shape, "spoof_shape", SPOOF_SHAPES)
        check_scalar(self.spoof_rate, "spoof_rate")
        if self.affected_receivers is not None:
            for i in self.affected_receivers:
                check_scalar(i, "affected_receivers", min_val=0, integer=True)

    def spoof_offset_s(self, t_s: np.ndarray) -> np.ndarray:
        """Drag-off ``s(t)`` (s) at times ``t_s`` (s since the run's start), shape of ``t_s``."""
        t_s = np.asarray(t_s, dtype=np.float64)
        if self.spoof_start_s is None:
            return np.zeros_like(t_s)
        since = np.maximum(t_s - self.spoof_start_s, 0.0)
        if self.spoof_shape == "ramp":
            return self.spoof_rate * since
        return 0.5 * self.spoof_rate * since**2

    def jammed(self, t_s: np.ndarray) -> np.ndarray:
        """Boolean mask of the jamming window at times ``t_s``, shape of ``t_s``."""
        t_s = np.asarray(t_s, dtype=np.float64)
        if self.jamming_start_s is None:
            return np.zeros(t_s.shape, dtype=bool)
        return (t_s >= self.jamming_start_s) & (t_s < self.jamming_start_s + self.jamming_duration_s)


# Only open sky is calibrated on data. The urban-canyon values are engineering assumptions (there is no
# urban 1PPS record in the project's data): noise that grows with the geometry, multipath several times
# the open-sky level and slower, NLOS outliers and short fix losses. The receiver oscillator
# (clock_* fields) is an assumed TCXO: ADEV 3e-10 at 1 s, offset within 0.5 ppm.
_OPEN_SKY = ReceiverModel()
_URBAN = dataclasses.replace(
    _OPEN_SKY,
    white_sigma_s=8e-9,
    multipath_sigma_s=20e-9,
    multipath_tau_s=60.0,
    outlier_prob=1e-3,
    outlier_sigma_s=100e-9,
    jump_prob=1e-4,
    jump_sigma_s=20e-9,
    outage_rate_hz=1.0 / 900.0,
    outage_mean_s=20.0,
    gdop_median=3.5,
    gdop_log_sigma=0.5,
    gdop_tau_s=120.0,
    n_sats_median=7.0,
    n_sats_spread=2.0,
)

SCENARIOS: dict[str, Scenario] = {
    "open-sky": Scenario(
        "open-sky", _OPEN_SKY,
        "Static antenna with a clear view: GDOP about 1.5 (< 2), noise fitted to a GPS-vs-maser record."),
    "urban-canyon": Scenario(
        "urban-canyon", _URBAN,
        "Street canyon: GDOP > 5 about a quarter of the time, 20 ns multipath, NLOS outliers, fix losses."),
    "jamming": Scenario(
        "jamming", _OPEN_SKY,
        "Open sky, jammed from 600 s to 1200 s: no fix, no 1PPS.",
        jamming_start_s=600.0, jamming_duration_s=600.0),
    "spoofing": Scenario(
        "spoofing", _OPEN_SKY,
        "Open sky, spoofer drags time off at 2 ns/s from 600 s while the fix stays good.",
        spoof_start_s=600.0, spoof_shape="ramp", spoof_rate=2e-9),
}


def scenario(name: str) -> Scenario:
    """The preset scenario called ``name`` (one of ``SCENARIOS``)."""
    check_choice(name, "scenario", SCENARIOS)
    return SCENARIOS[name]


_scenario_by_name = scenario


def gauss_markov(w: np.ndarray, sigma: float, tau_s: float, dt_s: float) -> np.ndarray:
    """Stationary first-order Gauss-Markov process from unit normals, along the last axis.

    ``w`` has shape ``(..., steps + 1)``: ``w[..., 0]`` draws the initial state from the stationary law
    ``N(0, sigma^2)``; the result ``x`` has shape ``(..., steps)`` with
    ``x_k = phi x_{k-1} + sigma sqrt(1 - phi^2) w_k``, ``phi = exp(-dt_s / tau_s)``, hence
    ``E[x_k x_{k+n}] = sigma^2 phi^n`` (Brown and Hwang, ch. 2), computed by an AR(1) IIR filter.
    """
    w = np.asarray(w, dtype=np.float64)
    phi = float(np.exp(-dt_s / tau_s))
    x_prev = sigma * w[..., :1]
    out, _ = lfilter([sigma * np.sqrt(1.0 - phi * phi)], [1.0, -phi], w[..., 1:], axis=-1, zi=phi * x_prev)
    return out


@dataclass(frozen=True)
class ReceiverTruth:
    """Simulated truth and reports of ``receivers`` receivers over ``trials`` Monte Carlo trials.

    Arrays of shape (trials, receivers, steps): ``pps_error_s`` (1PPS edge minus GNSS time, s, sawtooth
    included, NaN without a pulse), ``qerr_s`` (u-blox-signed qErr, s: ``pps_error_s + qerr_s`` removes
    the sawtooth), ``fix`` (bool), ``n_sats`` (int), ``gdop`` (NaN without a fix), ``clock_bias_s``
    (navigation clock bias, s, drag-off included, NaN without a fix), ``spoof_offset_s`` (true drag-off).
    Per step (steps,): ``gps_s`` (int64 GPS seconds), ``utc_s`` (int64, ``gps_s - leap_s``), ``leap_s``
    (int), ``leap_pending`` (bool). The arrays are held as read-only views.
    """

    rate_hz: float
    scenario: Scenario
    gps_s: np.ndarray
    utc_s: np.ndarray
    leap_s: np.ndarray
    leap_pending: np.ndarray
    pps_error_s: np.ndarray
    qerr_s: np.ndarray
    fix: np.ndarray
    n_sats: np.ndarray
    gdop: np.ndarray
    clock_bias_s: np.ndarray
    spoof_offset_s: np.ndarray

    def __post_init__(self):
        steps = self.gps_s.shape
        if len(steps) != 1:
            raise ValueError(f"gps_s has shape {self.gps_s.shape}, must have 1 dimension(s)")
        for name in ("utc_s", "leap_s", "leap_pending"):
            if getattr(self, name).shape != steps:
                raise ValueError(f"{name} has shape {getattr(self, name).shape}, must be {steps}")
        cube = self.pps_error_s.shape
        if len(cube) != 3 or cube[2] != steps[0]:
            raise ValueError(f"pps_error_s has shape {cube}, must be (trials, receivers, {steps[0]})")
        for name in ("qerr_s", "fix", "n_sats", "gdop", "clock_bias_s", "spoof_offset_s"):
            if getattr(self, name).shape != cube:
                raise ValueError(f"{name} has shape {getattr(self, name).shape}, must be {cube}")
        for field in dataclasses.fields(self):
            value = getattr(self, field.name)
            if isinstance(value, np.ndarray):
                view = value.view()
                view.flags.writeable = False
                object.__setattr__(self, field.name, view)

    @property
    def t_s(self) -> np.ndarray:
        """Seconds since the run's start, shape (steps,)."""
        return (self.gps_s - self.gps_s[0]).astype(np.float64)

    def to_frame(self, trial: int = 0) -> pd.DataFrame:
        """Tidy table of one trial: one row per (receiver, step), nanoseconds in ``*_ns`` columns.

        Columns: t_s, receiver (1-based: receiver ``j`` of the arrays is ``j + 1``), pps_error_ns, qerr_ns,
        fix, n_sats, gdop, utc_s, leap_s, leap_pending, clock_bias_ns, gps_s, spoof_offset_ns.
        """
        check_scalar(trial, "trial", min_val=0, max_val=self.pps_error_s.shape[0] - 1, integer=True)
        trial = int(trial)
        receivers, steps = self.pps_error_s.shape[1:]

        def per_step(a: np.ndarray) -> np.ndarray:
            return np.tile(a, receivers)

        return pd.DataFrame({
            "t_s": per_step(self.t_s),
            "receiver": np.repeat(np.arange(1, receivers + 1), steps),  # 1-based, as every report names them
            "pps_error_ns": self.pps_error_s[trial].reshape(-1) * 1e9,
            "qerr_ns": self.qerr_s[trial].reshape(-1) * 1e9,
            "fix": self.fix[trial].reshape(-1),
            "n_sats": self.n_sats[trial].reshape(-1),
            "gdop": self.gdop[trial].reshape(-1),
            "utc_s": per_step(self.utc_s),
            "leap_s": per_step(self.leap_s),
            "leap_pending": per_step(self.leap_pending),
            "clock_bias_ns": self.clock_bias_s[trial].reshape(-1) * 1e9,
            "gps_s": per_step(self.gps_s),
            "spoof_offset_ns": self.spoof_offset_s[trial].reshape(-1) * 1e9,
        })


def _root_seed(seed) -> np.random.SeedSequence:
    # A Generator stands for its original SeedSequence (not its current state), as documented.
    if isinstance(seed, np.random.Generator):
        return seed.bit_generator.seed_seq
    return root_seed(seed)


#: The random numbers of one (trial, receiver) stream, drawn in this order whatever the model (so that
#: two scenarios run with one seed share their noise): name, law, extra length beyond ``steps``.
_STREAM_LAYOUT = (
    ("white", "normal", 0),
    ("multipath", "normal", 1),
    ("wander", "normal", 1),
    ("geometry", "normal", 1),
    ("outlier_u", "uniform", 0),
    ("outlier_n", "normal", 0),
    ("jump_u", "uniform", 0),
    ("jump_n", "normal", 0),
    ("outage_u", "uniform", 0),
    ("outage_len", "geometric", 0),
    ("nofix_sats", "sats", 0),
    ("clock_wfm", "normal", 0),
    ("clock_rwfm", "normal", 0),
    ("clock_rwfm_phase", "normal", 0),
    ("clock_const", "uniform", None),  # 3 numbers: frequency offset, initial bias, tick phase
)


def _draw(root: np.random.SeedSequence, trials: int, receivers: int, steps: int,
          outage_mean_steps: float) -> dict[str, np.ndarray]:
    """Every stream's random numbers, each of shape (trials, receivers, length), filled in place."""
    draw = {}
    for name, law, extra in _STREAM_LAYOUT:
        length = 3 if extra is None else steps + extra
        draw[name] = np.empty((trials, receivers, length), dtype=np.int64 if law in ("geometric", "sats") else np.float64)
    p_geometric = min(1.0, 1.0 / outage_mean_steps)
    for i in range(trials):
        for j in range(receivers):
            rng = child_rng(root, i, j)
            for name, law, _ in _STREAM_LAYOUT:
                out = draw[name][i, j]
                if law == "normal":
                    rng.standard_normal(out=out)
                elif law == "uniform":
                    rng.random(out=out)
                elif law == "geometric":
                    out[:] = rng.geometric(p_geometric, out.shape[0])
                else:
                    out[:] = rng.integers(0, 4, out.shape[0])
    return draw


def _intervals_mask(start: np.ndarray, length: np.ndarray) -> np.ndarray:
    """True inside ``[k, k + length[k])`` for every ``k`` with ``start[k]``, along the last axis."""
    steps = start.shape[-1]
    flat = start.reshape(-1, steps)
    lengths = length.reshape(-1, steps)
    rows, cols = np.nonzero(flat)
    edges = np.zeros((flat.shape[0], steps + 1), dtype=np.int64)
    np.add.at(edges, (rows, cols), 1)
    np.add.at(edges, (rows, np.minimum(cols + lengths[rows, cols], steps)), -1)
    return (np.cumsum(edges[:, :steps], axis=1) > 0).reshape(start.shape)


def corrected_pps_adev(model: ReceiverModel, tau_s: np.ndarray, dt_s: float = 1.0) -> np.ndarray:
    """Theoretical ADEV of the qErr-corrected 1PPS error ``e`` (no outliers, jumps or outages).

    ``tau_s`` (k,) must be whole multiples ``n dt_s``; returns (k,). For stationary ``e`` with
    autocovariance ``R``, ``AVAR(n dt) = [6 R(0) - 8 R(n) + 2 R(2n)] / (2 n^2 dt^2)`` (the expectation
    of NIST SP 1065 eq. (7)); here ``R(0)`` holds the white variance
    ``sigma_w^2 exp(2 gdop_log_sigma^2)`` (the GDOP gain is log-normal) and each Gauss-Markov term adds
    ``sigma^2 exp(-n dt / tau)``. This is the GNSS-reference floor a disciplined oscillator can reach.
    """
    tau_s = np.asarray(tau_s, dtype=np.float64)
    n = np.rint(tau_s / dt_s)
    if tau_s.ndim != 1 or np.any(n < 1) or np.any(np.abs(n * dt_s - tau_s) > 1e-9 * tau_s):
        raise ValueError(f"tau_s == {tau_s}, must be a 1-D array of whole multiples of dt_s == {dt_s}")
    white_var = model.white_sigma_s**2 * np.exp(2.0 * model.gdop_log_sigma**2)

    def autocov(lag):
        return (np.where(lag == 0, white_var, 0.0)
                + model.multipath_sigma_s**2 * np.exp(-lag * dt_s / model.multipath_tau_s)
                + model.wander_sigma_s**2 * np.exp(-lag * dt_s / model.wander_tau_s))

    return np.sqrt((6.0 * autocov(0.0 * n) - 8.0 * autocov(n) + 2.0 * autocov(2.0 * n)) / (2.0 * tau_s**2))


def _solution_error(model: ReceiverModel, draw: dict[str, np.ndarray], geometry_gain, dt: float) -> np.ndarray:
    """Timing error ``e`` of the navigation solution, shape (trials, receivers, steps), seconds.

    Consumes (pops) its entries of ``draw`` to free memory early.
    """
    error = model.white_sigma_s * geometry_gain * draw.pop("white")
    error += gauss_markov(draw.pop("multipath"), model.multipath_sigma_s, model.multipath_tau_s, dt)
    error += gauss_markov(draw.pop("wander"), model.wander_sigma_s, model.wander_tau_s, dt)
    error += np.where(draw.pop("outlier_u") < model.outlier_prob, model.outlier_sigma_s * draw.pop("outlier_n"), 0.0)
    p_jump = 1.0 - (1.0 - model.jump_prob) ** dt
    error += np.cumsum(np.where(draw.pop("jump_u") < p_jump, model.jump_sigma_s * draw.pop("jump_n"), 0.0), axis=-1)
    return error


def _oscillator_bias_s(model: ReceiverModel, draw: dict[str, np.ndarray], t_s: np.ndarray, dt: float) -> np.ndarray:
    """True bias ``b`` of the free-running receiver oscillator, shape (trials, receivers, steps), seconds.

    ``b = b0 + y0 t`` plus white FM and random-walk FM, sampled exactly by
    :func:`~chronofuse.models.clock.two_state_clock_phase_s`, so that its second difference has SPEC
    section 4's autocorrelation. Pops its noise entries of ``draw``.
    """
    const = draw["clock_const"]
    y0 = model.clock_freq_offset_max * (2.0 * const[..., 0] - 1.0)
    b0 = model.clock_initial_bias_max_s * (2.0 * const[..., 1] - 1.0)
    noise = two_state_clock_phase_s(draw.pop("clock_wfm"), draw.pop("clock_rwfm"), draw.pop("clock_rwfm_phase"),
                                    h0=model.clock_h0, hm2=model.clock_hm2, dt_s=dt)
    return b0[..., None] + y0[..., None] * t_s + noise


def sawtooth_s(bias_hat_s: np.ndarray, tick_phase: np.ndarray, tick_hz: float, dt_s: float) -> np.ndarray:
    """Quantization error ``q`` of 1PPS edges placed on the nearest receiver-clock tick, seconds.

    ``bias_hat_s`` (trials, receivers, steps): the receiver's estimate of its clock bias at pulse ``k``
    (taken at ``t_k = k dt_s``); ``tick_phase`` (trials, receivers): ticks sit at local times
    ``(tick_phase + n) / tick_hz``. With ``u = t_k tick_hz + bias_hat tick_hz - tick_phase``,
    ``q = (round(u) - u) / tick_hz`` lies in ``[-T/2, T/2]``. ``t_k tick_hz`` is reduced modulo 1 in
    integer steps so that long runs keep the precision of a tick.
    """
    steps = bias_hat_s.shape[-1]
    step_frac = np.mod(dt_s * tick_hz, 1.0)
    u = np.mod(np.arange(steps) * step_frac, 1.0) + bias_hat_s * tick_hz - tick_phase[..., None]
    return (np.rint(u) - u) / tick_hz


def simulate_receivers(
    scenario: str | Scenario,
    duration_s: int,
    n_receivers: int,
    seed,
    trials: int = 1,
    *,
    rate_hz: float = 1.0,
    start_gps_s: int = DEFAULT_START_GPS_S,
    leap_s: int = GPS_MINUS_UTC_S,
    leap_event_gps_s: int | None = None,
    leap_announce_s: int = 86_400,
) -> ReceiverTruth:
    """Simulate ``n_receivers`` receivers at one site, independent errors, ``trials`` times.

    Parameters
    ----------
    scenario : a name in :data:`SCENARIOS` or a :class:`Scenario`.
    duration_s : run length in whole seconds; ``steps = duration_s * rate_hz``.
    n_receivers, trials : sizes of the first two axes of the result.
    seed : int, ``SeedSequence`` or ``Generator`` (its ``bit_generator.seed_seq``); stream ``(i, j)``
        (trial ``i``, receiver ``j``) is seeded by ``root.spawn(trials)[i].spawn(n_receivers)[j]`` of a
        fresh root, i.e. the child with spawn key ``root.spawn_key + (i, j)``, so it does not depend
        on how many trials or receivers ran.
    rate_hz : pulses kept per second; ``1 / rate_hz`` must be a whole number of seconds (1, 0.5, 0.1...).
    start_gps_s : GPS seconds of the first pulse (default 2025-01-01T00:00:00 UTC).
    leap_s : GPS - UTC at the start (s).
    leap_event_gps_s : first GPS second with ``leap_s + 1`` (a positive leap second); ``None``: none.
    leap_announce_s : ``leap_pending`` is set this long before the event.

    Returns
    -------
    ReceiverTruth with arrays of shape (trials, n_receivers, steps).
    """
    sc = _scenario_by_name(scenario) if isinstance(scenario, str) else scenario
    if not isinstance(sc, Scenario):
        raise TypeError(f"scenario == {scenario!r}, must be a scenario name or a Scenario")
    model = sc.model
    check_scalar(duration_s, "duration_s", min_val=1, integer=True)
    check_scalar(n_receivers, "n_receivers", min_val=1, integer=True)
    check_scalar(trials, "trials", min_val=1, integer=True)
    check_scalar(rate_hz, "rate_hz", min_val=0.0, max_val=1.0, include_min=False)
    period_s = int(round(1.0 / rate_hz))
    if abs(period_s * rate_hz - 1.0) > 1e-9:
        raise ValueError(f"rate_hz == {rate_hz}, must be 1 / (whole number of seconds)")
    check_scalar(start_gps_s, "start_gps_s", min_val=0, integer=True)
    check_scalar(leap_s, "leap_s", integer=True)
    check_scalar(leap_announce_s, "leap_announce_s", min_val=0, integer=True)
    if leap_event_gps_s is not None:
        check_scalar(leap_event_gps_s, "leap_event_gps_s", min_val=0, integer=True)
    affected = np.ones(int(n_receivers), dtype=bool)
    if sc.affected_receivers is not None:
        bad = [i for i in sc.affected_receivers if i >= n_receivers]
        if bad:
            raise ValueError(f"affected_receivers == {sc.affected_receivers}, must be < n_receivers == {n_receivers}")
        affected[:] = False
        affected[list(sc.affected_receivers)] = True

    steps = int(duration_s) // period_s
    if steps < 1:
        raise ValueError(f"duration_s == {duration_s}, must hold at least one pulse at rate_hz == {rate_hz}")
    dt = float(period_s)
    k = np.arange(steps, dtype=np.int64)
    gps_s = np.int64(start_gps_s) + k * period_s
    t_s = (k * period_s).astype(np.float64)

    # Leap seconds: per step.
    leap = np.full(steps, int(leap_s), dtype=np.int64)
    pending = np.zeros(steps, dtype=bool)
    if leap_event_gps_s is not None:
        leap[gps_s >= leap_event_gps_s] += 1
        pending = (gps_s < leap_event_gps_s) & (gps_s >= leap_event_gps_s - leap_announce_s)
    utc_s = gps_s - leap

    # Random numbers: one SeedSequence child per (trial, receiver).
    root = _root_seed(seed)
    shape = (int(trials), int(n_receivers), steps)
    draw = _draw(root, shape[0], shape[1], steps, model.outage_mean_s / dt)

    # Geometry.
    z = gauss_markov(draw.pop("geometry"), 1.0, model.gdop_tau_s, dt)
    gdop = np.maximum(1.0, model.gdop_median * np.exp(model.gdop_log_sigma * z))
    n_sats = np.clip(np.rint(model.n_sats_median - model.n_sats_spread * z), 4, model.n_sats_max).astype(np.int64)

    error = _solution_error(model, draw, gdop / model.gdop_median, dt)

    # Events.
    spoof = np.where(affected[:, None], sc.spoof_offset_s(t_s)[None, :], 0.0)
    spoof = np.broadcast_to(spoof, shape).copy()
    jammed = np.broadcast_to(affected[:, None] & sc.jammed(t_s)[None, :], shape)
    p_outage = 1.0 - np.exp(-model.outage_rate_hz * dt)
    outage = _intervals_mask(draw.pop("outage_u") < p_outage, draw.pop("outage_len"))
    fix = ~outage & ~jammed & (gdop <= model.gdop_fix_max)

    bias_hat = _oscillator_bias_s(model, draw, t_s, dt) + error + spoof
    sawtooth = sawtooth_s(bias_hat, draw["clock_const"][..., 2], model.tick_hz, dt)
    qerr = -np.round(sawtooth * 1e12) * 1e-12

    nan = np.float64(np.nan)
    return ReceiverTruth(
        rate_hz=float(rate_hz),
        scenario=sc,
        gps_s=gps_s,
        utc_s=utc_s,
        leap_s=leap,
        leap_pending=pending,
        pps_error_s=np.where(fix, error + spoof + sawtooth, nan),
        qerr_s=np.where(fix, qerr, nan),
        fix=fix,
        n_sats=np.where(fix, n_sats, np.where(jammed, 0, draw["nofix_sats"])),
        gdop=np.where(fix, gdop, nan),
        clock_bias_s=np.where(fix, bias_hat, nan),
        spoof_offset_s=spoof,
    )
