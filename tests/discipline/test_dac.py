"""EFC actuation: the DAC's bits quantize the correction, its range saturates it, near-rail is flagged."""

import numpy as np
import pytest

from chronofuse.discipline.dac import Dac
from chronofuse.models.oscillator_presets import preset


def test_the_ocxo_dac_quantizes_corrections_to_its_frequency_lsb():
    dac = Dac.for_oscillator(preset("ocxo"))
    lsb = 8e-8 * 5.0 / 2**20
    assert dac.frequency_step == pytest.approx(lsb, rel=1e-12)
    rng = np.random.default_rng(0)
    y = rng.uniform(-1e-8, 1e-8, 10_000)
    applied, near = dac.apply(y)
    assert np.all(np.abs(applied - y) <= lsb / 2 * (1 + 1e-9))
    assert np.allclose(applied / lsb, np.rint(applied / lsb), atol=1e-6)
    # uniform quantization error: rms lsb / sqrt(12)
    assert np.sqrt(np.mean((applied - y) ** 2)) == pytest.approx(lsb / np.sqrt(12), rel=0.05)
    assert not near.any()


def test_commands_beyond_the_range_saturate_at_the_rails_and_raise_the_alarm():
    dac = Dac(bits=8, range_V=2.0, efc_gain_per_V=1e-7, rail_margin=0.0)
    lo, hi = dac.frequency_range
    assert lo == pytest.approx(-1e-7) and hi == pytest.approx(1e-7 * (1 - 2 / 256))
    applied, near = dac.apply(np.array([5e-7, -5e-7, 0.0]))
    assert applied.tolist() == pytest.approx([hi, lo, 0.0])
    assert near.tolist() == [True, True, False]


def test_the_rail_margin_flags_codes_close_to_the_end():
    dac = Dac(bits=16, range_V=2.0, efc_gain_per_V=1e-7, rail_margin=0.1)
    _, near = dac.apply(np.array([0.85e-7, 0.95e-7, -0.95e-7]))
    assert near.tolist() == [False, True, True]


def test_a_negative_efc_slope_still_applies_the_commanded_sign():
    dac = Dac(bits=16, range_V=5.0, efc_gain_per_V=-8e-8)
    applied, _ = dac.apply(np.array([1e-9, -1e-9]))
    assert applied[0] == pytest.approx(1e-9, abs=dac.frequency_step)
    assert applied[1] == pytest.approx(-1e-9, abs=dac.frequency_step)


@pytest.mark.parametrize("bits", [0, -3, 33, 2.5])
def test_a_dac_with_no_bits_is_refused_naming_the_option(bits):
    with pytest.raises((ValueError, TypeError), match="dac_bits"):
        Dac(bits=bits, range_V=5.0, efc_gain_per_V=8e-8)
