"""Clock-bias truth under H0: reproducible seeding and the clock's stability against theory."""

import allantools
import numpy as np
import pytest

from chronofuse.integrity.simulate import ClockNoise, simulate_clock_bias


def test_the_same_seed_gives_the_same_trials_whatever_the_batch_size():
    noise = ClockNoise(2e-18, 1e-22, 1.0)
    a = simulate_clock_bias(noise, interval_s=1.0, steps=100, trials=3, seed=5)
    b = simulate_clock_bias(noise, interval_s=1.0, steps=100, trials=5, seed=5)
    np.testing.assert_array_equal(a.measured_s, b.measured_s[:3])
    c = simulate_clock_bias(noise, interval_s=1.0, steps=100, trials=3, seed=6)
    assert not np.allclose(a.measured_s, c.measured_s)
    assert a.truth_s.shape == (3, 100) and a.t_s[-1] == 99.0


def test_measurement_noise_is_the_pseudorange_noise_over_c():
    sim = simulate_clock_bias(ClockNoise(1e-20, 0.0, 3.0), interval_s=1.0, steps=20_000, trials=2, seed=1)
    resid = sim.measured_s - sim.truth_s
    assert resid.std() == pytest.approx(3.0 / 299_792_458.0, rel=0.02)


@pytest.mark.parametrize("h0, hm2", [(2e-18, 0.0), (0.0, 1e-20), (2e-18, 1e-20)])
def test_simulated_clock_adev_matches_the_white_fm_and_random_walk_fm_theory(h0, hm2):
    # NIST SP 1065: AVAR = h0 / (2 tau) + (2 pi^2 / 3) h_-2 tau; allantools as the ADEV oracle
    sim = simulate_clock_bias(ClockNoise(h0, hm2, 0.0), interval_s=1.0, steps=20_000, trials=8, seed=3)
    taus = np.array([1.0, 10.0, 100.0])
    avar = np.mean([allantools.oadev(row, rate=1.0, data_type="phase", taus=taus)[1] ** 2 for row in sim.truth_s],
                   axis=0)
    theory = h0 / (2 * taus) + 2 * np.pi**2 / 3 * hm2 * taus
    np.testing.assert_allclose(avar, theory, rtol=0.15)


def test_negative_noise_is_rejected_by_name():
    with pytest.raises(ValueError, match="sigma_rho_m"):
        ClockNoise(1e-18, 0.0, -1.0)


def test_a_seed_sequence_passed_in_is_not_mutated_so_two_calls_agree():
    import numpy as np

    from chronofuse.integrity.simulate import ClockNoise, simulate_clock_bias

    ss = np.random.SeedSequence(5)
    noise = ClockNoise(h0=2e-18, hm2=1e-22, sigma_rho_m=1.0)
    a = simulate_clock_bias(noise, interval_s=1.0, steps=50, trials=2, seed=ss)
    b = simulate_clock_bias(noise, interval_s=1.0, steps=50, trials=2, seed=ss)
    np.testing.assert_array_equal(a.measured_s, b.measured_s)
