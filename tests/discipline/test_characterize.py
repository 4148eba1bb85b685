"""`characterize`: an oscillator's h-coefficients, drift and temperature coefficient from its record.

Oracles: the measured overlapping ADEV's simultaneous confidence intervals on two real records (an OCXO
against an H-maser, a Cs 5071A); simulated oscillators of known coefficients and drift over a seed grid
(hold-out: not the presets); the analytic holdover error ``h^2 AVAR(h) + sigma_D^2 h^4``. Negative verdicts:
a wrong model is outside the intervals, a pure power-law record gets no spur, and records that cannot be
fitted are refused naming the file.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from chronofuse.analysis.theory import adev_theory
from chronofuse.discipline.characterize import (characterize, characterize_file, model_adev, oscillator_document,
                                                 oscillator_from_document, predict_holdover)
from chronofuse.models.oscillator import OscillatorModel, PowerLaw, simulate_oscillator
from chronofuse.models.oscillator_presets import preset
from chronofuse.validation import InputError

DATA = Path(__file__).resolve().parents[1] / "data" / "stability"
OCXO = DATA / "ocxo" / "ocxo_frequency.txt"
CS = DATA / "Cs5071A" / "5071A_phase.txt.gz"


@pytest.fixture(scope="module")
def ocxo():
    return characterize_file(OCXO, kind="freq", rate_hz=1.0, nominal_hz=1e7, holdover_trials=20)


@pytest.fixture(scope="module")
def cs():
    return characterize_file(CS, holdover_trials=20)


@pytest.mark.parametrize("name", ["ocxo", "cs"])
def test_the_fitted_model_lies_inside_the_measured_adev_intervals_at_every_tau(name, request):
    result = request.getfixturevalue(name)
    a = result.adev
    assert a.tau_s.size >= 12
    assert np.all(np.isfinite(a.lo) & np.isfinite(a.hi))
    assert result.fits and np.all((result.model_adev >= a.lo) & (result.model_adev <= a.hi))
    # the intervals are the simultaneous 95 % ones, each at 1 - 0.05 / k
    assert a.ci == pytest.approx(1.0 - 0.05 / a.tau_s.size)


@pytest.mark.parametrize("name", ["ocxo", "cs"])
def test_a_wrong_model_is_outside_the_intervals(name, request):
    """The check can fail: the fitted model with its frequency noise (white, flicker, random-walk FM) twice
    too large, or with its white PM halved, leaves the intervals."""
    result = request.getfixturevalue(name)
    a = result.adev
    h = result.h
    for wrong in (dataclasses.replace(h, h0=2 * h.h0, hm1=2 * h.hm1, hm2=2 * h.hm2),
                  dataclasses.replace(h, h2=h.h2 / 2)):
        m = model_adev(wrong, a.tau_s, result.rate_hz, result.spurs, result.tau0_excess_avar)
        assert not np.all((m >= a.lo) & (m <= a.hi))


def test_the_ocxo_record_shows_its_periodic_fm_and_the_cs_record_none(ocxo, cs):
    """The OCXO record's frequency has a line near 0.257 Hz (its Welch periodogram is 17x its running median
    there); the fit cannot pass the 2 s and 4 s intervals without it (their Allan variances are 4.5x apart,
    more than white PM's 4x, the most any power law gives)."""
    assert len(ocxo.spurs) == 1 and ocxo.spurs[0][0] == pytest.approx(0.2568, abs=2e-3)
    assert cs.spurs == ()
    no_spur = model_adev(ocxo.h, ocxo.adev.tau_s, 1.0, (), ocxo.tau0_excess_avar)
    assert not np.all((no_spur >= ocxo.adev.lo) & (no_spur <= ocxo.adev.hi))


def test_real_records_give_plausible_figures(ocxo, cs):
    """The OCXO's flicker floor is its ADEV plateau (5e-12 at 32..512 s); the Cs standard's white FM gives
    its tau^-1/2 slope (4.65e-13 at 1024 s); the record's loop and holdover are finite and ordered."""
    assert math.sqrt(2 * math.log(2) * ocxo.h.hm1) == pytest.approx(5e-12, rel=0.2)
    assert math.sqrt(cs.h.h0 / 2 / 1024) == pytest.approx(4.65e-13, rel=0.1)
    for r in (ocxo, cs):
        rms = [row["rms_s"] for row in r.holdover]
        assert rms == sorted(rms) and all(np.isfinite(rms))
        assert all(row["rms_ci_s"][0] <= row["rms_s"] <= row["rms_ci_s"][1] for row in r.holdover)
        assert r.loop.crossover_s > 1 and 0 < r.loop.kalman_gains[0] < 1
    # a Cs standard holds far better than an OCXO
    assert cs.holdover[-1]["rms_s"] < ocxo.holdover[-1]["rms_s"] / 100


TRUE_H = PowerLaw(h2=2e-21, h0=2e-23, hm1=5e-25, hm2=2e-28)
TRUE_DRIFT = 3e-16


@pytest.mark.parametrize("seed", range(1, 9))
def test_a_simulated_oscillator_of_known_coefficients_and_drift_is_recovered(seed):
    """Hold-out (not a preset; the seed grid 1..8): each coefficient that dominates the ADEV over a stretch
    of tau is recovered within its tolerance (white PM and FM and flicker FM 15 %, random-walk FM 1.6x:
    measured 0.80..1.39 over the grid), the model's ADEV within 25 % of the truth's up to a tenth of the
    record, no spur, the drift within 4 of its own standard errors, and the truth inside every interval."""
    model = OscillatorModel("holdout", 10e6, TRUE_H, TRUE_DRIFT, 0.0, 0.0, 1, 1.0, "test")
    x = simulate_oscillator(model, 2e5, 1.0, seed).x_s[0]
    r = characterize(x, 1.0, "phase", holdover_trials=20, seed=seed)
    for key, tol in (("h2", 0.15), ("h0", 0.15), ("hm1", 0.15)):
        assert getattr(r.h, key) == pytest.approx(getattr(TRUE_H, key), rel=tol), key
    assert 1 / 1.6 < r.h.hm2 / TRUE_H.hm2 < 1.6
    tau = r.adev.tau_s
    near = tau <= 2e4
    assert np.all(np.abs(r.model_adev[near] / adev_theory(TRUE_H, tau[near], 1.0) - 1) < 0.25)
    assert r.spurs == ()
    assert abs(r.drift_per_s - TRUE_DRIFT) < 4 * r.drift_sigma_per_s
    truth = adev_theory(TRUE_H, tau, 1.0)
    assert r.fits and np.all((truth >= r.adev.lo) & (truth <= r.adev.hi))


def test_the_drift_standard_error_is_honest_over_the_seed_grid():
    """The bootstrap's drift standard error against the drift's actual scatter: the rms of the z-scores
    over 8 seeds lies within what 8 draws of a unit normal give (0.4..1.7)."""
    model = OscillatorModel("holdout", 10e6, TRUE_H, TRUE_DRIFT, 0.0, 0.0, 1, 1.0, "test")
    z = []
    for seed in range(11, 19):
        x = simulate_oscillator(model, 2e5, 1.0, seed).x_s[0]
        r = characterize(x, 1.0, "phase", holdover_trials=20, seed=seed)
        z.append((r.drift_per_s - TRUE_DRIFT) / r.drift_sigma_per_s)
    assert 0.4 < math.sqrt(np.mean(np.square(z))) < 1.7


def test_the_temperature_coefficient_is_recovered():
    """A diurnal temperature swing of 2 K through a tempco of 3e-11/K on the same oscillator: the fit
    recovers the tempco within 3 of its standard errors and 10 %."""
    tempco = 3e-11
    model = OscillatorModel("holdout", 10e6, TRUE_H, TRUE_DRIFT, tempco, 0.0, 1, 1.0, "test")
    n = 200_000
    temp = 300.0 + 2.0 * np.sin(2 * np.pi * np.arange(n) / 86400.0)
    x = simulate_oscillator(model, float(n), 1.0, 4, temperature_K=temp).x_s[0]
    r = characterize(x, 1.0, "phase", temperature_K=temp, holdover_trials=20)
    assert abs(r.temp_coeff_per_K - tempco) < 3 * r.temp_coeff_sigma_per_K
    assert r.temp_coeff_per_K == pytest.approx(tempco, rel=0.1)
    assert r.drift_per_s == pytest.approx(TRUE_DRIFT, abs=4 * r.drift_sigma_per_s)


def test_the_holdover_prediction_matches_the_analytic_error_of_its_predictor():
    """White and random-walk FM, a 4 h record, the drift known: the frequency averaged over the last hour
    predicts the next hour with the error variance ``2 h^2 AVAR(h)`` exactly (the Allan variance is half the
    mean square of that very difference); the bootstrap's 95 % interval holds it."""
    h = PowerLaw(h0=2e-24, hm2=2e-29)
    known, _, _ = predict_holdover(h, 0.0, 4 * 3600.0, 1.0, horizons_s=(3600.0,), trials=400, seed=2, known_drift=True)
    lo, hi = known[0]["rms_ci_s"]
    assert lo <= known[0]["analytic_s"] <= hi
    assert known[0]["analytic_s"] == pytest.approx(math.sqrt(2) * 3600 * adev_theory(h, np.array([3600.0]), 1.0)[0])
    estimated, drift_sigma, _ = predict_holdover(h, 0.0, 4 * 3600.0, 1.0, horizons_s=(3600.0,), trials=400, seed=2)
    assert drift_sigma > 0
    assert estimated[0]["analytic_s"] > known[0]["analytic_s"]


def test_the_oscillator_document_round_trips_and_keeps_what_a_record_cannot_tell(ocxo):
    doc = oscillator_document(ocxo, preset("rb"), "mine", "ocxo_frequency.txt")
    model = oscillator_from_document(doc)
    assert model.h == ocxo.h and model.drift_per_s == ocxo.drift_per_s
    assert (model.efc_gain_per_V, model.dac_bits, model.dac_range_V) == (preset("rb").efc_gain_per_V, 16, 5.0)
    with pytest.raises(InputError, match="unknown keys"):
        oscillator_from_document({**doc, "h3": 1.0}, "x.json")
    with pytest.raises(InputError, match="x.json"):
        oscillator_from_document({**doc, "dac_bits": 99}, "x.json")


def test_a_record_too_short_to_fit_is_refused():
    x = simulate_oscillator(preset("ocxo"), 500.0, 1.0, 1).x_s[0]
    with pytest.raises(InputError, match="too short to fit.*500 samples"):
        characterize(x, 1.0, "phase", source="short.txt")


def test_a_frequency_record_given_as_phase_is_refused():
    """The OCXO's frequency readings (Hz) and the same as fractional frequency, both read as phase: bluer
    than white PM (alpha 3.2 at tau0), which no clock's phase is. The Cs phase record passes the same check."""
    from chronofuse.io.records import read_record

    y = read_record(OCXO, kind="freq", rate_hz=1.0, nominal_hz=1e7).values
    with pytest.raises(InputError, match="frequency record given as phase"):
        characterize(y, 1.0, "phase", source="ocxo.txt")
    with pytest.raises(InputError, match="frequency record given as phase"):
        characterize(y * 1e7 + 1e7, 1.0, "phase", source="ocxo.txt")


@pytest.mark.parametrize("rate_hz", [1.0, 10.0])
def test_the_pi_advice_is_a_stable_loop_even_where_the_crossover_is_a_few_samples(rate_hz):
    # A TCXO against a 0.1 ns receiver crosses over within a sample or two: the advice was capped at a quarter
    # of the rate, 0.25 Hz at 1 Hz, a loop whose poles lie outside the unit circle (kp 3.1).
    from chronofuse.discipline.characterize import recommend_loop
    from chronofuse.models.oscillator_presets import preset

    advice = recommend_loop(preset("tcxo").h, 1e-10, rate_hz)
    kp, ki = advice.pi_kp, advice.pi_ki
    assert max(abs(np.roots([1.0, -(2 - kp - ki), 1 - kp]))) < 1.0
