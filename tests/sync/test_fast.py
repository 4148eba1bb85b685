"""The numba seed chain against its numpy twin (ProposedChain), with and without the BP network."""

import numpy as np
import pytest

from chronofuse.estimation.interface import compare_streaming_to_batch
from chronofuse.experiments.swarm import LinkScenario, simulate_scenario
from chronofuse.sync.base import measurement_array
from chronofuse.sync.chain import ProposedChain
from chronofuse.sync.fast import FastSeedChain
from chronofuse.sync.registry import chain_noise
from chronofuse.models.oscillator_presets import preset


def _pair(light_time, net=None, steps=300):
    sc = LinkScenario(velocity_m_s=1500.0, exchanges=steps)
    kw = dict(filter="seed", light_time=light_time, urt_mode="calibrated", urt_fixed_s=19e-9,
              residual_model=net, **chain_noise(sc.link, preset("ocxo"), steps))
    Z = measurement_array(simulate_scenario(sc, 3, 2))
    return ProposedChain(**kw).fit(), FastSeedChain(**kw).fit(), Z


@pytest.mark.parametrize("light_time", ["seed", "exact"])
def test_the_numba_chain_equals_the_numpy_chain(light_time):
    slow, fast, Z = _pair(light_time)
    np.testing.assert_allclose(fast.run(Z).offset_s, slow.run(Z).offset_s, rtol=0, atol=1e-17)
    assert compare_streaming_to_batch(fast, Z) == []


def test_the_numba_chain_with_a_bp_network_equals_the_numpy_chain():
    torch = pytest.importorskip("torch")  # noqa: F841
    from chronofuse.sync.network import ResidualConfig, ResidualNetwork

    rng = np.random.default_rng(0)
    X = rng.standard_normal((500, 1, 9))
    y = 0.5 * X[:, 0, 0] + 0.2
    net = ResidualNetwork(ResidualConfig(epochs=3, batch=64)).fit(X, y, X[:100], y[:100])
    slow, fast, Z = _pair("seed", net)
    a, b = fast.run(Z).offset_s, slow.run(Z).offset_s
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-15)
    plain = _pair("seed")[1].run(Z).offset_s  # the same chain without its network
    w = fast.warmup_steps_
    np.testing.assert_array_equal(a[:, :w], plain[:, :w])
    assert np.mean(np.abs(a[:, w:] - plain[:, w:])) > 1e-11  # the network acts after the warm-up
    # the missing-exchange path predicts, as the numpy core does
    Zm = Z.copy()
    Zm[:, 100:120, :] = np.nan
    np.testing.assert_allclose(fast.run(Zm).offset_s, slow.run(Zm).offset_s, rtol=0, atol=1e-15)


def test_the_numba_chain_refuses_other_configurations():
    with pytest.raises(ValueError, match="calibrated"):
        FastSeedChain(urt_mode="paper").fit()
