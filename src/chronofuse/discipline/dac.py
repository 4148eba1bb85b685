"""EFC actuation through a DAC (2.1): a frequency command becomes a code, a voltage, a frequency.

A controller asks for a fractional-frequency correction ``y_cmd``. The EFC moves the oscillator by
``efc_gain_per_V`` per volt around its centre, so the voltage asked for is ``V = y_cmd / efc_gain``;
a ``bits``-bit bipolar DAC of span ``range_V`` outputs ``V_q = q clip(round(V / q), -2^(b-1), 2^(b-1) - 1)``
with ``q = range_V / 2^b`` (the same mid-tread converter as the oscillator truth model,
:func:`chronofuse.models.oscillator.dac_quantize`), and the applied correction is
``y = efc_gain V_q``. So the correction is quantized in steps of ``efc_gain q`` (the frequency LSB;
an OCXO with 8e-8/V through 20 bits over 5 V: 3.8e-13) and saturates at the rails
(``+-efc_gain range_V / 2``). A DAC within ``rail_margin`` (a fraction of the half span) of a rail
is an alarm: the loop is about to lose control (ageing has used up the tuning range).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from chronofuse.models.oscillator import OscillatorModel, dac_quantize
from chronofuse.validation import check_scalar

__all__ = ["Dac"]


@dataclass(frozen=True)
class Dac:
    """A DAC driving an oscillator's EFC.

    Parameters
    ----------
    bits : int, 1..32
    range_V : full span (V), > 0; the output covers ``[-range_V/2, range_V/2)`` around the EFC centre.
    efc_gain_per_V : fractional frequency per volt (non-zero; its sign is the tuning slope).
    rail_margin : a code within this fraction of the half span from either end is "near a rail", in [0, 1).
    """

    bits: int
    range_V: float
    efc_gain_per_V: float
    rail_margin: float = 0.05

    def __post_init__(self):
        check_scalar(self.bits, "dac_bits", min_val=1, max_val=32, integer=True)
        check_scalar(self.range_V, "dac_range_V", min_val=0.0, include_min=False)
        check_scalar(self.efc_gain_per_V, "efc_gain_per_V")
        if self.efc_gain_per_V == 0.0:
            raise ValueError("efc_gain_per_V == 0.0, must be non-zero (the EFC must tune the oscillator)")
        check_scalar(self.rail_margin, "rail_margin", min_val=0.0, max_val=1.0, include_max=False)

    @classmethod
    def for_oscillator(cls, model: OscillatorModel, rail_margin: float = 0.05) -> Dac:
        """The DAC of an oscillator model (its ``dac_bits``, ``dac_range_V``, ``efc_gain_per_V``)."""
        return cls(model.dac_bits, model.dac_range_V, model.efc_gain_per_V, rail_margin)

    @property
    def step_V(self) -> float:
        """Voltage LSB ``q = range_V / 2^bits`` (V)."""
        return self.range_V / 2.0 ** int(self.bits)

    @property
    def frequency_step(self) -> float:
        """Fractional-frequency LSB ``|efc_gain| q``."""
        return abs(self.efc_gain_per_V) * self.step_V

    @property
    def frequency_range(self) -> tuple[float, float]:
        """Lowest and highest applicable corrections (fractional frequency)."""
        half = 2.0 ** (int(self.bits) - 1)
        ends = self.efc_gain_per_V * self.step_V * np.array([-half, half - 1.0])
        return float(ends.min()), float(ends.max())

    def apply(self, y_cmd) -> tuple[np.ndarray, np.ndarray]:
        """``(y_applied, near_rail)`` for commanded corrections ``y_cmd`` (any shape; NaN not allowed).

        ``y_applied = efc_gain * dac_quantize(y_cmd / efc_gain)``; ``near_rail`` is True where the
        code is within ``rail_margin`` of the half span from an end (saturated codes included).
        """
        volts = np.asarray(y_cmd, dtype=np.float64) / self.efc_gain_per_V
        v_q = dac_quantize(volts, int(self.bits), float(self.range_V))
        half_span = 0.5 * self.range_V
        near = np.abs(v_q) >= half_span * (1.0 - self.rail_margin) - self.step_V
        return self.efc_gain_per_V * v_q, near
