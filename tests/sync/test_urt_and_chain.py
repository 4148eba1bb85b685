"""URT: the paper mode's failure with a true offset, the calibrated fix; the chains against the bound."""

import numpy as np
import pytest
from _links import exchanges

from chronofuse.experiments.swarm import LinkScenario, calibrated_urt_s, run_link, simulate_scenario
from chronofuse.models.link import LinkModel
from chronofuse.sync.base import measurement_array
from chronofuse.sync.registry import make_algorithm
from chronofuse.sync.twoway import rvc_offset_exact_s
from chronofuse.sync.urt import calibrate_urt


def test_calibration_recovers_the_fixed_urt_within_its_standard_error():
    link = LinkModel(urt_fixed_s=35e-9)
    ex = exchanges(velocity_m_s=500.0, link=link, steps=2000, trials=3, offset_s=1e-6, seed=4)
    eps = rvc_offset_exact_s(ex.t_i_s, ex.t_b_s, ex.t_r_s, ex.velocity_m_s)
    tp = calibrate_urt(eps, ex.offset_s, ex.velocity_m_s)
    # (eps - eps_true)/alpha has sigma ~ 2 * sqrt((2 sigma^2 + j^2)/4 + velocity share) per exchange.
    se = 2.0 * np.sqrt((2 * link.toa_sigma_s**2 + link.urt_jitter_s**2) / 4) / np.sqrt(2000)
    assert np.all(np.abs(tp - 35e-9) < 5 * se)


@pytest.mark.slow
def test_paper_urt_mode_removes_a_true_offset_and_the_calibrated_mode_does_not():
    nominal = LinkScenario(velocity_m_s=800.0, exchanges=1500)
    shifted = LinkScenario(velocity_m_s=800.0, exchanges=1500, true_offset_s=1e-6, true_skew=1e-9)
    r0 = run_link(nominal, ["proposed-no-nn"], trials=4, seed=2, urt_mode="calibrated")
    r1 = run_link(shifted, ["proposed-no-nn"], trials=4, seed=2, urt_mode="calibrated")
    paper = run_link(shifted, ["proposed-no-nn"], trials=4, seed=2, urt_mode="paper")
    # Paper mode subtracts the batch mean, the 1 us offset with it.
    assert paper["rmse_s"]["proposed-no-nn"] > 0.9e-6
    assert r1["rmse_s"]["proposed-no-nn"] <= 2.0 * r0["rmse_s"]["proposed-no-nn"]


@pytest.mark.slow
def test_the_doppler_observing_filter_is_within_1_5x_of_the_pcrb_at_2000_m_s():
    res = run_link(LinkScenario(velocity_m_s=2000.0), ["ours-doppler", "rtt-rvc", "proposed-no-nn"], trials=8, seed=5)
    best = res["rmse_s"]["ours-doppler"]
    assert best <= 1.5 * res["pcrb_s"]["rms"]
    assert best < res["rmse_s"]["proposed-no-nn"] < res["rmse_s"]["rtt-rvc"]


def test_the_seed_chain_in_paper_mode_reaches_sub_ns_at_the_seed_conditions_with_zero_offset():
    sc = LinkScenario(velocity_m_s=2000.0, exchanges=1000)
    ex = simulate_scenario(sc, 3, 7)
    alg = make_algorithm("proposed-no-nn", sc.link, steps=1000, urt_mode="paper").fit()
    err = alg.run(measurement_array(ex)).offset_s - ex.offset_s
    assert np.sqrt(np.mean(err**2)) < 0.5e-9


def test_calibrated_urt_estimate_is_close_to_the_configured_fixed_part():
    tp = calibrated_urt_s(LinkScenario(exchanges=100), seed=1, trials=2, exchanges=3000)
    # GNSS 5 ns per node over 6000 exchanges: sigma of the mean ~ 2 * 7.1 ns / sqrt(6000) = 0.18 ns.
    assert tp == pytest.approx(20e-9, abs=1e-9)


@pytest.mark.slow
def test_the_acceleration_state_removes_the_lag_of_the_velocity_random_walk_under_an_8_g_manoeuvre():
    sc = LinkScenario(velocity_m_s=300.0, acceleration_m_s2=80.0, exchanges=1500)
    res = run_link(sc, ["ours-doppler", "ours-accel"], trials=4, seed=3)
    assert res["rmse_s"]["ours-accel"] < 0.5 * res["rmse_s"]["ours-doppler"]
    assert res["rmse_s"]["ours-accel"] < 1.5 * res["pcrb_s"]["rms"]
