"""Leader election on clock quality, IEEE 1588's best-master comparison reduced to what a swarm needs.

Each node announces its quality every ``announce_interval_s``: ``(priority1, clock_class, clock_accuracy,
offset_scaled_log_variance, priority2, identity)``, compared lexicographically, lower is better (IEEE
1588-2019 clause 9.3.4, figure 34, without the steps-removed and port tie-breaks). The clock class follows
the node's time source: 6 while its GNSS time is good, 7 in holdover within specification, 248 when it
never had a time source. Accuracy and variance come from the oscillator's holdover (:data:`OSCILLATOR_QUALITY`):
its Allan deviation at 1000 s from the preset's noise and aging (``h0/(2 tau) + 2 ln2 h_-1 + (2 pi^2/3)
h_-2 tau + D^2 tau^2 / 2``), mapped to an IEEE 1588 Table 5 accuracy code and to
``offsetScaledLogVariance = 0x4000 + 256 log2(AVAR / 1e-22)`` rounded to a step of 256 (the standard's
log scaling; the reference level is ours). A leader that stops announcing is lost after
``announce_timeout`` intervals (linuxptp's ``announceReceiptTimeout``, default 3); the next best alive node
then leads, at the next announce: a new leader within ``(announce_timeout + 1) announce_interval_s``.
An announce travels over the radio links: a node alive but with every link cut is not heard (:func:`heard`),
so a leader cut off is replaced in the same time.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from chronofuse.models.oscillator_presets import PRESETS
from chronofuse.validation import check_scalar

__all__ = ["CLASS_GNSS", "CLASS_HOLDOVER", "CLASS_FREE", "OSCILLATOR_QUALITY", "ClockQuality", "elect",
           "heard", "leader_timeline"]

CLASS_GNSS, CLASS_HOLDOVER, CLASS_FREE = 6, 7, 248



def _holdover_avar(osc, tau_s: float = 1000.0) -> float:
    h = osc.h
    return (h.h0 / (2 * tau_s) + 2 * math.log(2) * h.hm1 + (2 * math.pi**2 / 3) * h.hm2 * tau_s
            + osc.drift_per_s**2 * tau_s**2 / 2)


def _quality(avar: float) -> tuple[int, int]:
    adev = math.sqrt(avar)
    accuracy = 0x21 if adev < 1e-12 else 0x22 if adev < 1e-11 else 0x25 if adev < 1e-10 else 0x31
    return accuracy, int(0x4000 + 256 * round(math.log2(avar / 1e-22))) & 0xFFFF


#: Oscillator preset -> (clockAccuracy code, offsetScaledLogVariance) of a node in holdover on it.
OSCILLATOR_QUALITY = {name: _quality(_holdover_avar(osc)) for name, osc in PRESETS.items()}


@dataclass(frozen=True, order=True)
class ClockQuality:
    """One announce's quality data set; ordering is the comparison (lower wins)."""

    priority1: int
    clock_class: int
    clock_accuracy: int
    offset_scaled_log_variance: int
    priority2: int
    identity: int


def elect(qualities: list[ClockQuality], alive) -> int:
    """The identity of the best alive node (``alive`` a bool per identity)."""
    best = [q for q in qualities if alive[q.identity]]
    if not best:
        raise ValueError("no node is alive to lead")
    return min(best).identity


def heard(alive, links, up) -> np.ndarray:
    """Whose announces reach the swarm (nodes, steps): a node alive with at least one link up to another alive
    node (``links`` (L, 2) node pairs, ``up`` (L, steps) radio availability). A leader whose every link is cut
    is lost to the others as one that left is (and leads again, if still the best, once it is heard); a swarm
    of one node hears itself."""
    alive = np.asarray(alive, dtype=bool)
    if alive.shape[0] == 1:
        return alive.copy()
    links = np.asarray(links, dtype=np.int64).reshape(-1, 2)
    both = np.asarray(up, dtype=bool) & alive[links[:, 0]] & alive[links[:, 1]]
    out = np.zeros(alive.shape, dtype=bool)
    for end in (0, 1):
        np.logical_or.at(out, links[:, end], both)
    return out & alive


def leader_timeline(qualities_at, alive, steps: int, interval_s: float, *, announce_interval_s: float = 1.0,
                    announce_timeout: int = 3) -> np.ndarray:
    """The leader's identity at each exchange (steps,), -1 while there is none.

    ``qualities_at(k)`` gives the list of :class:`ClockQuality` at exchange ``k``; ``alive`` (nodes, steps) says
    who is there. Elections happen at announce instants; a leader that is gone is noticed after
    ``announce_timeout`` announces and replaced at the next one.
    """
    check_scalar(announce_interval_s, "announce_interval_s", min_val=interval_s)
    check_scalar(announce_timeout, "announce_timeout", min_val=1, integer=True)
    every = max(1, int(round(announce_interval_s / interval_s)))
    out = np.full(int(steps), -1, dtype=np.int64)
    leader, gone_since = -1, None
    for k in range(int(steps)):
        if leader >= 0 and not alive[leader, k] and gone_since is None:
            gone_since = k
        if k % every == 0:
            if leader < 0:
                leader = elect(qualities_at(k), alive[:, k])
            elif gone_since is not None:
                if (k - gone_since) >= announce_timeout * every:
                    leader, gone_since = elect(qualities_at(k), alive[:, k]), None
            else:
                best = elect(qualities_at(k), alive[:, k])
                if qualities_at(k)[best] < qualities_at(k)[leader]:
                    leader = best
        out[k] = leader if gone_since is None else -1
    return out
