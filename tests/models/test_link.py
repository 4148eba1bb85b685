"""Link truth: exact light-time against closed forms and the source paper's first-order model; noise tables."""

import math

import numpy as np
import pytest

from chronofuse.constants import SPEED_OF_LIGHT_M_PER_S as C
from chronofuse.models.kinematics import constant_velocity, radial_geometry
from chronofuse.models.link import (
    LinkModel,
    doppler_sigma_hz,
    light_time_s,
    node_clock_error_s,
    paper_first_order_timestamps,
    simulate_exchanges,
    toa_sigma_s,
)

NOISELESS = LinkModel(toa_model="none", urt_fixed_s=0.0, urt_jitter_s=0.0)


def _noiseless(distance_m, v_m_s, steps=50, offset_s=0.0):
    a, b = radial_geometry(distance_m, v_m_s)
    x_a = np.zeros((1, steps + 2))
    x_b = np.full((1, steps + 2), offset_s)
    return simulate_exchanges(a, b, x_a, x_b, NOISELESS, steps, 0)


def test_light_time_to_a_receding_receiver_is_the_closed_form_s_over_c_minus_v():
    a, b = radial_geometry(80e3, 2000.0)
    t = np.array([[0.0, 3.0]])
    tau = light_time_s(a, b, t)
    s = 80e3 + 2000.0 * t
    np.testing.assert_allclose(tau, s / (C - 2000.0), rtol=1e-15)
    # Emitter moving, receiver at rest: the distance at emission over c.
    np.testing.assert_allclose(light_time_s(b, a, t), s / C, rtol=1e-15)


def test_co_moving_nodes_have_the_frame_term_two_d_v_over_c_squared_between_the_legs():
    d, v = 100e3, 2000.0
    a = constant_velocity([0.0, 0.0, 0.0], [v, 0.0, 0.0])
    b = constant_velocity([d, 0.0, 0.0], [v, 0.0, 0.0])
    t = np.zeros((1, 1))
    up, down = light_time_s(a, b, t), light_time_s(b, a, t)
    assert up[0, 0] - down[0, 0] == pytest.approx(2.0 * d * v / (C * C - v * v), rel=1e-9)
    assert d * v / C**2 == pytest.approx(2.2e-9, rel=0.02)  # the "about 2 ns" of the issue


def test_exact_timestamps_equal_the_paper_s_first_order_model_at_low_speed():
    ex = _noiseless(80e3, 1.0, offset_s=1e-6)
    t_i, t_r = paper_first_order_timestamps(ex.range_m, 1.0, ex.offset_s, NOISELESS.reply_delay_s)
    assert np.max(np.abs(ex.t_i_s - t_i)) < 1e-12
    assert np.max(np.abs(ex.t_r_s - t_r)) < 1e-15


def test_at_2000_m_s_the_paper_s_model_misses_the_uplink_term_s_v_over_c_squared():
    v = 2000.0
    for distance in (80e3, 100e3):
        ex = _noiseless(distance, v)
        t_i, t_r = paper_first_order_timestamps(ex.range_m, v, ex.offset_s, NOISELESS.reply_delay_s)
        expected = ex.range_m * v / (C * (C - v))
        np.testing.assert_allclose(ex.t_i_s - t_i, expected, rtol=1e-9)
        np.testing.assert_allclose(ex.t_r_s, t_r, atol=1e-15)
    # At 80 km the difference is 1.78 ns in T_i, hence 0.89 ns in the offset of the source paper's eq. (1)/(9).
    ex = _noiseless(80e3, v)
    assert (ex.t_i_s[0, 0] - paper_first_order_timestamps(80e3, v, 0.0, 4e-3)[0]) == pytest.approx(1.7803e-9, rel=1e-4)


def test_the_offset_recovered_by_the_paper_s_eq_1_from_static_noiseless_exchanges_is_the_true_offset():
    ex = _noiseless(80e3, 0.0, offset_s=3e-6)
    eps = (ex.t_i_s - ex.t_r_s + ex.t_b_s) / 2.0
    np.testing.assert_allclose(eps, ex.offset_s, atol=1e-16)


def test_toa_noise_follows_the_paper_s_table_and_the_cramer_rao_form():
    assert toa_sigma_s(4.0) == pytest.approx(2.5e-9) and toa_sigma_s(20.0) == pytest.approx(0.45e-9)
    assert toa_sigma_s(11.0) == pytest.approx((1.25e-9 + 1.0e-9) / 2)
    assert toa_sigma_s(10.0, "crb") == pytest.approx(1.25e-9, rel=1e-3)
    assert toa_sigma_s(20.0, "crb") / toa_sigma_s(10.0, "crb") == pytest.approx(10 ** -0.5)
    assert toa_sigma_s(30.0, "crb") > 0.0
    with pytest.raises(ValueError, match="snr_db == 30"):
        toa_sigma_s(30.0)
    with pytest.raises(ValueError, match="snr_db == 2"):
        LinkModel(snr_db=2.0)
    assert doppler_sigma_hz(4.0) == 190.0


def test_simulated_noise_has_the_table_sigmas():
    link = LinkModel(snr_db=6.0)
    a, b = radial_geometry(10e3, 0.0)
    steps, trials = 4000, 2
    x = np.zeros((trials, steps + 2))
    ex = simulate_exchanges(a, b, x, x, link, steps, 7)
    n = ex.t_i_s.size
    # Seed eq. (1) error: (delta_i - delta_r)/2 - t_p/2: variance (2 sigma^2 + jitter^2)/4.
    err = (ex.t_i_s - ex.t_r_s + ex.t_b_s) / 2.0 - ex.offset_s
    var_expected = (2.0 * 2.0e-9**2 + 2e-9**2) / 4.0
    # chi-square with n dof: 5-sigma band of the sample variance.
    assert abs(err.var() / var_expected - 1.0) < 5.0 * math.sqrt(2.0 / n)
    assert err.mean() == pytest.approx(-link.urt_fixed_s / 2.0, abs=5.0 * math.sqrt(var_expected / n))
    v_err = ex.velocity_m_s - ex.radial_velocity_m_s
    sigma_v = C * 152.0 / (math.sqrt(2.0) * 1e9)
    assert abs(v_err.var() / sigma_v**2 - 1.0) < 5.0 * math.sqrt(2.0 / n)


def test_a_trial_does_not_depend_on_how_many_trials_run():
    a, b = radial_geometry(50e3, 500.0)
    one = simulate_exchanges(a, b, np.zeros((1, 22)), np.zeros((1, 22)), LinkModel(), 20, 5)
    three = simulate_exchanges(a, b, np.zeros((3, 22)), np.zeros((3, 22)), LinkModel(), 20, 5)
    np.testing.assert_array_equal(one.t_i_s[0], three.t_i_s[0])
    np.testing.assert_array_equal(one.velocity_m_s[0], three.velocity_m_s[0])


def test_a_reply_slot_before_the_request_arrives_is_refused():
    a, b = radial_geometry(1500e3, 0.0)  # 5 ms of propagation
    with pytest.raises(ValueError, match="reply_delay_s == 0.004"):
        simulate_exchanges(a, b, np.zeros((1, 12)), np.zeros((1, 12)), LinkModel(), 10, 0)


def test_node_clock_carries_the_offset_and_frequency_offset():
    x = node_clock_error_s(None, 100, 0.01, 0, 2, offset_s=1e-6, frequency_offset=1e-9)
    assert x.shape == (2, 102)
    np.testing.assert_allclose(x[:, -1], 1e-6 + 1e-9 * 1.01)
    ex = simulate_exchanges(*radial_geometry(1e3, 0.0), np.zeros((2, 102)), x, NOISELESS, 100, 0)
    np.testing.assert_allclose(ex.skew, 1e-9, rtol=1e-6)


def test_snr_falls_with_range_by_free_space_spreading_and_the_toa_noise_follows_the_table():
    link = LinkModel(snr_db=14.0, snr_reference_range_m=50e3)
    np.testing.assert_allclose(link.snr_at(np.array([50e3, 100e3, 25e3])), [14.0, 14.0 - 6.0206, 14.0 + 6.0206],
                               atol=1e-3)
    a, b = radial_geometry(50e3, 1000.0)
    x = np.zeros((1, 3002))
    ex = simulate_exchanges(a, b, x, x, link, 3000, 3)
    np.testing.assert_allclose(ex.snr_db, 14.0 - 20 * np.log10(ex.range_m / 50e3), atol=1e-9)
    assert ex.snr_db[0, 0] == pytest.approx(14.0) and ex.snr_db[0, -1] == pytest.approx(9.92, abs=0.01)
    assert link.toa_sigma_at(2.0) == pytest.approx(2.5e-9)  # the table holds its end value below 4 dB


def test_nlos_arrivals_are_late_by_exponential_excesses_at_the_stated_rate():
    link = LinkModel(nlos_probability=0.1, nlos_mean_excess_s=30e-9)
    a, b = radial_geometry(10e3, 0.0)
    x = np.zeros((4, 5002))
    ex = simulate_exchanges(a, b, x, x, link, 5000, 4)
    late = ex.nlos_up_s > 0
    assert late.mean() == pytest.approx(0.1, abs=5 * np.sqrt(0.09 / late.size))
    assert ex.nlos_up_s[late].mean() == pytest.approx(30e-9, rel=0.05)
    assert np.all(ex.nlos_up_s >= 0) and np.all(ex.nlos_down_s >= 0)


def test_burst_losses_have_the_stated_fraction_and_mean_burst_length():
    link = LinkModel(loss_fraction=0.2, loss_burst_mean=8.0)
    a, b = radial_geometry(10e3, 0.0)
    x = np.zeros((20, 5002))
    ex = simulate_exchanges(a, b, x, x, link, 5000, 5)
    assert ex.lost.mean() == pytest.approx(0.2, abs=0.02)
    runs = [len(r) for row in ex.lost for r in "".join("1" if v else "0" for v in row).split("0") if r]
    assert np.mean(runs) == pytest.approx(8.0, rel=0.1)
    assert np.all(np.isnan(ex.t_i_s[ex.lost])) and np.all(np.isnan(ex.velocity_m_s[ex.lost]))


def test_reply_slot_jitter_is_reported_in_t_b_and_the_offset_still_follows_from_it():
    link = LinkModel(toa_model="none", urt_fixed_s=0.0, urt_jitter_s=0.0, reply_jitter_s=50e-6)
    a, b = radial_geometry(30e3, 0.0)
    x = np.full((1, 2002), 2e-6)
    ex = simulate_exchanges(a, b, np.zeros((1, 2002)), x, link, 2000, 6)
    assert np.std(ex.t_b_s) == pytest.approx(50e-6, rel=0.1)
    np.testing.assert_allclose((ex.t_i_s - ex.t_r_s + ex.t_b_s) / 2.0, 2e-6, atol=1e-15)
