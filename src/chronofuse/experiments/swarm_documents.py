"""The documents ``chronofuse swarm run`` and ``chronofuse swarm network`` print: swarm results with times in
ns at the edge (SI inside, as everywhere in the library).

:func:`link_report` turns :func:`chronofuse.experiments.swarm.run_link`'s result into the ``run`` document
(RMSE and its ratio to the bound with their intervals); :func:`network_document` runs a swarm
(:mod:`chronofuse.experiments.swarm_network`) and summarizes each node: its state, uncertainty, parent and
time error to the leader (RMS, percentiles, max, MTIE and TDEV against an ITU-T mask) and to true time.
"""

from __future__ import annotations

import numpy as np

from chronofuse.experiments.swarm_network import SwarmScenario, run_swarm
from chronofuse.sync.metrics import overhead, time_error_statistics
from chronofuse.sync.states import STATE_NAMES
from chronofuse.sync.swarm.timekeeping import LEADER

__all__ = ["link_report", "network_document"]

_NAMES = {**STATE_NAMES, LEADER: "leader"}


def link_report(res: dict) -> dict:
    """``run_link``'s result with times in ns at the edge, as the CLI prints it."""
    ns = lambda d: {k: v * 1e9 for k, v in d.items()}  # noqa: E731
    return {
        "rmse_ns": ns(res["rmse_s"]),
        "rmse_ci_ns": {k: [v[0] * 1e9, v[1] * 1e9] for k, v in res["rmse_ci_s"].items()},
        "ratio_to_bound": res["ratio"],
        "ratio_ci": res["ratio_ci"],
        "bound_ns": {"rms": res["bound_s"]["rms"] * 1e9, "final": res["bound_s"]["final"] * 1e9},
        "bound_scored_ns": ns(res["bound_rms_s"]),
        "true_offset_s": res.get("true_offset_s"),
        "convergence_epochs": res["convergence_epochs"],
        "unscored_trials": res["unscored_trials"],
        "convergence_threshold_ns": res["threshold_s"] * 1e9,
        "robustness": {k: {"delta_rmse_ns": v["delta_rmse_s"] * 1e9, "recovery_epochs": v["recovery_epochs"]}
                       for k, v in res["robustness"].items()},
        "calibration": {"urt_error_rms_ns": res["calibration"]["urt_error_rms_s"] * 1e9,
                        "stated_sigma_rms_ns": res["calibration"]["stated_sigma_rms_s"] * 1e9},
        "overhead": overhead(res["scenario"]["link"]["interval_s"]),
        "urt_mode": res["urt_mode"],
        "trials": res["trials"],
        "scenario": res["scenario"],
    }


def network_document(sc: SwarmScenario, *, seed: int, scheduler: str | None = "serial", mask: str | None = "prtc-b") -> dict:
    """Run the swarm ``sc`` and summarize it (module docstring); ``mask`` names the ITU-T mask the
    followers' time error to the leader is checked against (None: no mask)."""
    run = run_swarm(sc, seed, scheduler=scheduler)
    t = run.time
    to_leader = run.to_leader_s()
    rate = 1.0 / sc.interval_s
    lead = t.leader
    changes = [{"exchange": int(k), "leader": int(lead[k])} for k in range(1, lead.size) if lead[k] != lead[k - 1]]
    nodes = []
    for i in range(sc.nodes):
        te = np.where(lead != i, to_leader[i], np.nan)
        row = {"node": i, "oscillator": sc.oscillator_of(i), "state_end": _NAMES[int(t.state[i, -1])],
               "state_seconds": {_NAMES[int(c)]: float(np.sum(t.state[i] == c) * sc.interval_s)
                                 for c in np.unique(t.state[i])},
               "sigma_end_ns": _ns(t.sigma_s[i, -1]), "parent_end": int(t.parent[i, -1]),
               "hops_end": int(t.hops[i, -1]), "to_true_end_ns": _ns(run.to_true_s[i, -1])}
        if np.isfinite(te).sum() >= 8:
            stats = time_error_statistics(te, rate, mask)
            row["to_leader"] = {k[:-2] + "_ns": v * 1e9 for k, v in stats.items() if k.endswith("_s")}
            row["mtie"] = {"tau_s": stats["mtie"]["tau_s"], "mtie_ns": [v * 1e9 for v in stats["mtie"]["mtie_s"]]}
            row["tdev"] = {"tau_s": stats["tdev"]["tau_s"], "tdev_ns": [v * 1e9 for v in stats["tdev"]["tdev_s"]]}
            row["mask"] = stats.get("mask")
        nodes.append(row)
    return {"nodes": sc.nodes, "links": int(run.links.shape[0]), "steps": sc.steps, "interval_s": sc.interval_s,
            "topology": sc.topology, "leader_changes": changes, "link_up_fraction": float(run.usable.mean()),
            "per_node": nodes, "scenario": {k: v for k, v in sc.__dict__.items() if k not in ("prior", "calibration")}
            | {"prior": sc.prior.model_dump(), "calibration": sc.calibration.model_dump()}}


def _ns(x) -> float | None:
    return None if not np.isfinite(x) else float(x) * 1e9
