"""The two-state clock: its Allan variance is NIST SP 1065's for white FM and random-walk FM."""

import numpy as np
import pytest

from chronofuse.analysis.stability import oadev
from chronofuse.analysis.theory import adev_theory
from chronofuse.models.clock import clock_process_noise, clock_transition, two_state_clock_phase_s
from chronofuse.models.oscillator import PowerLaw


@pytest.mark.parametrize(("h0", "hm2"), [(1e-20, 0.0), (0.0, 1e-24)])
def test_pooled_allan_variance_equals_theory_for_each_noise_alone(h0, hm2):
    rng = np.random.default_rng(7)
    z = rng.standard_normal((3, 64, 4096))
    x = two_state_clock_phase_s(z[0], z[1], z[2], h0=h0, hm2=hm2, dt_s=1.0)
    assert x.shape == (64, 4096) and (x[:, 0] == 0).all()
    tau = np.array([1.0, 10.0, 100.0])
    avar = np.mean([oadev(row, 1.0, tau).dev ** 2 for row in x], axis=0)
    theory = adev_theory(PowerLaw(h0=h0, hm2=hm2), tau, 1.0) ** 2
    np.testing.assert_allclose(avar, theory, rtol=0.12)  # 64 records: a few percent scatter at 100 s


def test_sampled_phase_and_frequency_increments_have_the_process_noise_covariance_q():
    # The sampler and the filters' Q are one model: the empirical covariance of the (phase, frequency)
    # increments over one step equals clock_process_noise within its sampling error.
    h0, hm2, dt = 2e-18, 1e-20, 4.0
    rng = np.random.default_rng(3)
    z = rng.standard_normal((3, 20_000, 3))
    x = two_state_clock_phase_s(z[0], z[1], z[2], h0=h0, hm2=hm2, dt_s=dt)
    q2 = 2 * np.pi**2 * hm2
    y = np.sqrt(q2 * dt) * z[1][:, 0]  # frequency after the first step (it starts at 0)
    w = np.stack([x[:, 1], y])  # phase and frequency increments of the first step from the zero state
    q = clock_process_noise(dt, h0=h0, hm2=hm2)
    se = np.sqrt((q**2 + np.outer(np.diag(q), np.diag(q))) / w.shape[1])  # Wishart standard error
    assert np.all(np.abs(np.cov(w, bias=True) - q) < 5 * se)
    np.testing.assert_array_equal(clock_transition(dt), [[1.0, dt], [0.0, 1.0]])
