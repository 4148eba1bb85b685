"""The documents ``chronofuse swarm run`` and ``chronofuse swarm network`` print: swarm results with times in
ns at the edge (SI inside, as everywhere in the library).

:func:`link_report` turns :func:`chronofuse.experiments.swarm.run_link`'s result into the ``run`` document;
:func:`network_document` runs a leader and its followers (:mod:`chronofuse.experiments.swarm_network`) with
the per-part seeds of one root seed and summarizes each follower's time error (RMS and max, ns).
"""

from __future__ import annotations

import numpy as np

from chronofuse.experiments.swarm_network import follow_leader, leader_clock_s, link_availability
from chronofuse.models.link import LinkModel
from chronofuse.seeding import child_seed, root_seed
from chronofuse.sync.metrics import overhead

__all__ = ["link_report", "network_document"]


def link_report(res: dict) -> dict:
    """``run_link``'s result with times in ns at the edge, as the CLI prints it."""
    return {
        "rmse_ns": {k: v * 1e9 for k, v in res["rmse_s"].items()},
        "pcrb_ns": {k: v * 1e9 for k, v in res["pcrb_s"].items()},
        "convergence_epochs": res["convergence_epochs"],
        "convergence_threshold_ns": res["threshold_s"] * 1e9,
        "robustness": {k: {"delta_rmse_ns": v["delta_rmse_s"] * 1e9, "recovery_epochs": v["recovery_epochs"]}
                       for k, v in res["robustness"].items()},
        "overhead": overhead(res["scenario"]["link"]["interval_s"]),
        "urt_mode": res["urt_mode"],
        "urt_fixed_estimate_ns": res["urt_fixed_estimate_s"] * 1e9,
        "trials": res["trials"],
        "scenario": res["scenario"],
    }


def network_document(*, followers: int, topology: str, duration_s: float, interval_s: float,
                     gnss_loss_at_s: float, gnss_loss_for_s: float, mean_up_s: float, mean_down_s: float,
                     snr_db: float, oscillator: str, seed: int) -> dict:
    """A leader and ``followers`` over ``duration_s``: each follower's time error to the leader and to true
    time (RMS and max, ns), through the leader's GNSS loss (from ``gnss_loss_at_s`` for ``gnss_loss_for_s``;
    < 0: never) and links up and down for exponential times of means ``mean_up_s``/``mean_down_s``.

    ``topology``: ``"tree"`` (star: all follow the leader), ``"chain"`` (follower ``i`` follows ``i - 1``)
    or ``"consensus"`` (star plus peer averaging). Seeds: child 0 of ``seed`` the leader clock, 1 the link
    availability, 2 the followers' distances U[10, 80] km and radial velocities U[-10, 10] m/s, 3 the run.
    Bad parameters raise ``ValueError`` naming them (:mod:`chronofuse.validation`).
    """
    steps = int(round(duration_s / interval_s))
    base = root_seed(seed)
    link = LinkModel(interval_s=interval_s, snr_db=snr_db)
    leader = leader_clock_s(steps, interval_s, child_seed(base, 0), oscillator=oscillator,
                            loss_start_s=None if gnss_loss_at_s < 0 else gnss_loss_at_s,
                            loss_duration_s=gnss_loss_for_s)
    up = link_availability(followers, steps, child_seed(base, 1), mean_up_s=mean_up_s, mean_down_s=mean_down_s,
                           interval_s=interval_s)
    parents = tuple(range(followers)) if topology == "chain" else (0,) * followers
    rng = np.random.default_rng(child_seed(base, 2))
    res = follow_leader(leader, interval_s=interval_s, parents=parents,
                        distances_m=tuple(rng.uniform(10e3, 80e3, followers)),
                        velocities_m_s=tuple(rng.uniform(-10.0, 10.0, followers)), link=link,
                        oscillator=oscillator, link_up=up, topology="consensus" if topology == "consensus" else "tree",
                        seed=child_seed(base, 3))

    def rms(a):
        return [float(v) for v in np.atleast_1d(np.sqrt(np.mean(a**2, axis=-1)) * 1e9)]

    return {"topology": topology, "followers": followers, "steps": steps, "interval_s": interval_s,
            "leader_to_true_rms_ns": rms(res.leader_s), "leader_to_true_max_ns": float(np.abs(res.leader_s).max() * 1e9),
            "to_leader_rms_ns": rms(res.to_leader_s), "to_true_rms_ns": rms(res.to_true_s),
            "to_leader_max_ns": [float(v) for v in np.abs(res.to_leader_s).max(axis=1) * 1e9],
            "link_up_fraction": [float(v) for v in res.link_up.mean(axis=1)],
            "parents": [int(p) for p in res.parents]}
