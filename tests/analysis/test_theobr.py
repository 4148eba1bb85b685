"""TheoBR and TheoH: the numba kernel against its numpy twin, the bias it removes (checked against the exact
expected Allan variance of simulated noise), and TheoH's split at 10 % of the record."""

import numpy as np
import pytest
from scipy.signal import fftconvolve

from chronofuse.analysis import stability as st
from chronofuse.analysis.stability.kernels_theo import theo1_raw
from chronofuse.analysis.stability.kernels_theobr import theobr_numpy, theobr_raw, theoh_split_s
from tests.analysis.test_gaps import expected_square, phase_filter


def test_theobr_kernel_equals_its_numpy_twin():
    rng = np.random.default_rng(1)
    x = np.cumsum(rng.standard_normal(1500)) * 1e-9 + rng.standard_normal(1500) * 1e-9
    m = np.array([10, 12, 100, 400, 1000, 1498])
    np.testing.assert_allclose(theobr_raw(x, m, 0.5)[0], theobr_numpy(x, m, 0.5)[0], rtol=1e-10)


@pytest.mark.parametrize("noise", ["white FM", "flicker FM", "random-walk FM"])
def test_theobr_is_the_allan_variance_where_theo1_is_biased(noise):
    """200 trials of 1024 points: the mean TheoBR**2 at tau = 30, 150 and 300 s is the exact expected AVAR
    within three standard errors (one is 2-6 %); Theo1**2 itself is 0.4-0.6 of the AVAR for flicker and
    random-walk FM, which is the bias TheoBR removes."""
    n, trials = 1024, 200
    rng = np.random.default_rng(7)
    p = phase_filter(noise, n)
    phases = fftconvolve(rng.standard_normal((trials, n)), p[None, :], axes=1)[:, :n]
    m = np.array([40, 200, 400])
    tau = (0.75 * m).astype(int)
    truth = np.array([np.mean(expected_square(p, int(t), 2, n - 2 * int(t))) / (2.0 * t * t) for t in tau])
    br = np.array([theobr_raw(x, m, 1.0)[0] ** 2 for x in phases])
    mean, se = br.mean(axis=0), br.std(axis=0) / np.sqrt(trials)
    assert np.all(np.abs(mean - truth) <= 3 * se), (mean / truth, se / truth)
    np.testing.assert_allclose(mean / truth, 1.0, atol=0.15)
    theo1 = np.array([theo1_raw(x, m, 1.0)[0] ** 2 for x in phases]).mean(axis=0) / truth
    if noise != "white FM":
        assert np.all(theo1 < 0.7), theo1


def test_theoh_is_oadev_below_a_tenth_of_the_record_and_theobr_from_there():
    rng = np.random.default_rng(3)
    x = np.cumsum(rng.standard_normal(2000)) * 1e-9
    taus = st.tau_grid("octave", x.size, 1.0, "theoh")
    k = theoh_split_s(x.size, 1.0)
    assert k == 200.0 and taus[taus < k].tolist() == [1, 2, 4, 8, 16, 32, 64, 128]
    assert taus[taus >= k].tolist() == [0.75 * 512, 0.75 * 1024]
    h = st.theoh(x, 1.0, taus)
    low = st.oadev(x, 1.0, taus[taus < k])
    high = st.theobr(x, 1.0, taus[taus >= k])
    np.testing.assert_array_equal(h.dev, np.concatenate((low.dev, high.dev)))
    np.testing.assert_array_equal(h.edf, np.concatenate((low.edf, high.edf)))
    assert h.statistic == "theoh" and h.gap_rule == "fill"


def test_theobr_refuses_a_record_too_short_for_its_bias_sum():
    with pytest.raises(ValueError, match="too few for theobr"):
        st.tau_grid("octave", 80, 1.0, "theobr")
