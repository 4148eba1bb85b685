"""The numba chains against their numpy twins: the paper's chain (RvcKfChain, with and without its BP network)
and doppler-kf (the numba batch loop against the streaming numpy core)."""

import numpy as np
import pytest

from chronofuse.estimation.interface import compare_streaming_to_batch
from chronofuse.experiments.swarm import LinkScenario, calibrate_scenario, knowledge_of, simulate_scenario
from chronofuse.models.link import LinkModel
from chronofuse.sync.base import SyncAlgorithm, measurement_array
from chronofuse.sync.chain import RvcKfChain
from chronofuse.sync.fast import FastRvcKfChain
from chronofuse.sync.registry import make_algorithm


def _pair(light_time, net=None, steps=300):
    sc = LinkScenario(velocity_m_s=1500.0, exchanges=steps)
    config = make_algorithm("rtt-rvc-kf", knowledge_of(sc, None), light_time=light_time, urt_s=19e-9).config
    Z = measurement_array(simulate_scenario(sc, 3, 2)[0])
    return RvcKfChain(config, net).fit(), FastRvcKfChain(config, net).fit(), Z


@pytest.mark.parametrize("light_time", ["paper", "exact"])
def test_the_numba_chain_equals_the_numpy_chain(light_time):
    slow, fast, Z = _pair(light_time)
    np.testing.assert_allclose(fast.run(Z).offset_s, slow.run(Z).offset_s, rtol=0, atol=1e-17)
    assert compare_streaming_to_batch(fast, Z) == []


def test_the_numba_chain_with_a_bp_network_equals_the_numpy_chain():
    torch = pytest.importorskip("torch")  # noqa: F841
    from chronofuse.sync.residual import ResidualConfig, ResidualNetwork

    rng = np.random.default_rng(0)
    X = rng.standard_normal((500, 1, 9))
    y = 0.5 * X[:, 0, 0] + 0.2
    net = ResidualNetwork(ResidualConfig(epochs=3, batch=64)).fit(X, y, X[:100], y[:100])
    slow, fast, Z = _pair("paper", net)
    a, b = fast.run(Z).offset_s, slow.run(Z).offset_s
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-15)
    plain = _pair("paper")[1].run(Z).offset_s  # the same chain without its network
    w = fast.warmup_steps_
    np.testing.assert_array_equal(a[:, :w], plain[:, :w])
    assert np.mean(np.abs(a[:, w:] - plain[:, w:])) > 1e-11  # the network acts after the warm-up
    # the missing-exchange path predicts, as the numpy core does
    Zm = Z.copy()
    Zm[:, 100:120, :] = np.nan
    np.testing.assert_allclose(fast.run(Zm).offset_s, slow.run(Zm).offset_s, rtol=0, atol=1e-15)


def test_the_numba_chain_refuses_other_configurations():
    with pytest.raises(ValueError, match="calibrated"):
        make_algorithm("rtt-rvc-kf-numba", urt_mode="paper").fit()


def test_the_numba_doppler_kf_loop_equals_its_numpy_core_with_losses_outliers_and_references():
    link = LinkModel(nlos_probability=0.02, loss_fraction=0.05, loss_burst_mean=5.0, snr_reference_range_m=80e3)
    sc = LinkScenario(exchanges=400, link=link, common_velocity_m_s=200.0, latitude_deg=20.0)
    ex, draw = simulate_scenario(sc, 4, 3)
    kf = make_algorithm("doppler-kf", knowledge_of(sc, calibrate_scenario(sc, draw, 4))).fit()
    Z = measurement_array(ex)
    ref = np.where(np.arange(400) % 50 == 0, ex.offset_s, np.nan)
    fast, slow = kf.run(Z, ref), SyncAlgorithm.run(kf, Z, ref)
    np.testing.assert_allclose(fast.offset_s, slow.offset_s, rtol=0, atol=1e-18)
    # the compiled Kalman step's expanded Joseph update sums in another order than the twin's matrix form
    np.testing.assert_allclose(fast.uncertainty_s, slow.uncertainty_s, rtol=1e-9)
    np.testing.assert_array_equal(fast.node_state, slow.node_state)
    one = make_algorithm("doppler-kf", knowledge_of(sc, None)).fit()
    assert compare_streaming_to_batch(one, Z[:2, :150]) == []
