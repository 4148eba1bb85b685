"""Multi-node swarm: followers track the leader through its GNSS loss, through link outages, down a tree."""

import numpy as np
import pytest

from chronofuse.experiments.swarm_network import follow_leader, leader_clock_s, link_availability
from chronofuse.sync.metrics import convergence_epochs

STEPS = 600


def _leader_with_holdover_ramp(steps=STEPS, loss_at=200):
    """GNSS-disciplined (0) until loss_at, then a 2e-10 frequency error in holdover."""
    t = np.arange(steps + 2) * 1.0
    return np.where(t >= loss_at, 2e-10 * (t - loss_at), 0.0)


def test_followers_keep_following_the_leader_through_its_gnss_loss():
    x_l = _leader_with_holdover_ramp()
    res = follow_leader(x_l, parents=(0, 0), distances_m=(20e3, 60e3), velocities_m_s=(3.0, -6.0), seed=1)
    np.testing.assert_allclose(res.to_true_s - res.to_leader_s, np.broadcast_to(res.leader_s, (2, STEPS)), rtol=0,
                               atol=1e-18)
    late = slice(STEPS - 100, STEPS)
    assert np.all(np.abs(res.leader_s[late]) > 55e-9)  # the leader has drifted away from true time
    assert np.sqrt(np.mean(res.to_leader_s[:, late] ** 2)) < 2e-9  # the followers stayed with it


def test_a_follower_recovers_after_its_link_goes_down_and_comes_back():
    x_l = np.zeros(STEPS + 2)
    up = np.ones((1, STEPS), dtype=bool)
    up[0, 100:400] = False
    res = follow_leader(x_l, parents=(0,), distances_m=(30e3,), velocities_m_s=(4.0,), link_up=up, seed=2,
                        oscillator="tcxo")
    err = np.abs(res.to_leader_s[0])
    assert err[399] > 5 * np.median(err[:100])  # the TCXO wandered during the outage
    assert convergence_epochs(res.to_leader_s, 2e-9, start=400) is not None


def test_error_grows_down_a_chain_of_followers():
    x_l = np.zeros(STEPS + 2)
    res = follow_leader(x_l, parents=(0, 1, 2), distances_m=(20e3, 20e3, 20e3), velocities_m_s=(2.0, -2.0, 3.0),
                        seed=4)
    rms = np.sqrt(np.mean(res.to_leader_s[:, 100:] ** 2, axis=1))
    assert rms[2] > rms[0]


def test_consensus_uses_peer_links_and_stays_with_the_leader():
    x_l = leader_clock_s(STEPS, 1.0, 5, gnss_sigma_s=0.5e-9)
    up = link_availability(3, STEPS, 6, mean_up_s=200.0, mean_down_s=20.0)
    assert up[:, 0].all() and 0.7 < up.mean() < 1.0
    tree = follow_leader(x_l, link_up=up, seed=7)
    cons = follow_leader(x_l, link_up=up, topology="consensus", seed=7)
    for res in (tree, cons):
        assert np.sqrt(np.mean(res.to_leader_s[:, 100:] ** 2)) < 3e-9
    assert not np.array_equal(tree.to_leader_s, cons.to_leader_s)


def test_parents_must_come_before_their_children():
    with pytest.raises(ValueError, match="parents"):
        follow_leader(np.zeros(20), parents=(2, 0), distances_m=(1e3, 1e3), velocities_m_s=(0.0, 0.0))
