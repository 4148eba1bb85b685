"""Oscillator truth model: ADEV against theory, presets, seeding, temperature, EFC/DAC."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy.stats import chi2

from chronofuse.analysis.stability import oadev
from chronofuse.analysis.stability.edf import greenhall_edf
from chronofuse.analysis.theory import adev_theory
from chronofuse.models.oscillator import OscillatorModel, OscillatorTruth, PowerLaw, dac_quantize, simulate_oscillator
from chronofuse.models.oscillator_presets import PRESET_ADEV_1S, PRESETS, preset

CI = 0.99  # two-sided confidence of each interval checked below


def bare_model(**overrides) -> OscillatorModel:
    """A noiseless 10 MHz oscillator with a 16-bit, 5 V DAC; override any field."""
    base = OscillatorModel(
        name="bare",
        nominal_hz=10e6,
        h=PowerLaw(),
        drift_per_s=0.0,
        temp_coeff_per_K=0.0,
        efc_gain_per_V=0.0,
        dac_bits=16,
        dac_range_V=5.0,
        source="test",
    )
    return dataclasses.replace(base, **overrides)


def pooled_oadev_interval(truth: OscillatorTruth, tau_s: np.ndarray, alphas, ci: float = CI):
    """Mean overlapping AVAR over trials with a chi-square interval on the pooled EDF.

    Each trial's OADEV comes from ``chronofuse.analysis.stability.oadev``; its EDF is Greenhall's for the
    *known* noise type (the smallest over ``alphas`` present: conservative), not the type identified
    from a short record, which can be wrong at the largest taus and then inflates the EDF. (SP 1065
    Table 5's simple formulas overstate the flicker-PM EDF by up to 2x at m >= 100, so they are not used.)
    Trials are independent, so the mean of their AVARs has EDF = trials x EDF (SP 1065 eq. (45)
    applied to the mean). Returns ``(adev, lo, hi)`` of shape (k,).
    """
    trials, n_points = truth.x_s.shape
    avar = np.mean([oadev(x, truth.rate_hz, tau_s).dev ** 2 for x in truth.x_s], axis=0)
    m = np.rint(tau_s * truth.rate_hz).astype(int)
    edf = trials * np.array(
        [min(greenhall_edf(a, 2, int(mi), n_points, overlapping=True, modified=False) for a in alphas) for mi in m]
    )
    lo = np.sqrt(avar * edf / chi2.ppf((1.0 + ci) / 2.0, edf))
    hi = np.sqrt(avar * edf / chi2.ppf((1.0 - ci) / 2.0, edf))
    return np.sqrt(avar), lo, hi


ALPHA_OF = {"h2": 2, "h1": 1, "h0": 0, "hm1": -1, "hm2": -2}


# (coefficient, value, rate_hz): flicker PM is checked where SP 1065's formula holds (2 pi f_h tau >> 1:
# m >= 10); every other term is exact from tau = tau0.
NOISE_CASES = [
    ("h2", 1.0e-22, 1.0),
    ("h1", 1.0e-22, 10.0),
    ("h0", 1.0e-22, 1.0),
    ("hm1", 1.0e-22, 1.0),
    ("hm2", 1.0e-24, 1.0),
]


@pytest.mark.parametrize("key, value, rate_hz", NOISE_CASES)
def test_each_noise_type_alone_matches_theory_within_its_confidence_interval(key, value, rate_hz):
    model = bare_model(h=PowerLaw(**{key: value}))
    n_steps = 1 << 14
    truth = simulate_oscillator(model, n_steps / rate_hz, rate_hz, seed=2024, trials=16)
    tau_s = np.array([1.0, 10.0, 100.0, 1000.0])
    tau_s = tau_s[tau_s * rate_hz <= n_steps / 8]
    adev, lo, hi = pooled_oadev_interval(truth, tau_s, [ALPHA_OF[key]])
    theory = adev_theory(model.h, tau_s, rate_hz)
    assert np.all((lo <= theory) & (theory <= hi)), f"{key}: theory {theory}, interval [{lo}, {hi}], adev {adev}"


def test_drift_alone_gives_the_exact_allan_deviation_d_tau_over_root_two():
    drift_per_s = 2.0e-13
    truth = simulate_oscillator(bare_model(drift_per_s=drift_per_s), 4000.0, 1.0, seed=1)
    tau_s = np.array([1.0, 10.0, 100.0, 1000.0])
    dev = oadev(truth.x_s[0], 1.0, tau_s).dev
    np.testing.assert_allclose(dev, adev_theory(PowerLaw(), tau_s, 1.0, drift_per_s), rtol=1e-6)
    np.testing.assert_allclose(truth.x_s[0], drift_per_s * truth.t_s**2 / 2.0, rtol=1e-9, atol=1e-20)


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_presets_reproduce_their_documented_adev_at_one_second(name):
    model = preset(name)
    truth = simulate_oscillator(model, 4096.0, 1.0, seed=7, trials=8)
    present = [ALPHA_OF[key] for key, value in model.h.as_dict().items() if value > 0]
    adev, lo, hi = pooled_oadev_interval(truth, np.array([1.0]), present)
    documented = PRESET_ADEV_1S[name]
    assert lo[0] <= documented <= hi[0], f"{name}: documented {documented}, interval [{lo[0]}, {hi[0]}]"
    theory = adev_theory(model.h, np.array([1.0]), 1.0, model.drift_per_s)[0]
    assert theory == pytest.approx(documented, rel=1e-3)


def test_ocxo_preset_is_the_mti260_class_five_parts_in_ten_to_the_twelve():
    assert PRESET_ADEV_1S["ocxo"] == 5.0e-12
    assert "MTI-260" in preset("ocxo").source
    for model in PRESETS.values():
        assert model.source


def test_same_seed_gives_identical_truth_and_another_seed_does_not():
    model = preset("ocxo")
    a = simulate_oscillator(model, 500.0, 1.0, seed=3, trials=2)
    b = simulate_oscillator(model, 500.0, 1.0, seed=3, trials=2)
    c = simulate_oscillator(model, 500.0, 1.0, seed=4, trials=2)
    np.testing.assert_array_equal(a.x_s, b.x_s)
    np.testing.assert_array_equal(a.y, b.y)
    assert not np.array_equal(a.x_s, c.x_s)
    assert not np.array_equal(a.x_s[0], a.x_s[1])


@pytest.mark.parametrize("seed", [11, np.random.SeedSequence(11)])
def test_trial_i_is_the_same_whether_one_or_five_trials_run(seed):
    model = preset("tcxo")
    five = simulate_oscillator(model, 300.0, 1.0, seed=seed, trials=5)
    one = simulate_oscillator(model, 300.0, 1.0, seed=seed, trials=1)
    again = simulate_oscillator(model, 300.0, 1.0, seed=seed, trials=5)  # the seed object is not consumed
    np.testing.assert_array_equal(five.x_s[:1], one.x_s)
    np.testing.assert_array_equal(five.y[:1], one.y)
    np.testing.assert_array_equal(five.x_s, again.x_s)


def test_each_noise_type_draws_from_its_own_stream():
    h0_only = simulate_oscillator(bare_model(h=PowerLaw(h0=1e-22)), 200.0, 1.0, seed=5)
    hm2_only = simulate_oscillator(bare_model(h=PowerLaw(hm2=1e-26)), 200.0, 1.0, seed=5)
    both = simulate_oscillator(bare_model(h=PowerLaw(h0=1e-22, hm2=1e-26)), 200.0, 1.0, seed=5)
    np.testing.assert_allclose(both.y, h0_only.y + hm2_only.y, rtol=1e-14, atol=0)


def test_phase_is_the_integral_of_frequency_and_starts_at_zero():
    truth = simulate_oscillator(preset("ocxo"), 1000.0, 4.0, seed=9, trials=3)
    steps = 4000
    assert truth.t_s.shape == (steps,)
    assert truth.x_s.shape == truth.y.shape == (3, steps)
    np.testing.assert_array_equal(truth.x_s[:, 0], 0.0)
    np.testing.assert_allclose(truth.t_s, np.arange(steps) / 4.0)
    scale = np.abs(truth.x_s).max()
    np.testing.assert_allclose(np.diff(truth.x_s, axis=1), truth.y[:, :-1] / 4.0, atol=1e-13 * scale)


def test_number_of_steps_is_the_rounded_duration_times_rate():
    assert simulate_oscillator(bare_model(), 10.4, 1.0, seed=0).t_s.size == 10
    assert simulate_oscillator(bare_model(), 10.6, 1.0, seed=0).t_s.size == 11
    assert simulate_oscillator(bare_model(), 2.5, 10.0, seed=0).t_s.size == 25


def test_temperature_profile_shifts_frequency_by_the_coefficient_exactly():
    model = bare_model(temp_coeff_per_K=-3.0e-11, temp_ref_K=300.0)
    temperature_K = 300.0 + 5.0 * np.sin(np.arange(600) / 50.0)
    truth = simulate_oscillator(model, 600.0, 1.0, seed=0, trials=2, temperature_K=temperature_K)
    expected_y = -3.0e-11 * (temperature_K - 300.0)
    np.testing.assert_allclose(truth.y, np.broadcast_to(expected_y, (2, 600)), rtol=1e-12, atol=1e-25)
    np.testing.assert_allclose(truth.x_s[:, 1:], np.broadcast_to(np.cumsum(expected_y)[:-1], (2, 599)), rtol=1e-9)


def test_per_trial_temperature_profiles_are_applied_row_by_row():
    model = bare_model(temp_coeff_per_K=1.0e-10)
    temperature_K = np.array([np.full(50, 298.15), np.full(50, 299.15)])
    truth = simulate_oscillator(model, 50.0, 1.0, seed=0, trials=2, temperature_K=temperature_K)
    np.testing.assert_allclose(truth.y[0], 0.0, atol=1e-25)
    np.testing.assert_allclose(truth.y[1], 1.0e-10, rtol=1e-9)


def test_efc_voltage_reaches_frequency_through_the_dac_quantiser():
    bits, range_V, gain = 8, 4.0, 1.0e-7
    model = bare_model(efc_gain_per_V=gain, dac_bits=bits, dac_range_V=range_V)
    volts = np.linspace(-3.0, 3.0, 1000)  # beyond full scale at both ends
    truth = simulate_oscillator(model, 1000.0, 1.0, seed=0, efc_V=volts)
    step_V = range_V / 2**bits
    codes = truth.y[0] / (gain * step_V)
    np.testing.assert_allclose(codes, np.round(codes), atol=1e-6)  # whole DAC codes only
    assert codes.min() == pytest.approx(-(2 ** (bits - 1)))
    assert codes.max() == pytest.approx(2 ** (bits - 1) - 1)
    inside = np.abs(volts) < range_V / 2 - step_V
    assert np.all(np.abs(truth.y[0][inside] / gain - volts[inside]) <= step_V / 2 + 1e-12)


def test_dac_of_b_bits_quantises_to_range_over_two_to_the_b_steps():
    out = dac_quantize(np.array([0.0, 0.49, 0.51, -0.51, 2.6, 100.0, -100.0]), bits=3, range_V=8.0)
    np.testing.assert_array_equal(out, [0.0, 0.0, 1.0, -1.0, 3.0, 3.0, -4.0])  # step 8 / 2**3 = 1 V
    fine = dac_quantize(np.linspace(-1e-4, 1e-4, 10001), bits=20, range_V=5.0)  # input step < 1 LSB
    assert np.unique(np.round(np.diff(np.unique(fine)) / (5.0 / 2**20), 9)).tolist() == [1.0]


@pytest.mark.parametrize(
    "field, value",
    [
        ("nominal_hz", 0.0),
        ("drift_per_s", math.inf),
        ("temp_coeff_per_K", math.nan),
        ("dac_bits", 0),
        ("dac_bits", 12.5),
        ("dac_range_V", -1.0),
        ("temp_ref_K", 0.0),
        ("name", ""),
    ],
)
def test_bad_model_parameter_raises_an_error_naming_the_field(field, value):
    with pytest.raises(ValueError, match=field):
        dataclasses.replace(preset("ocxo"), **{field: value})


@pytest.mark.parametrize("key", ["h2", "h1", "h0", "hm1", "hm2"])
def test_negative_power_law_coefficient_raises_an_error_naming_it(key):
    with pytest.raises(ValueError, match=key):
        PowerLaw(**{key: -1e-24})


def test_bad_simulation_arguments_raise_errors_naming_them():
    model = preset("ocxo")
    with pytest.raises(ValueError, match="rate_hz"):
        simulate_oscillator(model, 10.0, 0.0, seed=1)
    with pytest.raises(ValueError, match="duration_s"):
        simulate_oscillator(model, -5.0, 1.0, seed=1)
    with pytest.raises(ValueError, match="trials"):
        simulate_oscillator(model, 10.0, 1.0, seed=1, trials=0)
    with pytest.raises(TypeError, match="seed"):
        simulate_oscillator(model, 10.0, 1.0, seed=-1)
    with pytest.raises(TypeError, match="seed"):
        simulate_oscillator(model, 10.0, 1.0, seed=1.5)
    with pytest.raises(ValueError, match="temperature_K"):
        simulate_oscillator(model, 10.0, 1.0, seed=1, temperature_K=np.zeros(9))
    with pytest.raises(ValueError, match="efc_V"):
        simulate_oscillator(model, 10.0, 1.0, seed=1, trials=2, efc_V=np.zeros((3, 10)))


def test_unknown_preset_lists_the_choices():
    with pytest.raises(ValueError, match=r"csac.*ocxo.*rb.*tcxo"):
        preset("hydrogen_maser")


def test_replace_overrides_a_preset_and_keeps_the_rest():
    model = dataclasses.replace(preset("ocxo"), drift_per_s=0.0, dac_bits=16)
    assert model.drift_per_s == 0.0 and model.dac_bits == 16
    assert model.h == preset("ocxo").h
    assert preset("ocxo").dac_bits == 20
