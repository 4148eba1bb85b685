"""Discrete clock model against Van Loan's matrix exponential; the second difference's one definition."""

import numpy as np
import pytest
from scipy import linalg

from chronofuse.estimation.process import ClockProcess, second_difference, second_difference_series


def _van_loan(a: np.ndarray, qc: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Phi and Q of dx/dt = A x + w (white, spectral density Qc) by C. F. Van Loan, "Computing integrals
    involving the matrix exponential", IEEE TAC 23(3), 1978: expm([[-A, Qc], [0, A']] dt)."""
    n = a.shape[0]
    m = np.zeros((2 * n, 2 * n))
    m[:n, :n] = -a
    m[:n, n:] = qc
    m[n:, n:] = a.T
    e = linalg.expm(m * dt)
    phi = e[n:, n:].T
    return phi, phi @ e[:n, n:]


@pytest.mark.parametrize("states, dt", [(2, 1.0), (2, 0.25), (3, 1.0), (3, 30.0)])
def test_phi_and_q_equal_van_loans_matrix_exponential(states, dt):
    h0, hm2, q3 = 2e-18, 1e-22, 3e-30
    proc = ClockProcess(dt_s=dt, h0=h0, hm2=hm2, drift_psd_per_s3=q3 if states == 3 else 0.0, states=states)
    a = np.diag(np.ones(states - 1), 1)  # dx/dt = y, dy/dt = D
    qc = np.diag([h0 / 2, 2 * np.pi**2 * hm2, q3][:states])
    phi, q = _van_loan(a, qc, dt)
    np.testing.assert_allclose(proc.F, phi, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(proc.Q, q, rtol=1e-9, atol=1e-12 * np.abs(q).max())


def test_bad_clock_parameters_are_named():
    with pytest.raises(ValueError, match="hm2"):
        ClockProcess(dt_s=1.0, h0=1e-18, hm2=-1.0)
    with pytest.raises(ValueError, match="drift_psd_per_s3"):
        ClockProcess(dt_s=1.0, h0=1e-18, hm2=0.0, drift_psd_per_s3=1e-30, states=2)
    with pytest.raises(ValueError, match="states"):
        ClockProcess(dt_s=1.0, h0=1e-18, hm2=0.0, states=4)


def test_second_difference_removes_phase_and_frequency_and_keeps_a_drift():
    t = np.arange(10.0) * 2.0
    x = 3e-6 + 4e-9 * t + 0.5 * 1e-12 * t**2
    df = second_difference_series(x, 2.0)
    assert np.isnan(df[:2]).all()
    np.testing.assert_allclose(df[2:], 1e-12 * 2.0, rtol=1e-6)  # D t_s^2 / t_s
    # the streaming (float) form is the same operator
    assert second_difference(x[5], x[4], x[3], 2.0) == df[5]
    gap = x.copy()
    gap[4] = np.nan
    assert np.isnan(second_difference_series(gap, 2.0)[4:7]).all()
