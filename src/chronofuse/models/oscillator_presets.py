"""Preset oscillators: TCXO, OCXO, rubidium and CSAC parameters from their data sheets.

One idea: turn published figures (ADEV at 1 s, phase-noise floor and flicker point, aging,
temperature coefficient, EFC pull and DAC) into :class:`~chronofuse.models.oscillator.OscillatorModel`
instances. ADEV at 1 s is split into white and flicker FM with ``sigma^2(1 s) = h0/2 + 2 ln2 hm1``
(NIST SP 1065 Table 3); phase noise ``L(f)`` becomes ``h2``/``h1`` through ``S_y = f^2 S_phi / nu0^2``,
``S_phi = 2 10^(L/10)``. Each preset's comment names its source and which numbers are assumed.

The presets are the members of the family's registry :data:`OSCILLATORS` (:mod:`chronofuse.registry`):
``OSCILLATORS.create("ocxo", drift_per_s=2e-15)`` is the preset with those fields replaced (validated
by :class:`OscillatorConfig`, each field with its unit); a plugin adds a preset through an entry point in
the group ``chronofuse.oscillators`` whose object is :func:`oscillator_entry` of an ``OscillatorModel``.
"""

from __future__ import annotations

import math

from pydantic import Field

from chronofuse.models.oscillator import OscillatorModel, PowerLaw
from chronofuse.registry import Config, Entry, Registry
from chronofuse.validation import InputError

__all__ = ["PRESETS", "PRESET_ADEV_1S", "preset", "OSCILLATORS", "OscillatorConfig", "oscillator_entry"]

SECONDS_PER_DAY = 86400.0
SECONDS_PER_MONTH = 30.4375 * SECONDS_PER_DAY
SECONDS_PER_YEAR = 365.25 * SECONDS_PER_DAY


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


def _hm2_meeting(adev: float, tau_s: float) -> float:
    """Random-walk FM whose ADEV is ``adev`` at ``tau_s``: ``sigma^2 = (2 pi^2 / 3) hm2 tau`` (SP 1065 Table 3)."""
    return adev**2 / ((2.0 * math.pi**2 / 3.0) * tau_s)


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
            hm2=_hm2_meeting(1.0e-9, 1.0e4),
        ),
        drift_per_s=5.0e-7 / SECONDS_PER_YEAR,
        temp_coeff_per_K=5.0e-7 / 140.0,
        efc_gain_per_V=1.0e-5 / 3.3,
        dac_bits=12,
        dac_range_V=3.3,
        source="Vig, Quartz Crystal Resonators and Oscillators tutorial (CECOM), comparison table; EFC/DAC assumed",
    ),
    # OCXO (MTI-260 class): sigma_y(1 s) = 5e-12 from the GNSSDO paper ("MTI-260, 5e-12/s"); split at 1 s into
    # white FM 1e-12 and flicker floor; random walk meeting the floor at 1000 s (assumed). Aging
    # 1e-10/day (typical after-30-days OCXO spec, assumed); temperature 1e-9 over -55..+85 degC (Vig
    # table, OCXO column). Phase noise floor -155 dBc/Hz, L(100 Hz) = -140 dBc/Hz (typical 10 MHz
    # SC-cut OCXO, assumed). EFC: +-2e-7 over +-2.5 V (8e-8/V) through a 20-bit DAC (the source paper's
    # "high-precision DA"; e.g. AD5791, 20 bits over 5 V).
    "ocxo": OscillatorModel(
        name="ocxo",
        nominal_hz=10e6,
        h=PowerLaw(
            h2=_h2_from_floor(-155.0, 10e6),
            h1=_h1_from_point(-140.0, 100.0, 10e6),
            h0=_OCXO_H0,
            hm1=_OCXO_HM1,
            hm2=_hm2_meeting(PRESET_ADEV_1S["ocxo"], 1.0e3),
        ),
        drift_per_s=1.0e-10 / SECONDS_PER_DAY,
        temp_coeff_per_K=1.0e-9 / 140.0,
        efc_gain_per_V=8.0e-8,
        dac_bits=20,
        dac_range_V=5.0,
        source="the GNSSDO paper (MTI-260, ADEV 5e-12 at 1 s); Vig tutorial comparison table; aging/EFC/DAC assumed",
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
            hm2=_hm2_meeting(5.0e-13, 1.0e5),
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
            hm2=_hm2_meeting(1.0e-12, 1.0e5),
        ),
        drift_per_s=9.0e-10 / SECONDS_PER_MONTH,
        temp_coeff_per_K=1.0e-9 / 80.0,
        efc_gain_per_V=1.77e-8,
        dac_bits=16,
        dac_range_V=2.5,
        source="Microchip SA.45s CSAC data sheet and User Guide rev. D; floor/random walk/ADC bits assumed",
    ),
}


class OscillatorConfig(Config):
    """Fields of a preset that a caller may replace (None: the preset's own value)."""

    nominal_hz: float | None = Field(None, gt=0.0, description="nominal output frequency (Hz)")
    h: PowerLaw | None = Field(None, description="noise: h2 (s^3), h1 (s^2), h0 (s), hm1 (dimensionless), hm2 (1/s) "
                                                 "(PowerLaw)")
    drift_per_s: float | None = Field(None, description="linear frequency drift, aging (1/s)")
    temp_coeff_per_K: float | None = Field(None, description="fractional frequency per kelvin (1/K)")
    efc_gain_per_V: float | None = Field(None, description="fractional frequency per EFC volt (1/V)")
    dac_bits: int | None = Field(None, ge=1, le=32, description="resolution of the EFC DAC (bits)")
    dac_range_V: float | None = Field(None, gt=0.0, description="span of the EFC DAC (V)")
    temp_ref_K: float | None = Field(None, gt=0.0, description="temperature of zero temperature offset (K)")


def oscillator_entry(model: OscillatorModel) -> Entry:
    """The registry entry of a preset: ``create`` replaces the fields given."""
    if not isinstance(model, OscillatorModel):
        raise TypeError(f"model == {model!r}, must be an OscillatorModel")
    return Entry(model, OscillatorConfig, model.source)


OSCILLATORS = Registry("oscillators", builtins=lambda: {name: oscillator_entry(m) for name, m in PRESETS.items()})


def preset(name: str) -> OscillatorModel:
    """The preset oscillator called ``name`` (one of ``PRESETS``, or a plugin's); ``dataclasses.replace`` to
    override, or ``OSCILLATORS.create(name, **fields)``."""
    if isinstance(name, str) and name in PRESETS:
        return PRESETS[name]
    if isinstance(name, str) and name in OSCILLATORS:
        return OSCILLATORS.create(name)
    raise InputError(f"{{oscillator}} == {name!r}, must be one of {sorted(OSCILLATORS.names())}", fields=("oscillator",))
