"""Theoretical Allan variance: each term against an independent computation."""

from __future__ import annotations

import math

import allantools
import numpy as np
import pytest
from scipy import integrate

from chronofuse.analysis.theory import adev_theory, avar_components, corrected_pps_adev
from chronofuse.models.oscillator import PowerLaw
from chronofuse.models.receiver_model import ReceiverModel

TAUS_S = np.array([1.0, 10.0, 100.0, 1000.0])


def avar_from_spectrum(h_key: str, h_value: float, tau_s: float, f_upper_hz: float) -> float:
    """AVAR = 2 int_0^f_upper S_y(f) sin^4(pi tau f) / (pi tau f)^2 df (NIST SP 1065 eq. (65))."""
    exponent = {"h2": 2, "h1": 1, "h0": 0, "hm1": -1, "hm2": -2}[h_key]

    def integrand(f):
        u = math.pi * tau_s * f
        return 2.0 * h_value * f**exponent * math.sin(u) ** 4 / u**2

    # Split at the zeros of sin(pi tau f) so quad sees one lobe at a time.
    edges = np.arange(0.0, f_upper_hz, 1.0 / tau_s)
    edges = np.append(edges, f_upper_hz)
    return sum(integrate.quad(integrand, a, b, limit=200)[0] for a, b in zip(edges[:-1], edges[1:]))


@pytest.mark.parametrize("tau_s", [2.0, 10.0, 40.0])
def test_white_pm_term_equals_the_band_limited_spectral_integral(tau_s):
    rate_hz = 1.0
    numeric = avar_from_spectrum("h2", 1.0, tau_s, rate_hz / 2.0)
    assert avar_components(PowerLaw(h2=1.0), np.array([tau_s]), rate_hz)["h2"][0] == pytest.approx(numeric, rel=1e-6)


def test_flicker_pm_term_is_the_asymptote_of_the_band_limited_integral():
    rate_hz, tau_s = 1.0, 200.0  # 2 pi f_h tau ~ 630 >> 1, where SP 1065's formula holds
    numeric = avar_from_spectrum("h1", 1.0, tau_s, rate_hz / 2.0)
    assert avar_components(PowerLaw(h1=1.0), np.array([tau_s]), rate_hz)["h1"][0] == pytest.approx(numeric, rel=2e-4)


@pytest.mark.parametrize("key", ["h0", "hm1", "hm2"])
@pytest.mark.parametrize("tau_s", [1.0, 7.0])
def test_frequency_noise_terms_equal_the_unbounded_spectral_integral(key, tau_s):
    # Integrate far beyond 1/tau; the tail above f_upper is below 1e-6 of the total for these three.
    f_upper = 2.0e5 / tau_s if key == "h0" else 200.0 / tau_s
    numeric = avar_from_spectrum(key, 1.0, tau_s, f_upper)
    theory = avar_components(PowerLaw(**{key: 1.0}), np.array([tau_s]), 1.0)[key][0]
    assert theory == pytest.approx(numeric, rel=2e-5 if key == "h0" else 1e-4)


def test_drift_term_equals_the_allan_variance_of_a_quadratic_phase():
    drift_per_s, rate_hz = 3.0e-12, 1.0
    t = np.arange(5000) / rate_hz
    x = drift_per_s * t**2 / 2.0
    for tau_s in TAUS_S:
        m = int(tau_s * rate_hz)
        second_difference = x[2 * m :] - 2.0 * x[m:-m] + x[: -2 * m]
        direct = np.mean(second_difference**2) / (2.0 * tau_s**2)
        comp = avar_components(PowerLaw(), np.array([tau_s]), rate_hz, drift_per_s)["drift"][0]
        assert comp == pytest.approx(direct, rel=1e-9)


@pytest.mark.parametrize("b, key", [(0, "h2"), (-1, "h1"), (-2, "h0"), (-3, "hm1"), (-4, "hm2")])
@pytest.mark.parametrize("tau0_s", [1.0, 0.1])
def test_adev_theory_agrees_with_allantools_noise_predictions(b, key, tau0_s):
    noise = allantools.Noise(nr=8, qd=1.0e-20, b=b)
    h_value = noise.frequency_psd_from_qd(tau0_s)
    ours = adev_theory(PowerLaw(**{key: h_value}), TAUS_S, 1.0 / tau0_s)
    theirs = np.array([noise.adev(tau0_s, tau) for tau in TAUS_S])
    # allantools writes the flicker-PM constant as 1.0385 where SP 1065 has 1.038.
    np.testing.assert_allclose(ours, theirs, rtol=1e-4 if key == "h1" else 1e-12)


def test_adev_theory_is_the_root_of_the_summed_components():
    h = PowerLaw(h2=1e-30, h1=1e-28, h0=1e-24, hm1=1e-25, hm2=1e-30)
    comps = avar_components(h, TAUS_S, 10.0, 1e-15)
    assert set(comps) == {"h2", "h1", "h0", "hm1", "hm2", "drift"}
    assert all(v.shape == TAUS_S.shape for v in comps.values())
    np.testing.assert_allclose(adev_theory(h, TAUS_S, 10.0, 1e-15) ** 2, sum(comps.values()), rtol=1e-14)


def test_theory_rejects_bad_inputs_naming_them():
    with pytest.raises(ValueError, match="tau_s"):
        adev_theory(PowerLaw(h0=1.0), np.array([1.0, 0.0]), 1.0)
    with pytest.raises(ValueError, match="rate_hz"):
        adev_theory(PowerLaw(h0=1.0), TAUS_S, -1.0)
    with pytest.raises(TypeError, match="h =="):
        adev_theory({"h0": 1.0}, TAUS_S, 1.0)


def avar_from_covariance(autocov, n: int, dt_s: float) -> float:
    """E[(x_{k+2n} - 2 x_{k+n} + x_k)^2] / (2 tau^2) as a quadratic form over the (2n+1)-point covariance
    matrix of a stationary phase (an independent route to SP 1065 eq. (7)'s expectation)."""
    lags = np.abs(np.subtract.outer(np.arange(2 * n + 1), np.arange(2 * n + 1)))
    weights = np.zeros(2 * n + 1)
    weights[[0, n, 2 * n]] = [1.0, -2.0, 1.0]
    return float(weights @ autocov(lags) @ weights) / (2.0 * (n * dt_s) ** 2)


@pytest.mark.parametrize("dt_s", [1.0, 2.0])
def test_corrected_pps_adev_is_the_allan_variance_of_the_white_plus_gauss_markov_covariance(dt_s):
    model = ReceiverModel(white_sigma_s=3e-9, gdop_log_sigma=0.3, multipath_sigma_s=5e-9, multipath_tau_s=12.0,
                          wander_sigma_s=4e-9, wander_tau_s=900.0)
    white_var = model.white_sigma_s**2 * math.exp(2 * model.gdop_log_sigma**2)  # E[(G/median)^2], log-normal G

    def autocov(lag):
        return (np.where(lag == 0, white_var, 0.0)
                + model.multipath_sigma_s**2 * np.exp(-lag * dt_s / model.multipath_tau_s)
                + model.wander_sigma_s**2 * np.exp(-lag * dt_s / model.wander_tau_s))

    n = np.array([1, 3, 10, 40])
    expect = [math.sqrt(avar_from_covariance(autocov, int(k), dt_s)) for k in n]
    np.testing.assert_allclose(corrected_pps_adev(model, n * dt_s, dt_s), expect, rtol=1e-12)


def test_corrected_pps_adev_of_white_phase_noise_is_sqrt3_sigma_over_tau():
    # White phase noise of variance sigma^2 at dt = 1 s: AVAR = 6 sigma^2 / (2 tau^2) = 3 sigma^2 / tau^2, which is
    # NIST SP 1065 Table 3's white PM 3 f_h h2 / (4 pi^2 tau^2) for the h2 of that variance (below).
    model = ReceiverModel(white_sigma_s=2e-9, gdop_log_sigma=0.0, multipath_sigma_s=0.0, wander_sigma_s=0.0)
    tau = np.array([1.0, 5.0, 100.0])
    np.testing.assert_allclose(corrected_pps_adev(model, tau), math.sqrt(3.0) * 2e-9 / tau, rtol=1e-14)
    h2 = 2e-9**2 * 4 * math.pi**2 / 0.5  # the h2 whose one-sided phase PSD integrates to sigma^2 over f_h = 0.5 Hz
    np.testing.assert_allclose(corrected_pps_adev(model, tau), adev_theory(PowerLaw(h2=h2), tau, 1.0), rtol=1e-12)


def test_corrected_pps_adev_refuses_a_tau_that_is_not_a_whole_number_of_steps():
    with pytest.raises(ValueError, match="tau_s"):
        corrected_pps_adev(ReceiverModel(), np.array([1.5]))
