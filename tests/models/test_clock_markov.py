"""Flicker FM as Gauss-Markov states: the model's Allan deviation against the flicker floor and against a
simulation of itself; its discretisation against the two-state clock's closed form."""

import math

import numpy as np
import pytest

from chronofuse.analysis.stability import oadev
from chronofuse.models.clock import clock_process_noise
from chronofuse.models.clock_markov import ClockMarkovModel, ou_allan_variance
from chronofuse.models.oscillator_presets import preset


def test_one_corner_per_decade_keeps_the_allan_deviation_within_5_percent_of_the_flicker_floor():
    m = ClockMarkovModel(h0_s=0.0, hm1=1e-23, hm2_per_s=0.0, flicker_lo_hz=1e-3, flicker_hi_hz=100.0)
    tau = np.logspace(np.log10(0.02), np.log10(30.0), 13)  # 2 / f_hi .. 1 / (30 f_lo)
    ratio = np.sqrt(m.allan_variance(tau) / (2 * math.log(2) * 1e-23))
    assert np.all(np.abs(ratio - 1.0) < 0.05), ratio


def test_the_closed_form_ou_allan_variance_is_that_of_a_simulated_process():
    rng = np.random.default_rng(0)
    lam, var, dt, n = 2.0, 1.0, 0.05, 400_000
    phi = math.exp(-lam * dt)
    y = np.empty(n)
    y[0] = rng.standard_normal()
    e = rng.standard_normal(n) * math.sqrt(1 - phi * phi)
    for k in range(1, n):
        y[k] = phi * y[k - 1] + e[k]
    # interval averages from a fine grid: phase is the integral of y
    x = np.concatenate([[0.0], np.cumsum(y) * dt])
    tau = np.array([0.2, 1.0, 5.0])
    dev = oadev(x, 1 / dt, tau).dev
    np.testing.assert_allclose(dev**2, ou_allan_variance(tau, lam, var), rtol=0.08)


def test_the_model_s_allan_deviation_is_that_of_its_own_simulation():
    o = preset("ocxo")
    m = ClockMarkovModel.for_link(o, o, 0.01, 20.0)
    x = m.simulate_phase_s(200_000, 0.01, np.random.default_rng(1), 1)[0]
    tau = np.array([0.02, 0.1, 1.0, 10.0])
    np.testing.assert_allclose(oadev(x, 100.0, tau).dev, np.sqrt(m.allan_variance(tau)), rtol=0.1)


def test_without_flicker_the_discretisation_is_the_two_state_clock_s_closed_form():
    m = ClockMarkovModel(h0_s=4e-24, hm1=0.0, hm2_per_s=7.6e-27)
    Phi, Q = m.discrete(0.01)
    np.testing.assert_allclose(Phi, [[1.0, 0.01], [0.0, 1.0]], atol=1e-15)
    np.testing.assert_allclose(Q, clock_process_noise(0.01, h0=4e-24, hm2=7.6e-27), rtol=1e-9)
    assert m.n_states == 2 and ClockMarkovModel.for_link(preset("ocxo"), preset("ocxo"), 0.01, 20.0).n_states == 7
