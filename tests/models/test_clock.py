"""The two-state clock: its Allan variance is NIST SP 1065's for white FM and random-walk FM."""

import numpy as np
import pytest

from chronofuse.analysis.stability import oadev
from chronofuse.analysis.theory import adev_theory
from chronofuse.models.clock import two_state_clock_phase_s
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
