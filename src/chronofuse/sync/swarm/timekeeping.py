"""Each node's time from its links' estimates: down a tree from the leader, with holdover and failover.

Every link ``l = (a, b)`` runs its own filter (``doppler-kf``) on its own exchanges, whatever the topology
does: its estimate ``e_l ~ x_b - x_a`` and uncertainty ``sigma_l`` exist at every exchange, measured while the
link is up and predicted by the filter while it is down. A node's correction to the network's time is
then a sum along a path of links from the leader::

    c_i = sum over (l, s) in path_i of s e_l,     sigma_i^2 = sum sigma_l^2,

``s = +1`` when the path crosses ``l`` from ``a`` to ``b``. At each exchange the path is the breadth-first
tree from the leader over the links that are up, between alive nodes, and not in FAULT (so peer links
carry time whenever a node's first link is down: they are independent of it). A node that has no such
path keeps the last path it had, frozen: its links' filters predict through their gaps, so it is in
**holdover** on that path, with the uncertainty the filters give. When the leader is lost, every node is in
holdover on its path to the old leader; the new leader (:mod:`~chronofuse.sync.swarm.election`) keeps its
own frozen path as its correction, so the network's time goes on through the loss, and the others join it.
A leader with GNSS time defines the network's time itself (empty path).

``consensus``: after the tree, each connected follower also averages what its other up neighbours imply,
``c_i <- w c_i + (1 - w) mean_j (c_j + s e_l)`` (one Jacobi round per exchange, as ATS-like protocols do),
anchored to the tree with weight ``w``; its uncertainty is kept at the tree's (conservative).

States per node and exchange: the leader ``LEADER``; a follower with a path ``LOCKED`` once its own part of
``sigma_i`` (without the leader's, ``sqrt(sigma_i^2 - sigma_root^2)``: a new leader's frozen path is common to
all) has stayed below ``lock_sigma_s`` for ``lock_hold_s``, else ``ACQUIRING``; without a path ``HOLDOVER`` (``FAULT`` if
one of its links was flagged by the URT monitor). A node cut off before it locked is in HOLDOVER, with the
large uncertainty of a filter that had not converged.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import breadth_first_order

from chronofuse.estimation.interface import FrozenResult
from chronofuse.sync.states import ACQUIRING, FAULT, HOLDOVER, LOCKED, NodeStateConfig
from chronofuse.validation import check_array, check_choice

__all__ = ["LEADER", "SwarmTime", "compose_network_time"]

#: A node that leads (PTP's MASTER state).
LEADER = 4


@dataclass(frozen=True)
class SwarmTime(FrozenResult):
    """``correction_s``, ``sigma_s`` (nodes, steps): each node's estimate of its clock minus the network's
    time and its 1-sigma; ``state`` (nodes, steps) int codes; ``parent`` (nodes, steps) (-1: none);
    ``hops`` (nodes, steps) (path length, -1: none); ``leader`` (steps,) (-1: none)."""

    correction_s: np.ndarray
    sigma_s: np.ndarray
    state: np.ndarray
    parent: np.ndarray
    hops: np.ndarray
    leader: np.ndarray


def compose_network_time(links, estimate_s, sigma_s, usable, leader, alive, *, gnss=None, link_fault=None,
                         topology: str = "tree", leader_weight: float = 0.5,
                         states: NodeStateConfig = NodeStateConfig(), interval_s: float = 1.0) -> SwarmTime:
    """Compose link estimates into node times (module docstring).

    ``links`` (L, 2); ``estimate_s``, ``sigma_s`` (L, steps) from the links' filters; ``usable`` (L, steps)
    bool: the link was up and measured; ``leader`` (steps,); ``alive`` (n, steps); ``gnss`` (n, steps) bool:
    the node has GNSS time (a leader with it anchors the network's time); ``link_fault`` (L, steps): the
    link's URT monitor flagged it.
    """
    check_choice(topology, "topology", ("tree", "consensus"))
    links = np.asarray(links, dtype=np.int64)
    est = check_array(estimate_s, "estimate_s", ndim=2, allow_nan=True)
    sig = check_array(sigma_s, "sigma_s", ndim=2, allow_nan=True)
    n, steps = np.asarray(alive).shape
    gnss = np.zeros((n, steps), dtype=bool) if gnss is None else np.asarray(gnss, dtype=bool)
    fault = np.zeros(est.shape, dtype=bool) if link_fault is None else np.asarray(link_fault, dtype=bool)
    corr = np.full((n, steps), np.nan)
    sigma = np.full((n, steps), np.nan)
    state = np.full((n, steps), HOLDOVER, dtype=np.int64)
    parent = np.full((n, steps), -1, dtype=np.int64)
    hops = np.full((n, steps), -1, dtype=np.int64)
    paths: list[tuple | None] = [None] * n  # each node's current (or frozen) path: ((link, sign), ...)
    lookup = {}
    for l, (a, b) in enumerate(links):
        lookup.setdefault((int(a), int(b)), l)
    root_path: tuple = ()
    root_prev = -1
    below = np.zeros(n)
    var = sig**2
    for k in range(steps):
        root = int(leader[k])
        ok = usable[:, k] & ~fault[:, k] & alive[links[:, 0], k] & alive[links[:, 1], k]
        reached = np.zeros(n, dtype=bool)
        if root >= 0:
            if root != root_prev:
                root_path = () if (gnss[root, k] or paths[root] is None) else paths[root]
                root_prev = root
            elif gnss[root, k]:
                root_path = ()
            paths[root] = root_path
            order, pred = _tree(n, links[ok], root)
            reached[order] = True
            c_root = sum(s * est[l, k] for l, s in root_path)
            v_root = sum(var[l, k] for l, _ in root_path)
            corr[root, k], sigma[root, k], hops[root, k] = c_root, np.sqrt(v_root), len(root_path)
            for node in order[1:]:  # down the tree: c_i = c_p + s e_l, sigma_i^2 = sigma_p^2 + sigma_l^2
                p = int(pred[node])
                l = lookup[(min(p, int(node)), max(p, int(node)))]
                s = 1 if links[l, 0] == p else -1
                paths[node] = paths[p] + ((l, s),)
                parent[node, k] = p
                corr[node, k] = corr[p, k] + s * est[l, k]
                sigma[node, k] = np.sqrt(sigma[p, k] ** 2 + var[l, k])
                hops[node, k] = hops[p, k] + 1
        for i in np.flatnonzero(~reached):  # holdover on the frozen path: its links' filters predict
            if paths[i] is not None:
                corr[i, k] = sum(s * est[l, k] for l, s in paths[i])
                sigma[i, k] = np.sqrt(sum(var[l, k] for l, _ in paths[i]))
        if topology == "consensus" and root >= 0:
            corr[:, k] = _consensus_round(corr[:, k], links, est[:, k], ok, reached, parent[:, k], root, leader_weight)
        # Locked is a follower's claim about its time against the leader's: the uncertainty of a leader in
        # holdover on its frozen path (common to every follower) is in sigma_s, not in the claim.
        own = np.sqrt(np.maximum(sigma[:, k] ** 2 - (sigma[root, k] ** 2 if root >= 0 else 0.0), 0.0))
        below = np.where(reached & (own <= states.lock_sigma_s), below + interval_s, 0.0)
        state[:, k] = np.where(reached, np.where(below >= states.lock_hold_s, LOCKED, ACQUIRING), HOLDOVER)
        if root >= 0:
            state[root, k] = LEADER
        faulty_node = np.zeros(n, dtype=bool)
        faulty_node[links[fault[:, k], 0]] = True
        faulty_node[links[fault[:, k], 1]] = True
        state[:, k] = np.where(~reached & faulty_node & (state[:, k] == HOLDOVER), FAULT, state[:, k])
        state[~alive[:, k], k] = HOLDOVER
        corr[~alive[:, k], k] = np.nan  # a node that left the swarm has no time in it
        sigma[~alive[:, k], k] = np.nan
    return SwarmTime(correction_s=corr, sigma_s=sigma, state=state, parent=parent, hops=hops,
                     leader=np.asarray(leader, dtype=np.int64).copy())


def _tree(n: int, edges: np.ndarray, root: int):
    """Breadth-first order from ``root`` over ``edges`` (undirected) and each node's predecessor."""
    if edges.size == 0:
        return np.array([root]), np.full(n, -9999)
    rows = np.concatenate([edges[:, 0], edges[:, 1]])
    cols = np.concatenate([edges[:, 1], edges[:, 0]])
    graph = csr_matrix((np.ones(rows.size), (rows, cols)), shape=(n, n))
    return breadth_first_order(graph, root, directed=False, return_predecessors=True)


def _consensus_round(c, links, e, ok, reached, parent, root, w):
    """One averaging round over the up peer links of connected followers (module docstring)."""
    out = c.copy()
    total = np.zeros(c.size)
    count = np.zeros(c.size)
    for l in np.flatnonzero(ok):
        a, b = int(links[l, 0]), int(links[l, 1])
        if not (reached[a] and reached[b]):
            continue
        if parent[b] != a:  # b hears a over a peer link: c_b ~ c_a + e
            total[b] += c[a] + e[l]
            count[b] += 1
        if parent[a] != b:
            total[a] += c[b] - e[l]
            count[a] += 1
    heard = (count > 0) & reached
    heard[root] = False
    out[heard] = w * c[heard] + (1.0 - w) * total[heard] / count[heard]
    return out
