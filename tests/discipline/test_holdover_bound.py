"""Holdover after a day locked, against the causal optimal predictor and the analytic floor."""

import math

import numpy as np
import pytest

from chronofuse.analysis.montecarlo import ratio_ci
from chronofuse.discipline.bound import clairvoyant_servo
from chronofuse.discipline.dac import Dac
from chronofuse.discipline.holdover import holdover_error
from chronofuse.discipline.loop import close_loop
from chronofuse.experiments.gnssdo import _free_phase, scenario_environment
from chronofuse.experiments.gnssdo_holdover import holdover_floor_s, holdover_study
from chronofuse.models.oscillator_presets import preset
from chronofuse.models.receiver import simulate_receivers
from chronofuse.seeding import child_seed, root_seed


def test_the_analytic_floor_of_the_ocxo_preset_at_a_day_is_about_4_us():
    h = preset("ocxo").h
    floor = holdover_floor_s(h.h0, h.hm2, 86_400.0)
    q = 2 * math.pi**2 * h.hm2
    assert math.isclose(floor, math.sqrt(q * 86_400.0**3 / 3 + h.h0 * 86_400.0 / 2), rel_tol=1e-12)
    assert 3.9e-6 < floor < 4.1e-6


@pytest.mark.slow
def test_after_a_day_locked_the_causal_optimal_predictor_is_not_beaten_and_its_covariance_is_its_error():
    # The yardstick knows the oscillator's aging (the true model); with the servos' zero-mean drift prior it
    # was beaten after a day locked, 0.962 [0.937, 0.988] over 200 trials, and by 38 % after 2 h.
    for design in ("datasheet", "fit"):
        s = holdover_study(locked_s=86_400, horizons_s=(86_400.0,), trials=16, chunk=16, seed=40, design=design)
        row = s["rows"][0]
        assert row["ratio_ci"][1] >= 1.0, design  # not beaten: its interval reaches 1 or lies above
    # the clairvoyant predictor is never below the floor outside its interval, and its own covariance agrees
    assert row["clairvoyant_ci_ns"][1] >= row["floor_ns"]
    assert row["clairvoyant_ci_ns"][0] <= row["clairvoyant_predicted_ns"] <= row["clairvoyant_ci_ns"][1]
    assert row["clairvoyant_predicted_ns"] >= row["floor_ns"]


def _grid():
    """Every servo of the registry as a designer sets it up, and the Kalman servo over a grid of its steering
    time and drift prior (the settings that decide a prediction)."""
    from chronofuse.discipline.registry import SERVOS
    from chronofuse.experiments.gnssdo import make_controller

    osc = preset("ocxo")
    env = scenario_environment("open-sky", 7200.0)
    dac = Dac.for_oscillator(osc)
    for name in SERVOS.names():
        yield name, make_controller(name, osc, env, 2, dac)
    for steer in (10.0, 300.0, 3000.0):
        for sigma_d in (1e-16, 1e-14):
            servo = make_controller("kalman", osc, env, 2, dac, steer_s=steer)
            servo.sigma_drift0_per_s = sigma_d
            yield f"kalman steer {steer:g} s, drift prior {sigma_d:g}", servo


def test_no_servo_of_the_registry_at_any_setting_of_a_grid_beats_the_predictor_after_2_h_locked():
    # 2 h locked, then 4 h of holdover, 16 trials: each servo's error against the clairvoyant's on the same
    # oscillators and receivers, paired; "beats" is a ratio whose 95 % interval lies wholly below 1
    locked, horizon, trials = 7200, 14_400.0, 16
    osc = preset("ocxo")
    env = scenario_environment("open-sky", float(locked))
    dac = Dac.for_oscillator(osc)
    root = root_seed(42)
    free, _ = _free_phase(osc, locked + int(horizon) + 1, trials, root)
    rx = simulate_receivers(env, locked, 2, child_seed(root, 1), trials=trials)
    ref = np.full(free.shape, np.nan)
    ref[:, :locked] = np.nanmean(rx.pps_error_s + rx.epochs.qerr_s, axis=1)
    best = holdover_error(close_loop(clairvoyant_servo(osc, env, 2, dac), free, ref).phase_s, locked, (horizon,))
    ratios = {}
    for name, servo in _grid():
        ours = holdover_error(close_loop(servo, free, ref).phase_s, locked, (horizon,))
        ratios[name] = ratio_ci(ours[:, 0] ** 2, best[:, 0] ** 2)
    assert all(r[2] >= 1.0 for r in ratios.values()), ratios
    # and the grid is not all far away: its best setting comes within 1.6x, so the test could fail
    assert min(r[0] for r in ratios.values()) < 1.6, ratios


@pytest.mark.slow
def test_the_gnssdo_papers_pi_preset_is_not_within_110_percent_of_the_predictor_in_holdover():
    s = holdover_study(locked_s=6 * 3600, horizons_s=(86_400.0,), trials=8, chunk=8, seed=41, controller="pi",
                       design="datasheet")
    assert s["rows"][0]["ratio_ci"][0] > 1.10
