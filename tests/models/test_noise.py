"""Kasdin–Walter power-law noise: impulse response, convolution, spectrum, shaping gains, seeding."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal, special

from chronofuse.models.noise import (
    KasdinWalterFilter,
    PartitionedConvolution,
    flicker_fm_gain,
    flicker_pm_gain,
    gauss_markov,
    kasdin_walter_impulse_response,
    power_law_noise,
    shaping_kernel,
    tabulated_gain,
)


@pytest.mark.parametrize("alpha", [-2.0, -1.0, -0.5, 1.0, 2.0])
def test_impulse_response_matches_the_binomial_series_in_gamma_functions(alpha):
    d = -alpha / 2.0
    k = np.arange(150)
    h = kasdin_walter_impulse_response(alpha, k.size)
    if d in (0.0, -1.0):  # polynomial filters: (1 - z^-1)^1 has h = [1, -1, 0, ...]
        expected = np.zeros(k.size)
        expected[0] = 1.0
        if d == -1.0:
            expected[1] = -1.0
    else:
        expected = special.poch(d, k) / special.factorial(k)  # Gamma(k+d) / (Gamma(d) k!)
    np.testing.assert_allclose(h, expected, rtol=1e-12, atol=1e-15)


def test_impulse_response_chunks_agree_with_one_cumulative_product():
    n = (1 << 20) + 12345  # crosses the chunk boundary
    h = kasdin_walter_impulse_response(-1.0, n)
    k = np.arange(1, n)
    direct = np.concatenate(([1.0], np.cumprod((k - 0.5) / k)))
    np.testing.assert_allclose(h, direct, rtol=1e-10)


@pytest.mark.parametrize("n, block", [(10, 3), (1000, 64), (1000, 1000), (777, 100), (5, 8)])
def test_partitioned_convolution_equals_numpy_convolve(n, block):
    rng = np.random.default_rng(n + block)
    impulse, x = rng.standard_normal(n), rng.standard_normal(n)
    out = np.zeros(n)
    for start, blk in PartitionedConvolution(impulse, block).blocks(x, n):
        out[start : start + blk.size] = blk
    np.testing.assert_allclose(out, np.convolve(impulse, x)[:n], atol=1e-12)


@pytest.mark.parametrize("alpha", [-2.0, -1.0, -0.7, 0.0, 1.0])
def test_power_law_noise_is_the_truncated_convolution_of_the_same_draws(alpha):
    n, trials = 3000, 3
    u = power_law_noise(alpha, n, np.random.default_rng(11), trials)
    assert u.shape == (trials, n)
    rng = np.random.default_rng(11)
    h = kasdin_walter_impulse_response(alpha, n)
    for i in range(trials):
        expected = np.convolve(h, rng.standard_normal(n))[:n]
        np.testing.assert_allclose(u[i], expected, atol=1e-9 * np.abs(expected).max())


@pytest.mark.parametrize("alpha", [-2.0, -1.0, 0.0, 1.0, 2.0])
def test_welch_spectrum_has_slope_alpha_and_unit_innovation_level(alpha):
    # One-sided PSD (fs = 1) of K-W noise with unit innovations is 2 |2 sin(pi f)|^alpha.
    u = power_law_noise(alpha, 1 << 14, np.random.default_rng(5), trials=16)
    f, p = signal.welch(u, fs=1.0, nperseg=1024, axis=-1)
    p = p.mean(axis=0)
    band = (f >= 0.01) & (f <= 0.4)
    slope, intercept = np.polyfit(np.log(2.0 * np.sin(np.pi * f[band])), np.log(p[band]), 1)
    assert slope == pytest.approx(alpha, abs=0.05)
    assert np.exp(intercept) == pytest.approx(2.0, rel=0.05)


def test_flicker_fm_gain_squared_equals_the_aliasing_sum_over_the_kasdin_walter_spectrum():
    nu = np.array([1e-3, 0.05, 0.2, 0.37, 0.5])
    k = np.arange(-200000, 200001)[:, None]
    aliased = np.sum(np.sinc(nu + k) ** 2 / np.abs(nu + k), axis=0)  # sum_k sinc^2(nu+k)/|nu+k|
    kasdin_walter = np.pi / (2.0 * np.sin(np.pi * nu)) * 2.0 / 1.0  # pi h (2 sin)^-1 over h/2
    np.testing.assert_allclose(flicker_fm_gain(nu) ** 2, aliased / kasdin_walter, rtol=1e-5)
    assert flicker_fm_gain(np.array([0.0]))[0] == pytest.approx(1.0)


def test_flicker_pm_gain_squared_is_the_brick_wall_ratio_sinc():
    nu = np.linspace(0.0, 0.5, 11)
    np.testing.assert_allclose(flicker_pm_gain(nu) ** 2, np.sinc(nu), rtol=1e-15)


@pytest.mark.parametrize("gain", [flicker_fm_gain, flicker_pm_gain])
def test_shaping_kernel_response_reproduces_its_gain(gain):
    kernel = shaping_kernel(gain)
    half = (kernel.size - 1) // 2
    nu = np.array([0.0, 0.01, 0.1, 0.25, 0.49])
    lags = np.arange(-half, half + 1)
    response = np.real(np.exp(-2j * np.pi * nu[:, None] * lags[None, :]) @ kernel)
    np.testing.assert_allclose(response, gain(nu), atol=2e-4)
    np.testing.assert_allclose(kernel, kernel[::-1], atol=1e-15)  # zero phase


def test_tabulated_gain_is_close_to_the_exact_gain():
    nu = np.random.default_rng(0).uniform(0.0, 0.5, 1000)
    np.testing.assert_allclose(tabulated_gain(flicker_fm_gain)(nu), flicker_fm_gain(nu), rtol=1e-7)


def test_shaped_filter_equals_convolving_the_plain_output_with_the_kernel():
    n = 3000
    gain = flicker_pm_gain
    kernel = shaping_kernel(gain)
    half = (kernel.size - 1) // 2
    shaped = np.zeros(n)
    KasdinWalterFilter(-1.0, n, gain=gain).add_row(shaped, np.random.default_rng(2))
    # Twin: innovations start `half` samples early; K-W filter them, then apply the kernel.
    e = np.random.default_rng(2).standard_normal(n + half)
    h = kasdin_walter_impulse_response(-1.0, n + half)
    plain = np.convolve(h, e)[: n + half]
    padded = np.concatenate((np.zeros(half), plain))  # K-W output is zero before its start
    expected = np.convolve(padded, kernel, mode="valid")[:n]
    np.testing.assert_allclose(shaped, expected, atol=1e-9 * np.abs(expected).max())


def test_same_generator_state_gives_identical_noise():
    a = power_law_noise(-1.0, 500, np.random.default_rng(42), trials=2)
    b = power_law_noise(-1.0, 500, np.random.default_rng(42), trials=2)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a[0], a[1])


def test_power_law_noise_rejects_bad_arguments_naming_them():
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match="alpha"):
        power_law_noise(3.0, 10, rng)
    with pytest.raises(ValueError, match="n_samples"):
        power_law_noise(-1.0, 0, rng)
    with pytest.raises(ValueError, match="trials"):
        power_law_noise(-1.0, 10, rng, trials=0)
    with pytest.raises(TypeError, match="rng"):
        power_law_noise(-1.0, 10, 42)


def test_gauss_markov_filter_matches_the_ar1_recursion_written_as_a_loop():
    rng = np.random.default_rng(3)
    w = rng.standard_normal((2, 3, 51))
    sigma, tau_s, dt_s = 2.0, 7.0, 1.5
    phi = np.exp(-dt_s / tau_s)
    expect = np.empty((2, 3, 50))
    prev = sigma * w[..., 0]
    for k in range(50):
        prev = phi * prev + sigma * np.sqrt(1 - phi**2) * w[..., k + 1]
        expect[..., k] = prev
    np.testing.assert_allclose(gauss_markov(w, sigma, tau_s, dt_s), expect, rtol=1e-12, atol=1e-12)


def test_gauss_markov_is_stationary_with_exponential_autocovariance():
    # Started from its stationary law: variance sigma^2 at every step, E[x_k x_{k+n}] = sigma^2 phi^n.
    sigma, tau_s, dt_s = 3.0, 4.0, 1.0
    x = gauss_markov(np.random.default_rng(5).standard_normal((20000, 9)), sigma, tau_s, dt_s)
    np.testing.assert_allclose(x.var(axis=0), sigma**2, rtol=0.05)
    for lag in (1, 4, 7):
        assert np.mean(x[:, 0] * x[:, lag]) == pytest.approx(sigma**2 * np.exp(-lag * dt_s / tau_s), abs=0.2)
