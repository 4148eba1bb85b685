"""The one convention for randomness (chronofuse.seeding): an int or SeedSequence reproduces, a
Generator is consumed; and every simulate_* that takes a seed follows it."""

from __future__ import annotations

import numpy as np
import pytest

from chronofuse.integrity.simulate import ClockNoise, simulate_clock_bias
from chronofuse.models.oscillator import simulate_oscillator
from chronofuse.models.oscillator_presets import preset
from chronofuse.models.receiver import simulate_receivers
from chronofuse.seeding import child_rng, child_seed, root_seed


def test_an_int_seed_is_the_seed_sequence_of_that_int():
    assert root_seed(7).entropy == np.random.SeedSequence(7).entropy
    assert root_seed(np.int64(7)).entropy == 7


def test_a_seed_sequence_is_used_as_is_and_never_spawned_from():
    seq = np.random.SeedSequence(11)
    assert root_seed(seq) is seq
    child_seed(seq, 3)
    assert seq.n_children_spawned == 0


def test_a_generator_is_consumed_so_two_calls_give_two_roots():
    rng = np.random.default_rng(5)
    first, second = root_seed(rng), root_seed(rng)
    assert first.entropy != second.entropy
    # ...and the Generator moved on exactly as if it had drawn those words itself.
    twin = np.random.default_rng(5)
    twin.integers(0, 2**32, size=8, dtype=np.uint64)
    assert rng.random() == twin.random()


def test_generators_in_the_same_state_give_the_same_root():
    assert root_seed(np.random.default_rng(5)).entropy == root_seed(np.random.default_rng(5)).entropy


@pytest.mark.parametrize("bad", [True, -1, 1.5, "3", None, np.random.RandomState(1)])
def test_anything_else_is_refused_naming_the_seed(bad):
    with pytest.raises(TypeError, match="seed"):
        root_seed(bad)


def test_a_child_is_what_spawn_gives_a_fresh_parent_at_any_depth():
    base = np.random.SeedSequence(21)
    expect = np.random.SeedSequence(21).spawn(3)[2].spawn(2)[1]
    assert child_seed(base, 2, 1).generate_state(4).tolist() == expect.generate_state(4).tolist()
    assert child_rng(base, 2, 1).random() == np.random.default_rng(expect).random()


def _oscillator(seed):
    return simulate_oscillator(preset("tcxo"), 64.0, 1.0, seed, trials=2).x_s


def _receivers(seed):
    return simulate_receivers("urban-canyon", 64, 2, seed, trials=2).pps_error_s


def _clock_bias(seed):
    return simulate_clock_bias(ClockNoise(h0=1e-19, hm2=1e-23, sigma_rho_m=1.0), interval_s=1.0, steps=64,
                               trials=2, seed=seed).measured_s


SIMULATIONS = [_oscillator, _receivers, _clock_bias]


@pytest.mark.parametrize("simulate", SIMULATIONS)
def test_every_simulation_reproduces_an_int_or_seed_sequence(simulate):
    np.testing.assert_array_equal(simulate(3), simulate(3))
    seq = np.random.SeedSequence(3)
    np.testing.assert_array_equal(simulate(seq), simulate(seq))
    np.testing.assert_array_equal(simulate(seq), simulate(3))
    assert seq.n_children_spawned == 0
    assert not np.array_equal(simulate(3), simulate(4), equal_nan=True)


@pytest.mark.parametrize("simulate", SIMULATIONS)
def test_every_simulation_consumes_a_generator_so_two_calls_differ(simulate):
    rng = np.random.default_rng(3)
    first, second = simulate(rng), simulate(rng)
    assert not np.array_equal(first, second, equal_nan=True)
    # A Generator in the same state repeats the first call: the run is a function of its state.
    np.testing.assert_array_equal(simulate(np.random.default_rng(3)), first)
