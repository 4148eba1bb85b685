"""The main job's second half: the scenario's OCXO disciplined to its receivers through a GNSS outage, and
a small swarm that keeps the disciplined leader's time over two-way links.

Orchestration only: the disciplined oscillator is :func:`chronofuse.experiments.gnssdo.simulate_gnssdo`
(the default controller, picked by measurement), the swarm
:func:`chronofuse.experiments.swarm_network.follow_leader`; the figures come from
:mod:`chronofuse.report.gnssdo` and :mod:`chronofuse.report.swarm_follow`.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from chronofuse.experiments.gnssdo import SETTLE_S, GnssdoSetup, evaluate, simulate_gnssdo
from chronofuse.experiments.scenario import Scenario, ScenarioError
from chronofuse.experiments.swarm_network import follow_leader

__all__ = ["discipline_and_swarm", "outage_window_s", "MIN_DURATION_S"]

#: The shortest run the disciplining stage takes (the controller's settling time, twice).
MIN_DURATION_S = 2 * SETTLE_S


def _rms_ns(x: np.ndarray) -> float:
    return float(np.sqrt(np.nanmean(x**2)) * 1e9)


def outage_window_s(scn: Scenario) -> tuple[float, float]:
    """The GNSS outage ``(start, length)`` of a scenario, its defaults filled in; a window that does not fit in
    the run is refused naming the key."""
    d, duration = scn.discipline, float(scn.duration_s)
    start = duration / 2 if d.outage_start_s is None else float(d.outage_start_s)
    length = min(3600.0, duration / 4) if d.outage_s is None else float(d.outage_s)
    if start + length > duration:
        raise ScenarioError(f"discipline.outage_start_s + outage_s = {start + length:g} s, must be within the "
                            f"run's duration_s = {duration:g} s")
    return start, length


def discipline_and_swarm(scn: Scenario, out: Path, say: Callable[[str], None]) -> tuple[dict, list[Path]]:
    """Run both stages for ``scn``; returns the summary sections and the files written into ``out``.

    A run shorter than :data:`MIN_DURATION_S` has no room for the loop to settle: the section then says so.
    """
    from chronofuse.report.gnssdo import write_report
    from chronofuse.report.swarm_follow import plot_followers

    if scn.duration_s < MIN_DURATION_S:
        return {"discipline": {"skipped": f"the run ({scn.duration_s:g} s) is shorter than the {MIN_DURATION_S:g} s "
                                          "a disciplined oscillator needs to settle"}}, []
    d = scn.discipline
    start, length = outage_window_s(scn)
    setup = GnssdoSetup(scenario=scn.receivers.scenario, controller=d.controller, receivers=scn.receivers.count,
                        duration_s=int(round(scn.duration_s)), seed=scn.seed, oscillator=scn.oscillator.preset,
                        outage_start_s=start if length > 0 else None, outage_s=length)
    say(f"disciplining the {setup.oscillator} ({setup.controller}) through a {length:g} s GNSS outage")
    sim = simulate_gnssdo(setup, say)
    summary = evaluate(sim)
    sub = out / "discipline"
    sub.mkdir(parents=True, exist_ok=True)
    files = [sub / name for name in write_report(sim, summary, sub)]
    sections = {"discipline": {k: summary[k] for k in summary if k != "state_changes_trial0"}}
    if scn.swarm.followers > 0:
        say(f"{scn.swarm.followers} followers keeping the leader's time over two-way links")
        leader = np.asarray(sim["run"].phase_s[0, 1:])  # after the first jam sync (the start-up phase step)
        n = scn.swarm.followers
        swarm = follow_leader(np.r_[leader, leader[-1], leader[-1]], interval_s=1.0, parents=(0,) * n,
                              distances_m=tuple(20e3 + 30e3 * i for i in range(n)),
                              velocities_m_s=tuple((-1) ** i * (5.0 + 3.0 * i) for i in range(n)),
                              algorithm=scn.swarm.algorithm, topology=scn.swarm.topology, seed=scn.seed + 1)
        outage = (swarm.t_s >= start - 1) & (swarm.t_s < start + length - 1)
        sections["swarm"] = {
            "algorithm": scn.swarm.algorithm, "topology": scn.swarm.topology, "followers": n,
            "leader_to_true_rms_ns": _rms_ns(swarm.leader_s),
            "leader_to_true_in_outage_max_ns": float(np.max(np.abs(swarm.leader_s[outage])) * 1e9) if outage.any() else None,
            "to_leader_rms_ns": [_rms_ns(e) for e in swarm.to_leader_s],
            "to_true_rms_ns": [_rms_ns(e) for e in swarm.to_true_s],
            "to_leader_in_outage_rms_ns": [_rms_ns(e[outage]) for e in swarm.to_leader_s] if outage.any() else None,
        }
        files.append(plot_followers(swarm, outage, out / "swarm.png"))
    return sections, files
