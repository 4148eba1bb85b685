"""Oscillator truth model (SPEC 2.1): power-law noise, aging, temperature and EFC through a DAC.

Fractional frequency noise has the one-sided PSD ``S_y(f) = sum_a h_a f**a``, a in {2, 1, 0, -1, -2}
(NIST SP 1065 section 4). Samples are taken every ``tau0 = 1/rate_hz``; the measurement bandwidth is
``f_h = rate_hz / 2``. ``x[n]`` is the phase (time error, s) at ``t_n = n tau0`` and ``y[n]`` the
fractional frequency averaged over ``[t_n, t_n + tau0)``, so ``x[n+1] = x[n] + tau0 y[n]`` exactly.

How each coefficient becomes a discrete sequence, and why it is exact
-------------------------------------------------------------------
Each choice below makes the Allan variance of the sampled phase equal SP 1065's formula (the ones in
``chronofuse.analysis.theory``) at every ``tau = m tau0`` where that formula is exact, and reproduces
the band-limited continuous process behind it where the formula is an asymptote.

* white PM (h2): ``S_x = h2 / (4 pi^2)`` flat up to ``f_h`` -> ``x`` white with variance
  ``h2 f_h / (4 pi^2)``. AVAR = ``3 var(x) / tau^2 = 3 f_h h2 / (4 pi^2 tau^2)``, exact for every m.
* flicker PM (h1): ``S_x = h1 / (4 pi^2 f)``. Kasdin–Walter flicker (alpha = -1) scaled by
  ``sqrt(h1 / (4 pi))`` (K-W eq. (39) with alpha = -1), reshaped by
  :func:`~chronofuse.models.noise.flicker_pm_gain` into the brick-wall ``1/f`` spectrum cut at ``f_h``.
  Its AVAR is ``(1/(2 tau^2)) int_0^f_h S_x(f) 16 sin^4(pi f tau) df``, whose asymptote is SP 1065's
  ``(1.038 + 3 ln(2 pi f_h tau)) h1 / (4 pi^2 tau^2)``: -7 % at m = 1, +0.04 % at m = 10, 0.003 % at
  m = 100 (the formula assumes ``2 pi f_h tau >> 1``). Plain K-W would be +6 % at m = 10, +4 % at 100.
* white FM (h0): ``y`` white with variance ``h0 f_h``; AVAR = ``h0 / (2 tau)`` exactly.
* flicker FM (h-1): K-W flicker ``y`` scaled by ``sqrt(pi h-1)``, reshaped by
  :func:`~chronofuse.models.noise.flicker_fm_gain` into the interval-average of continuous flicker FM,
  whose AVAR is ``2 ln 2 h-1`` at every tau (SP 1065 Table). Plain K-W gives 2 h-1 at m = 1 (+44 %).
* random-walk FM (h-2): the exact discretisation of a Wiener frequency ``y(t)`` with diffusion
  ``q = 2 pi^2 h-2`` (one-sided ``S_y = q / (2 pi^2 f^2)``) integrated into phase: per step
  ``dy = sqrt(q tau0) z1``, ``dx = tau0 y + tau0 dy / 2 + sqrt(q tau0^3 / 12) z2``. AVAR = ``q tau / 3
  = (2 pi^2 / 3) h-2 tau`` exactly (a plain random walk of ``y`` gives ``(2 m^2 + 1)/(6 m) q tau0``, +50 % at m = 1).
* drift D: ``x = D t^2 / 2`` (``y[n] = D (t_n + tau0/2)``); AVAR = ``D^2 tau^2 / 2`` exactly.
* temperature: ``y[n] += temp_coeff_per_K (T[n] - temp_ref_K)``, zero-order hold over the step.
* EFC: ``y[n] += efc_gain_per_V dac_quantize(V[n])``, zero-order hold (a DAC holds its output).

Randomness: the seed follows :mod:`chronofuse.seeding` (an int or SeedSequence reproduces, a Generator
is consumed); one child ``SeedSequence`` per trial (``spawn_key + (i,)`` of the root, exactly what
``SeedSequence.spawn`` gives a fresh sequence) and one grandchild per noise type, so trial ``i`` and
each component's realisation do not depend on how many trials run or which other ``h`` are non-zero.

Memory: peak resident memory of ``simulate_oscillator(preset("ocxo"), 1e7, 1.0, seed=1)`` (1e7 steps,
one trial, all five noise types plus drift), measured as ``VmHWM`` in a fresh subprocess with the
interpreter and imports included, is 691 MiB (118 MiB at 1e6 steps); outputs are 3 x 76 MiB of it.
Measured by ``benchmarks/bench_oscillator.py`` (``peak_memory_mib``) on 2026-11-24.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from chronofuse.models.noise import KasdinWalterFilter, flicker_fm_gain, flicker_pm_gain, tabulated_gain
from chronofuse.seeding import child_rng, root_seed
from chronofuse.validation import check_array, check_scalar

__all__ = [
    "PowerLaw",
    "OscillatorModel",
    "OscillatorTruth",
    "PRESETS",
    "preset",
    "dac_quantize",
    "simulate_oscillator",
]

SECONDS_PER_DAY = 86400.0
SECONDS_PER_MONTH = 30.4375 * SECONDS_PER_DAY
SECONDS_PER_YEAR = 365.25 * SECONDS_PER_DAY

# Component order fixes which grandchild SeedSequence each noise type draws from.
_COMPONENT_KEYS = {"h2": 0, "h1": 1, "h0": 2, "hm1": 3, "hm2": 4}


@dataclass(frozen=True)
class PowerLaw:
    """One-sided fractional-frequency PSD coefficients, ``S_y(f) = sum h_a f**a`` (NIST SP 1065 eq. (63)).

    Units make each ``h_a f**a`` a PSD in 1/Hz: ``h2`` Hz^-3, ``h1`` Hz^-2, ``h0`` Hz^-1, ``hm1``
    dimensionless, ``hm2`` Hz. All must be finite and >= 0.
    """

    h2: float = 0.0
    h1: float = 0.0
    h0: float = 0.0
    hm1: float = 0.0
    hm2: float = 0.0

    def __post_init__(self):
        for f in fields(self):
            check_scalar(getattr(self, f.name), f.name, min_val=0.0)

    def as_dict(self) -> dict[str, float]:
        """``{"h2": ..., "h1": ..., "h0": ..., "hm1": ..., "hm2": ...}``."""
        return {f.name: float(getattr(self, f.name)) for f in fields(self)}


@dataclass(frozen=True)
class OscillatorModel:
    """Physical parameters of a free-running oscillator (SPEC 2.1).

    Attributes
    ----------
    name : str
        Short name (``"ocxo"``).
    nominal_hz : float
        Nominal output frequency, Hz (> 0); informational (noise is fractional).
    h : PowerLaw
        Fractional-frequency noise coefficients.
    drift_per_s : float
        Linear frequency drift (aging) ``D``, fractional frequency per second.
    temp_coeff_per_K : float
        Fractional frequency change per kelvin (linear model around ``temp_ref_K``).
    efc_gain_per_V : float
        Fractional frequency change per volt of EFC deviation from the EFC centre voltage.
    dac_bits : int
        Resolution of the DAC driving the EFC, 1..32 bits.
    dac_range_V : float
        Full-scale span of that DAC, V (> 0); it outputs ``[-range/2, range/2)`` around the centre.
    source : str
        Where the numbers come from (datasheet, paper, or "user").
    temp_ref_K : float
        Temperature at which the temperature term is zero, K (> 0). Default 298.15 K (25 degC).
    """

    name: str
    nominal_hz: float
    h: PowerLaw
    drift_per_s: float
    temp_coeff_per_K: float
    efc_gain_per_V: float
    dac_bits: int
    dac_range_V: float
    source: str
    temp_ref_K: float = 298.15

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name:
            raise ValueError(f"name == {self.name!r}, must be a non-empty string")
        check_scalar(self.nominal_hz, "nominal_hz", min_val=0.0, include_min=False)
        if not isinstance(self.h, PowerLaw):
            raise TypeError(f"h == {self.h!r}, must be a PowerLaw")
        check_scalar(self.drift_per_s, "drift_per_s")
        check_scalar(self.temp_coeff_per_K, "temp_coeff_per_K")
        check_scalar(self.efc_gain_per_V, "efc_gain_per_V")
        check_scalar(self.dac_bits, "dac_bits", min_val=1, max_val=32, integer=True)
        check_scalar(self.dac_range_V, "dac_range_V", min_val=0.0, include_min=False)
        if not isinstance(self.source, str):
            raise TypeError(f"source == {self.source!r}, must be a string")
        check_scalar(self.temp_ref_K, "temp_ref_K", min_val=0.0, include_min=False)


@dataclass(frozen=True)
class OscillatorTruth:
    """Simulated truth of an oscillator.

    Attributes
    ----------
    t_s : ndarray of shape (steps,)
        Sample epochs relative to the start, ``n / rate_hz``, s.
    x_s : ndarray of shape (trials, steps)
        Phase (time error) at ``t_s``, s; ``x_s[:, 0] == 0``.
    y : ndarray of shape (trials, steps)
        Fractional frequency averaged over ``[t_n, t_n + 1/rate_hz)``;
        ``x_s[:, n+1] == x_s[:, n] + y[:, n] / rate_hz``.
    model : OscillatorModel
        The parameters used.
    rate_hz : float
        Sample rate, Hz.
    """

    t_s: np.ndarray
    x_s: np.ndarray
    y: np.ndarray
    model: OscillatorModel
    rate_hz: float


def _adev1_white_flicker(adev_1s: float, white_fm_1s: float) -> tuple[float, float]:
    """Split a datasheet ADEV at 1 s into ``(h0, hm1)``: white FM ``white_fm_1s`` at 1 s, the rest flicker.

    ``sigma^2(1 s) = h0/2 + 2 ln2 hm1`` (NIST SP 1065 Table 3); phase terms are negligible at 1 s.
    """
    h0 = 2.0 * white_fm_1s**2
    hm1 = (adev_1s**2 - white_fm_1s**2) / (2.0 * math.log(2.0))
    return h0, hm1


def _h2_from_floor(floor_dbc_hz: float, nominal_hz: float) -> float:
    """White PM from the phase-noise floor L(f): ``S_y = f^2 S_phi / nu0^2``, ``S_phi = 2 10^(L/10)``."""
    return 2.0 * 10.0 ** (floor_dbc_hz / 10.0) / nominal_hz**2


def _h1_from_point(l_dbc_hz: float, f_hz: float, nominal_hz: float) -> float:
    """Flicker PM from one point ``L(f)`` of the flicker-PM region: ``h1 = f S_phi(f) / nu0^2``."""
    return f_hz * 2.0 * 10.0 ** (l_dbc_hz / 10.0) / nominal_hz**2


# Datasheet (or seed) ADEV at tau = 1 s that each preset reproduces at rate_hz = 1 (f_h = 0.5 Hz).
PRESET_ADEV_1S = {"tcxo": 1.0e-9, "ocxo": 5.0e-12, "rb": 2.0e-11, "csac": 2.5e-10}

_TCXO_H0, _TCXO_HM1 = _adev1_white_flicker(PRESET_ADEV_1S["tcxo"], 6.0e-10)
_OCXO_H0, _OCXO_HM1 = _adev1_white_flicker(PRESET_ADEV_1S["ocxo"], 1.0e-12)
_RB_H0, _RB_HM1 = _adev1_white_flicker(PRESET_ADEV_1S["rb"], math.sqrt(2.0e-11**2 - 5.0e-13**2))
_CSAC_H0, _CSAC_HM1 = _adev1_white_flicker(PRESET_ADEV_1S["csac"], math.sqrt(2.5e-10**2 - 1.0e-12**2))

PRESETS: dict[str, OscillatorModel] = {
    # TCXO: Vig, "Quartz Crystal Resonators and Oscillators for Frequency Control and Timing
    # Applications - A Tutorial" (US Army CECOM, rev. 8.5), table "Comparison of frequency standards":
    # sigma_y(1 s) 1e-9, aging 5e-7/year, temperature 5e-7 over -55..+85 degC (taken as linear,
    # 5e-7/140 K). Split at 1 s: white FM 6e-10, flicker floor 8e-10; random walk reaching 1e-9 at
    # 1e4 s (assumed). Phase noise: floor -150 dBc/Hz, L(100 Hz) = -130 dBc/Hz (typical 10 MHz TCXO,
    # assumed). EFC: VCTCXO pull +-5 ppm over 3.3 V with a 12-bit DAC (assumed typical).
    "tcxo": OscillatorModel(
        name="tcxo",
        nominal_hz=10e6,
        h=PowerLaw(
            h2=_h2_from_floor(-150.0, 10e6),
            h1=_h1_from_point(-130.0, 100.0, 10e6),
            h0=_TCXO_H0,
            hm1=_TCXO_HM1,
            hm2=1.0e-18 / ((2.0 * math.pi**2 / 3.0) * 1.0e4),
        ),
        drift_per_s=5.0e-7 / SECONDS_PER_YEAR,
        temp_coeff_per_K=5.0e-7 / 140.0,
        efc_gain_per_V=1.0e-5 / 3.3,
        dac_bits=12,
        dac_range_V=3.3,
        source="Vig, Quartz Crystal Resonators and Oscillators tutorial (CECOM), comparison table; EFC/DAC assumed",
    ),
    # OCXO (MTI-260 class): sigma_y(1 s) = 5e-12 from seed 000 ("MTI-260, 5e-12/s"); split at 1 s into
    # white FM 1e-12 and flicker floor; random walk meeting the floor at 1000 s (assumed). Aging
    # 1e-10/day (typical after-30-days OCXO spec, assumed); temperature 1e-9 over -55..+85 degC (Vig
    # table, OCXO column). Phase noise floor -155 dBc/Hz, L(100 Hz) = -140 dBc/Hz (typical 10 MHz
    # SC-cut OCXO, assumed). EFC: +-2e-7 over +-2.5 V (8e-8/V) through a 20-bit DAC (the seed's
    # "high-precision DA"; e.g. AD5791, 20 bits over 5 V).
    "ocxo": OscillatorModel(
        name="ocxo",
        nominal_hz=10e6,
        h=PowerLaw(
            h2=_h2_from_floor(-155.0, 10e6),
            h1=_h1_from_point(-140.0, 100.0, 10e6),
            h0=_OCXO_H0,
            hm1=_OCXO_HM1,
            hm2=PRESET_ADEV_1S["ocxo"] ** 2 / ((2.0 * math.pi**2 / 3.0) * 1.0e3),
        ),
        drift_per_s=1.0e-10 / SECONDS_PER_DAY,
        temp_coeff_per_K=1.0e-9 / 140.0,
        efc_gain_per_V=8.0e-8,
        dac_bits=20,
        dac_range_V=5.0,
        source="seed 000 (MTI-260, ADEV 5e-12 at 1 s); Vig tutorial comparison table; aging/EFC/DAC assumed",
    ),
    # Rubidium (SRS PRS10 class): PRS10 data sheet ADEV < 2e-11 at 1 s, aging < 5e-11/month, phase
    # noise < -130 dBc/Hz at 10 Hz; white FM ~2e-11/sqrt(tau) (time-nuts, PRS10 measurements 2006).
    # Flicker floor 5e-13 and random walk meeting it at 1e5 s (assumed). Temperature: Vig table,
    # rubidium 3e-10 over -55..+68 degC. EFC: analog C-field tuning +-1e-9 over 5 V with a 16-bit DAC
    # (assumed typical).
    "rb": OscillatorModel(
        name="rb",
        nominal_hz=10e6,
        h=PowerLaw(
            h2=_h2_from_floor(-150.0, 10e6),
            h1=_h1_from_point(-130.0, 10.0, 10e6),
            h0=_RB_H0,
            hm1=_RB_HM1,
            hm2=5.0e-13**2 / ((2.0 * math.pi**2 / 3.0) * 1.0e5),
        ),
        drift_per_s=5.0e-11 / SECONDS_PER_MONTH,
        temp_coeff_per_K=3.0e-10 / 123.0,
        efc_gain_per_V=2.0e-9 / 5.0,
        dac_bits=16,
        dac_range_V=5.0,
        source="SRS PRS10 data sheet (ADEV 2e-11 at 1 s, aging 5e-11/month); Vig tutorial table; EFC/DAC assumed",
    ),
    # CSAC (Microchip/Microsemi SA.45s): ADEV 2.5e-10 at 1 s, white-FM slope to 100 s (data sheet),
    # aging 9e-10/month ("typical", data sheet rev. of 2011-2018; later units < 3e-10/month),
    # temperature +-5e-10 over -10..+70 degC; analog tuning 1.77e-11 per mV over 0..2.5 V, centre
    # 1.25 V (SA.45s User Guide, section 3.3.11). Flicker floor 1e-12 and random walk meeting it at
    # 1e5 s (assumed); internal ADC resolution taken as 16 bits (not published). Phase noise floor
    # -150 dBc/Hz (assumed); flicker PM negligible at the low rates a CSAC is sampled at.
    "csac": OscillatorModel(
        name="csac",
        nominal_hz=10e6,
        h=PowerLaw(
            h2=_h2_from_floor(-150.0, 10e6),
            h1=0.0,
            h0=_CSAC_H0,
            hm1=_CSAC_HM1,
            hm2=1.0e-12**2 / ((2.0 * math.pi**2 / 3.0) * 1.0e5),
        ),
        drift_per_s=9.0e-10 / SECONDS_PER_MONTH,
        temp_coeff_per_K=1.0e-9 / 80.0,
        efc_gain_per_V=1.77e-8,
        dac_bits=16,
        dac_range_V=2.5,
        source="Microchip SA.45s CSAC data sheet and User Guide rev. D; floor/random walk/ADC bits assumed",
    ),
}


def preset(name: str) -> OscillatorModel:
    """The preset oscillator called ``name`` (one of ``PRESETS``); ``dataclasses.replace`` to override."""
    try:
        return PRESETS[name]
    except (KeyError, TypeError):
        raise ValueError(f"name == {name!r}, must be one of {sorted(PRESETS)}") from None


def dac_quantize(volts, bits: int, range_V: float) -> np.ndarray:
    """Voltage a ``bits``-bit DAC of span ``range_V`` outputs when asked for ``volts``.

    Bipolar mid-tread DAC around the EFC centre voltage: step ``q = range_V / 2**bits``, codes
    ``-2**(bits-1) .. 2**(bits-1) - 1``, output ``q * clip(round(volts / q))`` (saturates at the ends).
    ``volts`` is any-shape array of deviations from the centre, V; returns the same shape.
    """
    check_scalar(bits, "bits", min_val=1, max_val=32, integer=True)
    check_scalar(range_V, "range_V", min_val=0.0, include_min=False)
    volts = np.asarray(volts, dtype=np.float64)
    if not np.all(np.isfinite(volts)):
        raise ValueError("volts contains NaN or infinite values")
    step = range_V / 2.0 ** int(bits)
    half = 2.0 ** (int(bits) - 1)
    return np.clip(np.rint(volts / step), -half, half - 1.0) * step


def _component_rng(base: np.random.SeedSequence, trial: int, component: str) -> np.random.Generator:
    return child_rng(base, trial, _COMPONENT_KEYS[component])


def _per_trial_profile(values, name: str, trials: int, steps: int) -> np.ndarray:
    """Validate a profile of shape (steps,) or (trials, steps); return it (never reshaped)."""
    arr = check_array(values, name, ndim=(1, 2))
    if arr.shape not in ((steps,), (trials, steps)):
        raise ValueError(f"{name} has shape {arr.shape}, must be ({steps},) or ({trials}, {steps})")
    return arr


def simulate_oscillator(
    model: OscillatorModel,
    duration_s: float,
    rate_hz: float,
    seed,
    trials: int = 1,
    *,
    temperature_K=None,
    efc_V=None,
) -> OscillatorTruth:
    """Simulate ``trials`` independent realisations of ``model`` (see the module docstring for the maths).

    Parameters
    ----------
    model : OscillatorModel
    duration_s : float
        Length; the number of steps is ``round(duration_s * rate_hz)`` (>= 2).
    rate_hz : float
        Sample rate; the noise bandwidth is ``f_h = rate_hz / 2``.
    seed : int or numpy.random.SeedSequence (reproduces) or numpy.random.Generator (consumed)
        :func:`chronofuse.seeding.root_seed`; trial ``i`` uses the child ``spawn_key + (i,)`` of the
        root: its result does not depend on ``trials``.
    trials : int
    temperature_K : array of shape (steps,) or (trials, steps), optional
        Oscillator temperature at each ``t_s``, K, held over the step.
    efc_V : array of shape (steps,) or (trials, steps), optional
        Requested EFC voltage (deviation from the centre), V, quantised by :func:`dac_quantize`.

    Returns
    -------
    OscillatorTruth
        ``t_s`` (steps,), ``x_s`` and ``y`` (trials, steps).
    """
    if not isinstance(model, OscillatorModel):
        raise TypeError(f"model == {model!r}, must be an OscillatorModel")
    check_scalar(duration_s, "duration_s", min_val=0.0, include_min=False)
    check_scalar(rate_hz, "rate_hz", min_val=0.0, include_min=False)
    check_scalar(trials, "trials", min_val=1, integer=True)
    trials = int(trials)
    steps = int(round(duration_s * rate_hz))
    if steps < 2:
        raise ValueError(f"duration_s * rate_hz == {duration_s * rate_hz}, must round to at least 2 steps")
    base = root_seed(seed)
    temperature = None if temperature_K is None else _per_trial_profile(temperature_K, "temperature_K", trials, steps)
    efc = None if efc_V is None else _per_trial_profile(efc_V, "efc_V", trials, steps)

    tau0 = 1.0 / rate_hz
    f_h = rate_hz / 2.0
    h = model.h
    y = np.zeros((trials, steps), dtype=np.float64)
    # Phase noise at steps + 1 epochs, so that y stays the exact first difference of x.
    phase = np.zeros((trials, steps + 1), dtype=np.float64) if (h.h2 > 0.0 or h.h1 > 0.0) else None

    if h.h0 > 0.0:
        _add_white_fm(y, h.h0, f_h, base)
    if h.hm2 > 0.0:
        _add_random_walk_fm(y, h.hm2, tau0, base)
    if h.h2 > 0.0:
        sigma = math.sqrt(h.h2 * f_h) / (2.0 * math.pi)
        for i in range(trials):
            white = _component_rng(base, i, "h2").standard_normal(steps + 1)
            white *= sigma
            phase[i] += white
            del white
    if h.hm1 > 0.0 or h.h1 > 0.0:
        _add_flicker(y, phase, h, base)

    # Deterministic terms.
    t_s = np.arange(steps, dtype=np.float64) * tau0
    if model.drift_per_s != 0.0:
        y += model.drift_per_s * (t_s + 0.5 * tau0)
    if temperature is not None:
        y += model.temp_coeff_per_K * (temperature - model.temp_ref_K)
    if efc is not None:
        y += model.efc_gain_per_V * dac_quantize(efc, model.dac_bits, model.dac_range_V)

    x = np.empty((trials, steps), dtype=np.float64)
    x[:, 0] = 0.0
    np.cumsum(y[:, :-1], axis=1, out=x[:, 1:])
    x[:, 1:] *= tau0
    if phase is not None:
        x += phase[:, :-1]
        x -= phase[:, :1]
        for i in range(trials):
            increments = np.diff(phase[i])
            increments *= rate_hz
            y[i] += increments
            del increments
    return OscillatorTruth(t_s=t_s, x_s=x, y=y, model=model, rate_hz=float(rate_hz))


def _add_white_fm(y: np.ndarray, h0: float, f_h: float, base: np.random.SeedSequence) -> None:
    """White FM: ``y`` white with variance ``h0 f_h`` (AVAR ``h0 / (2 tau)``), added in place."""
    sigma = math.sqrt(h0 * f_h)
    for i in range(y.shape[0]):
        white = _component_rng(base, i, "h0").standard_normal(y.shape[1])
        white *= sigma
        y[i] += white


def _add_random_walk_fm(y: np.ndarray, hm2: float, tau0: float, base: np.random.SeedSequence) -> None:
    """Random-walk FM, exact discretisation of an integrated Wiener process, added to ``y`` in place.

    With ``q = 2 pi^2 hm2`` and ``z1, z2`` unit normals per step: ``y(t_{n+1}) = y(t_n) + sqrt(q tau0) z1``
    and the interval average ``y[n] = y(t_n) + sqrt(q tau0) z1 / 2 + sqrt(q tau0 / 12) z2`` (the
    covariance of the Wiener increment and its integral, q [[tau0, tau0^2/2], [tau0^2/2, tau0^3/3]]).
    """
    q = 2.0 * math.pi**2 * hm2
    for i in range(y.shape[0]):
        rng = _component_rng(base, i, "hm2")
        kicks = rng.standard_normal(y.shape[1])
        kicks *= math.sqrt(q * tau0)
        walk = np.cumsum(kicks)
        kicks *= 0.5
        walk -= kicks  # y(t_n) + kick_n / 2
        del kicks
        inner = rng.standard_normal(y.shape[1])
        inner *= math.sqrt(q * tau0 / 12.0)
        walk += inner
        del inner
        y[i] += walk
        del walk


def _add_flicker(y: np.ndarray, phase: np.ndarray | None, h: PowerLaw, base: np.random.SeedSequence) -> None:
    """Flicker FM into ``y`` and flicker PM into ``phase`` (K-W, alpha = -1, shaped), in place.

    Flicker FM: ``sqrt(pi hm1)`` times K-W flicker shaped by ``flicker_fm_gain``; flicker PM:
    ``sqrt(h1 / (4 pi))`` times K-W flicker shaped by ``flicker_pm_gain`` (K-W eq. (39) with
    alpha = -1, where the level does not depend on tau0).
    """
    trials, steps = y.shape
    if h.hm1 > 0.0:
        kw = KasdinWalterFilter(-1.0, steps, gain=tabulated_gain(flicker_fm_gain))
        for i in range(trials):
            kw.add_row(y[i], _component_rng(base, i, "hm1"), math.sqrt(math.pi * h.hm1))
        del kw
    if h.h1 > 0.0:
        kw = KasdinWalterFilter(-1.0, steps + 1, gain=flicker_pm_gain)
        for i in range(trials):
            kw.add_row(phase[i], _component_rng(base, i, "h1"), math.sqrt(h.h1 / (4.0 * math.pi)))
