"""A multi-node swarm (SPEC 0 and 5): a leader and followers in a tree, links that come and go, and GNSS
loss at the leader (orchestration over the link truth and the sync algorithms).

Truth: the leader's clock error ``x_L(t)`` (given, e.g. a GNSS-disciplined oscillator that goes into
holdover; :func:`leader_clock_s` makes a simple one), each follower's free-running oscillator, and each
follower's radial motion relative to its parent. Follower ``i`` exchanges with its parent ``p(i)``
(A = parent, B = follower, so the link offset is ``x_i - x_p``) every ``interval_s``; a link that is
down gives no measurement and the follower's filter predicts through the gap.

Time transfer down the tree: follower ``i`` corrects its clock by ``c_i = eps_hat_i + c_p`` (the
leader's ``c = 0``), so its time error to the leader is ``x_i - c_i - x_L`` and to true time
``x_i - c_i``. In the ``consensus`` variant followers also exchange over peer links (simulated with the same
link model, each with its own filter) and average the corrections their peers imply (one averaging
round per exchange, ATS-style; seed ref. [12]), anchored to the tree estimate with weight
``leader_weight``.

:func:`follow_leader` is the one call the main job uses: a leader clock series in, each follower's time
error to the leader and to true time out.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from chronofuse.estimation.interface import FrozenResult
from chronofuse.models.kinematics import radial_geometry
from chronofuse.models.link import LinkModel, node_clock_error_s, simulate_exchanges
from chronofuse.models.oscillator_presets import preset
from chronofuse.seeding import child_seed, root_seed
from chronofuse.sync.base import measurement_array
from chronofuse.sync.registry import make_algorithm
from chronofuse.validation import check_array, check_choice, check_scalar

__all__ = ["SwarmResult", "leader_clock_s", "link_availability", "follow_leader"]


@dataclass(frozen=True)
class SwarmResult(FrozenResult):
    """``t_s`` (steps,); ``to_leader_s`` and ``to_true_s`` (followers, steps): each follower's corrected
    time error to the leader and to true time; ``leader_s`` (steps,): the leader's own error to true
    time; ``link_up`` (followers, steps); ``parents`` (followers,) (0 = leader, i = follower i)."""

    t_s: np.ndarray
    to_leader_s: np.ndarray
    to_true_s: np.ndarray
    leader_s: np.ndarray
    link_up: np.ndarray
    parents: np.ndarray


def leader_clock_s(steps: int, interval_s: float, seed, *, oscillator: str = "ocxo", gnss_sigma_s: float = 1e-9,
                   loss_start_s: float | None = None, loss_duration_s: float = 3600.0) -> np.ndarray:
    """A GNSS-disciplined leader's time error, s, shape (steps + 2,): white ``gnss_sigma_s`` while GNSS is
    good; from ``loss_start_s`` for ``loss_duration_s`` the oscillator runs free (holdover: its own
    noise and aging from the loss instant, no initial frequency error); then disciplined again."""
    base = root_seed(seed)
    m = int(steps) + 2
    x = gnss_sigma_s * np.random.default_rng(child_seed(base, 0)).standard_normal(m)
    if loss_start_s is not None:
        free = node_clock_error_s(preset(oscillator), steps, interval_s, child_seed(base, 1), 1)[0]
        t = np.arange(m) * interval_s
        lost = (t >= loss_start_s) & (t < loss_start_s + loss_duration_s)
        if lost.any():
            i0 = int(np.argmax(lost))
            x[lost] = x[i0] + free[lost] - free[i0]
    return x


def link_availability(links: int, steps: int, seed, *, mean_up_s: float = np.inf, mean_down_s: float = 10.0,
                      interval_s: float = 1.0) -> np.ndarray:
    """Links that come and go: a two-state Markov chain per link (mean up and down times, s); shape
    (links, steps), True = up; all up when ``mean_up_s`` is infinite."""
    if not np.isfinite(mean_up_s):
        return np.ones((links, steps), dtype=bool)
    check_scalar(mean_up_s, "mean_up_s", min_val=0.0, include_min=False)
    check_scalar(mean_down_s, "mean_down_s", min_val=0.0, include_min=False)
    p_fail, p_fix = min(1.0, interval_s / mean_up_s), min(1.0, interval_s / mean_down_s)
    u = np.random.default_rng(root_seed(seed)).random((links, steps))
    up = np.ones((links, steps), dtype=bool)  # up at the start (a filter needs a first exchange)
    for k in range(1, steps):
        up[:, k] = np.where(up[:, k - 1], u[:, k] >= p_fail, u[:, k] < p_fix)
    return up


def follow_leader(leader_s, *, interval_s: float = 1.0, parents=(0, 0, 0), distances_m=(20e3, 50e3, 80e3),
                  velocities_m_s=(5.0, -8.0, 12.0), link: LinkModel | None = None, oscillator: str = "ocxo",
                  algorithm: str = "ours-doppler", urt_fixed_s: float | None = None, link_up=None,
                  topology: str = "tree", leader_weight: float = 0.5, seed=0) -> SwarmResult:
    """Followers tracking the leader over two-way links (module docstring).

    Parameters
    ----------
    leader_s : array of shape (steps + 2,)
        The leader's time error to true time, s, every ``interval_s`` from t = 0.
    parents : sequence of int
        Follower ``i`` (1-based) follows ``parents[i-1]`` (0 = the leader); parents come first.
    distances_m, velocities_m_s : sequences
        Initial distance and radial velocity of each follower from its parent.
    link : LinkModel
        Default: the seed's link with ``interval_s``.
    urt_fixed_s : float
        The calibrated fixed URT (default: the link's, i.e. a perfect GNSS-time calibration).
    link_up : bool array (followers, steps), optional
        Availability of each follower's link to its parent (default: always up).
    topology : {"tree", "consensus"}
    """
    x_l = check_array(leader_s, "leader_s", ndim=1)
    steps = x_l.size - 2
    check_scalar(steps, "steps", min_val=2, integer=True)
    check_choice(topology, "topology", ("tree", "consensus"))
    parents = np.asarray(parents, dtype=np.int64)
    n = parents.size
    if np.any(parents < 0) or np.any(parents >= np.arange(1, n + 1)):
        raise ValueError(f"parents == {parents.tolist()}, must be 0 (leader) or an earlier follower")
    link = LinkModel(interval_s=interval_s) if link is None else link
    up = np.ones((n, steps), dtype=bool) if link_up is None else np.asarray(link_up, dtype=bool)
    if up.shape != (n, steps):
        raise ValueError(f"link_up has shape {up.shape}, must be ({n}, {steps})")
    base = root_seed(seed)
    osc = preset(oscillator)
    xf = node_clock_error_s(osc, steps, interval_s, child_seed(base, 0), n)
    clocks = np.vstack([x_l[None, :], xf])  # node 0 = leader
    tp = link.urt_fixed_s if urt_fixed_s is None else urt_fixed_s
    eps_hat = np.empty((n, steps))
    for i in range(n):
        a, b = radial_geometry(distances_m[i], velocities_m_s[i])
        ex = simulate_exchanges(a, b, clocks[parents[i]][None, :], clocks[i + 1][None, :], link, steps,
                                child_seed(base, 1, i))
        Z = measurement_array(ex)
        Z[0, ~up[i], :] = np.nan
        alg = make_algorithm(algorithm, link, steps=steps, urt_mode="calibrated", urt_fixed_s=tp,
                             oscillator=osc).fit()
        eps_hat[i] = alg.run(Z).offset_s[0]
    corr = np.zeros((n + 1, steps))
    for i in range(n):
        corr[i + 1] = eps_hat[i] + corr[parents[i]]
    if topology == "consensus":
        corr = _consensus(corr, clocks, up, leader_weight, link, osc, algorithm, tp, distances_m, velocities_m_s,
                          steps, child_seed(base, 2))
    x = clocks[1:, :steps] - corr[1:]
    return SwarmResult(t_s=np.arange(steps) * interval_s, to_leader_s=x - x_l[:steps], to_true_s=x,
                       leader_s=x_l[:steps].copy(), link_up=up, parents=parents)


def _consensus(corr, clocks, up, leader_weight, link, osc, algorithm, tp, distances_m, velocities_m_s, steps,
               base):
    """One averaging round per exchange. Followers ``i < j`` also exchange over a peer link (distance
    ``|d_i - d_j| + 10 km``, radial velocity ``v_j - v_i``), whose filter estimates ``x_j - x_i``; follower
    ``i``'s correction becomes ``w c_i + (1 - w) mean_j (c_j + e_ij)`` (``e_ij`` the estimate of
    ``x_i - x_j``, ``w = leader_weight``), over the peers whose links are up, while its own link is up."""
    n = corr.shape[0] - 1
    rel = np.full((n, n, steps), np.nan)  # rel[i, j] estimates x_i - x_j
    for i in range(n):
        for j in range(i + 1, n):
            a, b = radial_geometry(abs(distances_m[i] - distances_m[j]) + 10e3, velocities_m_s[j] - velocities_m_s[i])
            ex = simulate_exchanges(a, b, clocks[i + 1][None, :], clocks[j + 1][None, :], link, steps,
                                    child_seed(base, i, j))
            Z = measurement_array(ex)
            peer_up = up[i] & up[j]
            Z[0, ~peer_up, :] = np.nan
            alg = make_algorithm(algorithm, link, steps=steps, urt_mode="calibrated", urt_fixed_s=tp,
                                 oscillator=osc).fit()
            est = alg.run(Z).offset_s[0]
            rel[j, i] = np.where(peer_up, est, np.nan)
            rel[i, j] = -rel[j, i]
    out = corr.copy()
    for i in range(n):
        via = np.array([corr[j + 1] + rel[i, j] for j in range(n) if j != i])
        if via.size == 0:
            continue
        heard = np.isfinite(via)
        count = heard.sum(axis=0)
        peers = np.where(count > 0, np.where(heard, via, 0.0).sum(axis=0) / np.maximum(count, 1), np.nan)
        blended = np.where(np.isnan(peers), corr[i + 1], leader_weight * corr[i + 1] + (1.0 - leader_weight) * peers)
        out[i + 1] = np.where(up[i], blended, corr[i + 1])
    return out
