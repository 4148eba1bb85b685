"""Which nodes talk: links to the ``k`` nearest neighbours within radio range.

A link joins ``i < j`` when one is among the other's ``k`` nearest neighbours and they are at most
``radio_range_m`` apart; nearest neighbours come from a k-d tree (:class:`scipy.spatial.cKDTree`), so
building the graph costs ``O(n log n)`` and the swarm has at most ``n k`` links, not ``n (n - 1) / 2``.
Over a run a link is usable only while its two nodes stay within range and its radio is up.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from chronofuse.validation import check_array, check_scalar

__all__ = ["neighbour_links", "in_range"]


def neighbour_links(positions_m, k: int, radio_range_m: float) -> np.ndarray:
    """Links ``(L, 2)`` (int, ``i < j``, sorted) between nodes at ``positions_m`` (n, 3)."""
    pos = check_array(positions_m, "positions_m", ndim=2)
    check_scalar(k, "k", min_val=1, integer=True)
    check_scalar(radio_range_m, "radio_range_m", min_val=0.0, include_min=False)
    n = pos.shape[0]
    if n < 2:
        return np.zeros((0, 2), dtype=np.int64)
    dist, idx = cKDTree(pos).query(pos, k=min(int(k) + 1, n))
    pairs = set()
    for i in range(n):
        for d, j in zip(dist[i, 1:], idx[i, 1:]):
            if np.isfinite(d) and d <= radio_range_m and j != i:
                pairs.add((min(i, int(j)), max(i, int(j))))
    return np.array(sorted(pairs), dtype=np.int64).reshape(-1, 2)


def in_range(positions_m, links, radio_range_m: float) -> np.ndarray:
    """Whether each link's nodes are within range at each epoch: positions (n, steps, 3) -> (L, steps)."""
    pos = check_array(positions_m, "positions_m", ndim=3)
    links = np.asarray(links, dtype=np.int64)
    return np.linalg.norm(pos[links[:, 1]] - pos[links[:, 0]], axis=-1) <= radio_range_m
