"""Oscillator truth model: power-law noise, aging, temperature and EFC through a DAC.

The parameters (:class:`PowerLaw`, :class:`OscillatorModel`) and their simulation live here; the
data-sheet presets (``preset("ocxo")``, ``PRESETS``) in :mod:`chronofuse.models.oscillator_presets`.

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
from chronofuse.validation import InputError, check_array, check_scalar

__all__ = [
    "PowerLaw",
    "OscillatorModel",
    "OscillatorTruth",
    "dac_quantize",
    "simulate_oscillator",
]

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
    """Physical parameters of a free-running oscillator.

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
    first_trial: int = 0,
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
    first_trial : int
        The first trial's index: the result's trial ``i`` is trial ``first_trial + i`` of a larger run (the
        same numbers), so a run can be simulated in blocks of trials.
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
    check_scalar(first_trial, "first_trial", min_val=0, integer=True)
    first = int(first_trial)
    steps = int(round(duration_s * rate_hz))
    if steps < 2:
        raise InputError(f"{{duration_s}} * {{rate_hz}} == {duration_s * rate_hz}, must round to at least 2 steps",
                         fields=("duration_s", "rate_hz"))
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
        _add_white_fm(y, h.h0, f_h, base, first)
    if h.hm2 > 0.0:
        _add_random_walk_fm(y, h.hm2, tau0, base, first)
    if h.h2 > 0.0:
        sigma = math.sqrt(h.h2 * f_h) / (2.0 * math.pi)
        for i in range(trials):
            white = _component_rng(base, first + i, "h2").standard_normal(steps + 1)
            white *= sigma
            phase[i] += white
            del white
    if h.hm1 > 0.0 or h.h1 > 0.0:
        _add_flicker(y, phase, h, base, first)

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


def _add_white_fm(y: np.ndarray, h0: float, f_h: float, base: np.random.SeedSequence, first: int = 0) -> None:
    """White FM: ``y`` white with variance ``h0 f_h`` (AVAR ``h0 / (2 tau)``), added in place."""
    sigma = math.sqrt(h0 * f_h)
    for i in range(y.shape[0]):
        white = _component_rng(base, first + i, "h0").standard_normal(y.shape[1])
        white *= sigma
        y[i] += white


def _add_random_walk_fm(y: np.ndarray, hm2: float, tau0: float, base: np.random.SeedSequence, first: int = 0) -> None:
    """Random-walk FM, exact discretisation of an integrated Wiener process, added to ``y`` in place.

    With ``q = 2 pi^2 hm2`` and ``z1, z2`` unit normals per step: ``y(t_{n+1}) = y(t_n) + sqrt(q tau0) z1``
    and the interval average ``y[n] = y(t_n) + sqrt(q tau0) z1 / 2 + sqrt(q tau0 / 12) z2`` (the
    covariance of the Wiener increment and its integral, q [[tau0, tau0^2/2], [tau0^2/2, tau0^3/3]]).
    """
    q = 2.0 * math.pi**2 * hm2
    for i in range(y.shape[0]):
        rng = _component_rng(base, first + i, "hm2")
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


def _add_flicker(y: np.ndarray, phase: np.ndarray | None, h: PowerLaw, base: np.random.SeedSequence,
                 first: int = 0) -> None:
    """Flicker FM into ``y`` and flicker PM into ``phase`` (K-W, alpha = -1, shaped), in place.

    Flicker FM: ``sqrt(pi hm1)`` times K-W flicker shaped by ``flicker_fm_gain``; flicker PM:
    ``sqrt(h1 / (4 pi))`` times K-W flicker shaped by ``flicker_pm_gain`` (K-W eq. (39) with
    alpha = -1, where the level does not depend on tau0).
    """
    trials, steps = y.shape
    if h.hm1 > 0.0:
        kw = KasdinWalterFilter(-1.0, steps, gain=tabulated_gain(flicker_fm_gain))
        for i in range(trials):
            kw.add_row(y[i], _component_rng(base, first + i, "hm1"), math.sqrt(math.pi * h.hm1))
        del kw
    if h.h1 > 0.0:
        kw = KasdinWalterFilter(-1.0, steps + 1, gain=flicker_pm_gain)
        for i in range(trials):
            kw.add_row(phase[i], _component_rng(base, first + i, "h1"), math.sqrt(h.h1 / (4.0 * math.pi)))
