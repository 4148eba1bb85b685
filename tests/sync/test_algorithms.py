"""Sync algorithms: one interface (streaming == batch), and each checked against an independent result."""

import numpy as np
import pytest
from _links import NOISELESS, exchanges

from chronofuse.constants import SPEED_OF_LIGHT_M_PER_S as C
from chronofuse.estimation.interface import compare_streaming_to_batch
from chronofuse.models.link import LinkModel
from chronofuse.sync.base import NullSync, measurement_array
from chronofuse.sync.mls import PtpMls, weighted_line_at_zero
from chronofuse.sync.ptp import PtpOffset, PtpPiServo, pi_gains
from chronofuse.sync.registry import ALGORITHM_NAMES, NEEDS_NETWORK, LinkKnowledge, make_algorithm
from chronofuse.sync.regression import ChronyRegression, PtpLinreg, runs_test_passes
from chronofuse.sync.rvc import RttRvc
from chronofuse.sync.twoway import ptp_offset_s, rvc_offset_exact_s, rvc_offset_paper_s


@pytest.mark.parametrize("name", [n for n in ALGORITHM_NAMES if n not in NEEDS_NETWORK])
def test_every_algorithm_streams_exactly_what_its_batch_run_gives(name):
    ex = exchanges(velocity_m_s=800.0, link=LinkModel(), steps=150, trials=2, offset_s=3e-6)
    alg = make_algorithm(name, LinkKnowledge(steps=150)).fit()
    assert compare_streaming_to_batch(alg, measurement_array(ex)) == []


def test_run_before_fit_is_refused_and_results_are_read_only():
    with pytest.raises(RuntimeError, match="fit"):
        RttRvc().run(np.zeros((1, 3, 6)))
    res = NullSync().fit().run(np.zeros((1, 3, 6)))
    assert not res.offset_s.flags.writeable
    with pytest.raises(ValueError, match="last axis"):
        NullSync().fit().run(np.zeros((1, 3, 4)))


@pytest.mark.parametrize("old, new", [("proposed", "rtt-rvc-kf-bp"), ("proposed-no-nn", "rtt-rvc-kf"),
                                      ("ours-doppler", "doppler-kf"), ("ptp", "ptp-pi"), ("lstm", "rtt-rvc-kf-lstm")])
def test_an_old_algorithm_name_is_refused_with_its_new_name(old, new):
    with pytest.raises(ValueError, match=f"now called '{new}'"):
        make_algorithm(old)
    with pytest.raises(ValueError, match="removed"):
        make_algorithm("ours-accel")


def test_a_configuration_override_is_validated_by_the_algorithm_s_config():
    assert make_algorithm("ptp-mls", window=16).fit().window == 16
    with pytest.raises(ValueError, match="window"):
        make_algorithm("ptp-mls", window=8)


def test_pi_gains_are_linuxptp_hardware_defaults():
    # At a 1 s sync interval linuxptp's hardware PI constants are kp = 0.7, ki = 0.3 (ptp4l(8)).
    assert pi_gains(1.0) == pytest.approx((0.7, 0.3))
    kp, ki = pi_gains(0.01)
    assert kp == pytest.approx(0.7 * 0.01**-0.3) and ki == pytest.approx(0.3 * 0.01**0.4)
    # The norm_max caps bind at long intervals: kp <= 0.7/T, ki <= 0.3/T.
    assert pi_gains(1e-6, kp_scale=1e9, ki_scale=1e9) == pytest.approx((0.7e6, 0.3e6))


def test_pi_servo_steps_a_first_offset_beyond_20_us_and_then_tracks_a_skew():
    ex = exchanges(distance_m=1e3, steps=3000, trials=1, offset_s=50e-6, skew=2e-8)
    est = PtpPiServo().fit().run(measurement_array(ex)).offset_s[0]
    err = est - ex.offset_s[0]
    first_update = int(np.argmax(np.abs(np.diff(est)) > 1e-6)) + 1
    assert abs(err[first_update]) < 1e-7  # the jump lands on the measured offset
    assert np.max(np.abs(err[-500:])) < 1e-10  # a PI loop tracks a constant skew with no steady error


def test_pi_servo_below_the_step_threshold_slews_instead_of_stepping():
    ex = exchanges(distance_m=1e3, steps=600, trials=1, offset_s=5e-6)
    est = PtpPiServo().fit().run(measurement_array(ex)).offset_s[0]
    assert np.max(np.abs(np.diff(est))) < 5e-6 * 0.2
    assert abs(est[-1] - 5e-6) < 1e-7


def test_pi_servo_anti_windup_freezes_the_integral_while_clamped():
    alg = PtpPiServo(max_frequency=1e-7).fit()
    ex = exchanges(distance_m=1e3, steps=400, trials=1, offset_s=15e-6)
    alg.reset()
    drifts = []
    for z in measurement_array(ex)[0]:
        alg.step(z)
        drifts.append(alg._state["drift"][0])
    state = alg._state
    assert state["freq"][0] == pytest.approx(-1e-7) or state["freq"][0] == pytest.approx(1e-7)
    # While the output sits on the clamp the integral term does not move.
    locked = np.flatnonzero(np.abs(np.diff(drifts)) > 0)
    assert locked.size <= 2


def test_moving_median_delay_lags_by_four_and_a_half_exchanges_on_a_moving_link():
    v = 2000.0
    ex = exchanges(velocity_m_s=v, steps=60, trials=1)
    z = measurement_array(ex)
    raw = PtpOffset().fit().run(z).offset_s[0]
    med = PtpOffset("median").fit().run(z).offset_s[0]
    # The mean path delay grows by v dt / c per exchange; the median of the last 10 is 4.5 exchanges old.
    lag = 4.5 * v * NOISELESS.interval_s / C
    np.testing.assert_allclose((med - raw)[20:], lag, rtol=2e-3)
    assert lag == pytest.approx(300e-9, rel=0.001)


def test_exact_rvc_recovers_the_offset_of_a_noiseless_moving_link_and_the_paper_s_eq9_misses_s_v_over_2c2():
    v = 2000.0
    ex = exchanges(velocity_m_s=v, trials=1, offset_s=2e-6)
    exact = rvc_offset_exact_s(ex.t_i_s, ex.t_b_s, ex.t_r_s, ex.radial_velocity_m_s)
    np.testing.assert_allclose(exact, ex.offset_s, atol=1e-17)
    eq9 = rvc_offset_paper_s(ex.t_i_s, ex.t_b_s, ex.t_r_s, ex.radial_velocity_m_s)
    np.testing.assert_allclose(eq9 - ex.offset_s, ex.range_m * v / (2 * C * C), rtol=2e-3)
    with_doppler = rvc_offset_exact_s(ex.t_i_s, ex.t_b_s, ex.t_r_s, ex.velocity_m_s)
    np.testing.assert_array_equal(RttRvc("exact").fit().run(measurement_array(ex)).offset_s, with_doppler)
    paper = rvc_offset_paper_s(ex.t_i_s, ex.t_b_s, ex.t_r_s, ex.velocity_m_s)
    np.testing.assert_array_equal(RttRvc("paper").fit().run(measurement_array(ex)).offset_s, paper)


def test_mls_is_a_weighted_least_squares_line_evaluated_now():
    rng = np.random.default_rng(3)
    x = -np.arange(31, -1, -1) * 0.01
    z = 1e-9 * rng.standard_normal(32) + 2e-7 * x + 5e-9
    w = rng.uniform(0.1, 1.0, 32)
    slope, intercept = np.polyfit(x, z, 1, w=np.sqrt(w))
    assert weighted_line_at_zero(x[None], z[None], w[None])[0] == pytest.approx(intercept, rel=1e-9)
    # On a noiseless static link with a skew, the PTP offsets lie on a line: MLS returns them unchanged.
    ex = exchanges(distance_m=1e3, steps=80, trials=1, offset_s=1e-6, skew=1e-7)
    est = PtpMls().fit().run(measurement_array(ex)).offset_s[0]
    np.testing.assert_allclose(est, ptp_offset_s(ex.t_i_s, ex.t_b_s, ex.t_r_s)[0], rtol=0, atol=1e-18)


def test_mls_window_outside_16_to_64_is_refused():
    with pytest.raises(ValueError, match="window == 8"):
        PtpMls(window=8).fit()


def test_linreg_servo_locks_onto_a_skewed_noiseless_link_within_its_first_regressions():
    ex = exchanges(distance_m=1e3, steps=300, trials=1, offset_s=5e-6, skew=2e-8)
    z = measurement_array(ex)
    est = PtpLinreg().fit().run(z).offset_s[0]
    raw = PtpOffset().fit().run(z).offset_s[0]
    np.testing.assert_allclose(est[30:], raw[30:], rtol=0, atol=1e-13)


def test_linreg_and_chrony_average_white_timestamp_noise_down_like_a_long_line_fit():
    link = LinkModel(urt_fixed_s=0.0)
    ex = exchanges(distance_m=1e3, steps=1500, trials=3, link=link, seed=9)
    z = measurement_array(ex)
    raw = PtpOffset().fit().run(z).offset_s - ex.offset_s
    for alg in (PtpLinreg(), ChronyRegression()):
        err = alg.fit().run(z).offset_s - ex.offset_s
        # A line's end point from n >= 16 points has at most 4/n of one point's variance (< 1/2 of its sigma).
        assert np.sqrt(np.mean(err[:, 200:] ** 2)) < 0.5 * np.sqrt(np.mean(raw[:, 200:] ** 2))


def test_runs_test_accepts_white_residuals_and_rejects_a_slow_wave():
    rng = np.random.default_rng(1)
    white = rng.standard_normal((2000, 48))
    assert 0.95 < runs_test_passes(white).mean() < 0.995
    wave = np.sin(np.linspace(0, 2 * np.pi, 48))[None, :] + 0.1 * rng.standard_normal((200, 48))
    assert runs_test_passes(wave).mean() < 0.05


def test_pi_servo_holds_its_state_through_missing_exchanges_and_keeps_its_clock_running():
    ex = exchanges(distance_m=1e3, steps=800, trials=1, offset_s=3e-6, skew=1e-8)
    z = measurement_array(ex)
    z_gap = z.copy()
    z_gap[:, 500:520, :] = np.nan
    full = PtpPiServo().fit().run(z).offset_s[0]
    gap = PtpPiServo().fit().run(z_gap).offset_s[0]
    np.testing.assert_array_equal(gap[:500], full[:500])
    assert np.all(np.isfinite(gap))
    # Through the gap the clock runs on at its last frequency (a straight line) and keeps up with the skew.
    np.testing.assert_allclose(np.diff(gap[500:521], 2), 0.0, atol=1e-16)
    err = gap - ex.offset_s[0]
    assert np.max(np.abs(err[500:520] - err[499])) < 1e-9
    assert abs(err[-1]) < 2 * abs(full[-1] - ex.offset_s[0, -1]) + 1e-10


def test_linreg_servo_survives_missing_exchanges():
    ex = exchanges(distance_m=1e3, steps=400, trials=1, offset_s=3e-6, skew=1e-8)
    z = measurement_array(ex)
    z[:, 200:230, :] = np.nan
    est = PtpLinreg().fit().run(z).offset_s[0]
    raw = PtpOffset().fit().run(measurement_array(ex)).offset_s[0]
    assert np.all(np.isfinite(est))
    np.testing.assert_allclose(est[300:], raw[300:], rtol=0, atol=1e-12)
