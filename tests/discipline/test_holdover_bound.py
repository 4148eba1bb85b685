"""Holdover after a day locked, against the causal optimal predictor and the analytic floor."""

import math

import pytest

from chronofuse.experiments.gnssdo_holdover import holdover_floor_s, holdover_study
from chronofuse.models.oscillator_presets import preset


def test_the_analytic_floor_of_the_ocxo_preset_at_a_day_is_about_4_us():
    h = preset("ocxo").h
    floor = holdover_floor_s(h.h0, h.hm2, 86_400.0)
    q = 2 * math.pi**2 * h.hm2
    assert math.isclose(floor, math.sqrt(q * 86_400.0**3 / 3 + h.h0 * 86_400.0 / 2), rel_tol=1e-12)
    assert 3.9e-6 < floor < 4.1e-6


@pytest.mark.slow
def test_after_a_day_locked_the_datasheet_designed_24_h_holdover_is_within_110_percent_of_the_causal_optimal_predictor():
    # the data-sheet design: 16 trials are not enough for the fitted one, whose ratio spreads with its one
    # calibration record (1.25x on this seed; 0.962 [0.937, 0.988] over 200 trials, docs/gnssdo/holdover.md)
    s = holdover_study(locked_s=86_400, horizons_s=(86_400.0,), trials=16, chunk=16, seed=40, design="datasheet")
    row = s["rows"][0]
    assert row["ratio_ci"][1] <= 1.10
    # the clairvoyant predictor is never below the floor outside its interval, and its own covariance agrees
    assert row["clairvoyant_ci_ns"][1] >= row["floor_ns"]
    assert row["clairvoyant_ci_ns"][0] <= row["clairvoyant_predicted_ns"] <= row["clairvoyant_ci_ns"][1]


@pytest.mark.slow
def test_the_gnssdo_papers_pi_preset_is_not_within_110_percent_of_the_predictor_in_holdover():
    s = holdover_study(locked_s=6 * 3600, horizons_s=(86_400.0,), trials=8, chunk=8, seed=41, controller="pi",
                       design="datasheet")
    assert s["rows"][0]["ratio_ci"][0] > 1.10
