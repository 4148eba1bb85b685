"""The PCRB: Tichavský's recursion against the Kalman covariance, and its static limit against the
two-way CRB of Skog and Händel built from the one-way measurements' Fisher information."""

import dataclasses

import numpy as np
import pytest

from chronofuse.estimation.kalman import predict, update
from chronofuse.models.link import LinkModel
from chronofuse.models.oscillator import PowerLaw
from chronofuse.models.oscillator_presets import preset
from chronofuse.sync.pcrb import link_model_matrices, link_pcrb, tichavsky_pcrb


def test_tichavsky_recursion_equals_the_kalman_posterior_covariance_of_the_same_linear_model():
    link = LinkModel(snr_db=6.0)
    F, Q, H, R = link_model_matrices(link, 4e-24, 8e-27, 300, 80e3, 1500.0, accel_psd=0.5)
    P0 = np.diag([1e-12, 1e-14, 1e4])
    bound = tichavsky_pcrb(F, Q, H, R, P0)
    # Second method: covariance-form Riccati recursion through the estimation layer's Kalman core.
    x = np.zeros((1, 3))
    P = P0[None]
    post = update(x, P, np.zeros((1, 2)), H[0][None], R)
    P = post.P
    assert bound[0] == pytest.approx(P[0], rel=1e-8)
    for k in range(1, 300):
        prior = predict(post.x, P, F, Q)
        post = update(prior.x, prior.P, np.zeros((1, 2)), H[k][None], R)
        P = post.P
    np.testing.assert_allclose(bound[-1], P[0], rtol=1e-6)


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
def test_at_zero_velocity_the_pcrb_is_the_static_two_way_crb(steps):
    link = LinkModel(snr_db=8.0, urt_jitter_s=0.0)
    quiet = dataclasses.replace(preset("ocxo"), h=PowerLaw(h0=1e-40, hm2=1e-46))
    res = link_pcrb(link, quiet, steps, 0.0, 0.0, accel_psd=1e-20, offset_sigma_s=1.0, frequency_sigma=1e-2,
                    velocity_sigma_m_s=1e-9)
    crb = _skog_handel_crb(link.toa_sigma_s, steps, link.interval_s, link.reply_delay_s)
    assert res.offset_var_s2[-1] == pytest.approx(crb, rel=1e-4)
    # Its known asymptote: about 4 sigma^2 / (2 N) for a line's end point from N points of variance sigma^2/2.
    assert res.offset_var_s2[-1] == pytest.approx(4 * link.toa_sigma_s**2 / 2 / steps, rel=0.05)


def test_the_bound_of_a_moving_link_grows_with_doppler_noise_but_not_with_velocity_itself():
    osc = preset("ocxo")
    slow = link_pcrb(LinkModel(snr_db=10.0), osc, 500, 80e3, 200.0)
    fast = link_pcrb(LinkModel(snr_db=10.0), osc, 500, 80e3, 2000.0)
    noisy = link_pcrb(LinkModel(snr_db=10.0, carrier_hz=1e8), osc, 500, 80e3, 2000.0)
    assert fast.offset_var_s2[-1] == pytest.approx(slow.offset_var_s2[-1], rel=0.01)
    assert noisy.offset_var_s2[-1] > 1.05 * fast.offset_var_s2[-1]
    assert not fast.bound.flags.writeable
