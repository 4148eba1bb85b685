"""The Bayesian bound: its two recursions against each other and the Kalman core, its static limit against
the two-way CRB of Skog and Händel, and what flicker FM and the calibration add to it."""

import numpy as np
import pytest

from chronofuse.estimation.kalman import predict, update
from chronofuse.models.clock_markov import ClockMarkovModel
from chronofuse.models.link import LinkModel
from chronofuse.models.oscillator_presets import preset
from chronofuse.sync.pcrb import bayesian_bound, exchange_bound, link_pcrb, link_rows, tichavsky_pcrb
from chronofuse.sync.prior import LinkPrior


def _model(steps=300, flicker=True):
    clock = ClockMarkovModel.for_link(preset("ocxo"), preset("ocxo"), 0.01, steps * 0.01, flicker=flicker)
    Phi, Q = clock.discrete(0.01)
    t_i = np.full((1, steps), 2.7e-4)
    H = link_rows(clock, t_i, np.full((1, steps), 4e-3), 0.0, np.zeros((1, steps)), with_urt=False)
    n = clock.n_states
    P0 = np.diag([1e-12, 1e-14] + list(clock.flicker_variances()))
    return Phi, Q, H, np.full((1, steps), 1.8e-18), P0, n


def test_the_covariance_recursion_equals_tichavsky_s_information_recursion_and_the_kalman_core():
    # Tichavský's information form needs Q well conditioned: the two-state clock (the flicker states' Q is
    # near singular at 10 ms and costs the information form 1e-3 of relative accuracy).
    Phi, Q, H, R, P0, n = _model(flicker=False)
    cov = bayesian_bound(Phi, Q, H, R, P0)[0]
    info = tichavsky_pcrb(Phi, Q, H[0][:, None, :], np.array([[R[0, 0]]]), P0)
    np.testing.assert_allclose(cov[:, 0, 0], info[:, 0, 0], rtol=1e-4)  # inverting J loses a few digits
    assert cov[-1, 0, 0] == pytest.approx(info[-1, 0, 0], rel=1e-6)
    # A third computation, with flicker FM: the estimation layer's Kalman core (Joseph form) on the same model.
    Phi, Q, H, R, P0, n = _model()
    cov = bayesian_bound(Phi, Q, H, R, P0)[0]
    x, P = np.zeros((1, n)), P0[None]
    for k in range(H.shape[1]):
        if k:
            pr = predict(x, P, Phi, Q)
            x, P = pr.x, pr.P
        post = update(x, P, np.zeros((1, 1)), H[0, k][None, None, :], np.array([[R[0, k]]]))
        x, P = post.x, post.P
    assert cov[-1, 0, 0] == pytest.approx(P[0, 0, 0], rel=1e-8)


def _skog_handel_crb(sigma_s, steps, dt, reply_s):
    """Static two-way CRB: forward t2-t1 = eps0 + y t_k + d + n, backward t4-t3 = -(eps0 + y (t_k + T_B)) + d + n,
    unknown [eps0, y, d], white Gaussian n of sigma each (Skog and Händel 2010, sec. III); returns the bound on
    eps at the last exchange's transmission."""
    t = np.arange(steps) * dt
    rows = np.concatenate([np.stack([np.ones(steps), t, np.ones(steps)], 1),
                           np.stack([-np.ones(steps), -(t + reply_s), np.ones(steps)], 1)])
    fim = rows.T @ rows / sigma_s**2
    g = np.array([1.0, t[-1], 0.0])
    return g @ np.linalg.solve(fim, g)


@pytest.mark.parametrize("steps", [50, 400])
def test_at_zero_range_with_quiet_clocks_the_bound_is_the_static_two_way_crb(steps):
    link = LinkModel(snr_db=8.0, urt_jitter_s=0.0)
    quiet = ClockMarkovModel(h0_s=1e-44, hm1=0.0, hm2_per_s=1e-50)
    prior = LinkPrior(offset_sigma_s=1e-3, skew_sigma=1e-4)
    zeros = np.zeros((1, steps))
    res = exchange_bound(link, quiet, prior, t_i_s=zeros, t_b_s=zeros + link.reply_delay_s, offset_s=0.0,
                         velocity_m_s=zeros, snr_db=zeros + 8.0)
    crb = _skog_handel_crb(link.toa_sigma_s, steps, link.interval_s, link.reply_delay_s)
    assert res.offset_var_s2[0, -1] == pytest.approx(crb, rel=1e-4)
    # Its known asymptote: about 4 sigma^2 / (2 N) for a line's end point from N points of variance sigma^2/2.
    assert res.offset_var_s2[0, -1] == pytest.approx(4 * link.toa_sigma_s**2 / 2 / steps, rel=0.05)


def test_flicker_fm_raises_the_bound_of_a_long_run():
    link = LinkModel(interval_s=0.1, reply_delay_s=4e-3)
    osc = preset("ocxo")
    with_flicker = link_pcrb(link, osc, 2000, 80e3, 800.0)
    without = link_pcrb(link, osc, 2000, 80e3, 800.0, flicker=False)
    assert with_flicker.mean_rms_s > 1.1 * without.mean_rms_s


def test_a_calibration_s_uncertainty_adds_its_quarter_variance_to_the_bound():
    link, osc = LinkModel(), preset("ocxo")
    plain = link_pcrb(link, osc, 500, 80e3, 800.0)
    calibrated = link_pcrb(link, osc, 500, 80e3, 800.0, calibration_sigma_s=0.6e-9)
    # The URT's error b enters z1 as -b/2 and no exchange can see it apart from the offset.
    np.testing.assert_allclose(calibrated.offset_var_s2, plain.offset_var_s2 + (0.3e-9) ** 2, rtol=2e-3)
    assert not calibrated.offset_var_s2.flags.writeable


def test_a_lost_exchange_adds_no_information():
    link, osc = LinkModel(), preset("ocxo")
    clock = ClockMarkovModel.for_link(osc, osc, link.interval_s, 2.0)
    t_i = np.full((1, 200), 2.7e-4)
    lost = t_i.copy()
    lost[0, 100:150] = np.nan
    args = dict(t_b_s=np.full((1, 200), 4e-3), offset_s=0.0, velocity_m_s=np.zeros((1, 200)), snr_db=np.full((1, 200), 10.0))
    full = exchange_bound(link, clock, LinkPrior(), t_i_s=t_i, **args)
    gap = exchange_bound(link, clock, LinkPrior(), t_i_s=lost, **args)
    np.testing.assert_allclose(gap.offset_var_s2[0, :100], full.offset_var_s2[0, :100])
    assert np.all(np.diff(gap.offset_var_s2[0, 100:150]) > 0)  # the prediction only grows through the gap
