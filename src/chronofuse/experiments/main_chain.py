"""The main job's second half: the scenario's OCXO disciplined to its receivers through a GNSS outage, and
a small swarm that keeps the disciplined leader's time over two-way links.

Orchestration only: the disciplined oscillator is :func:`chronofuse.experiments.gnssdo.simulate_gnssdo`
(the default controller, picked by measurement), the swarm
:func:`chronofuse.experiments.swarm_network.follow_leader`; the figures come from
:mod:`chronofuse.report.gnssdo` and :mod:`chronofuse.report.swarm_follow`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path

import numpy as np

from chronofuse.experiments.gnssdo import SETTLE_S, GnssdoSetup, evaluate, scenario_environment, simulate_gnssdo
from chronofuse.experiments.scenario import Scenario, ScenarioError
from chronofuse.experiments.swarm_network import follow_leader
from chronofuse.models.environment import ReceiverEnvironment
from chronofuse.models.oscillator import OscillatorModel
from chronofuse.progress import within

#: The clock classes the disciplined output is checked against, besides the scenario's own mask.
OUTPUT_MASKS = ("prtc-a", "prtc-b", "g811")

__all__ = ["OUTPUT_MASKS", "discipline_and_swarm", "outage_window_s", "discipline_environment", "check_disciplinable",
           "MIN_DURATION_S"]

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


#: The followers' radial speeds (m/s) for runs up to a day; a longer run flies them slower, so that the
#: farthest one (80 km + 11 m/s x 1 day = 1,030 km, 3.4 ms of light time) stays inside the link's 4 ms reply slot.
FOLLOWER_SPEED_DAY_S = 86_400.0


def _follower_velocities_m_s(n: int, duration_s: float) -> tuple[float, ...]:
    scale = min(1.0, FOLLOWER_SPEED_DAY_S / float(duration_s))
    return tuple((-1) ** i * (5.0 + 3.0 * i) * scale for i in range(n))


def check_disciplinable(scn: Scenario) -> None:
    """Refuse, naming the key, what the disciplining stage cannot honour: a rate other than the 1PPS's 1 Hz
    and an outage outside the run (called before anything is simulated or written)."""
    if not scn.discipline.enabled or scn.duration_s < MIN_DURATION_S:
        return
    if scn.rate_hz != 1.0:
        raise ScenarioError(f"rate_hz: {scn.rate_hz:g} Hz with discipline enabled; the loop runs on the 1PPS, one "
                            "sample per second (set rate_hz = 1, or discipline.enabled = false)")
    outage_window_s(scn)


def discipline_environment(scn: Scenario) -> ReceiverEnvironment:
    """The receivers' environment of a scenario: its ``receivers.scenario`` with the discipline's GNSS outage
    (every receiver jammed) when disciplining is on and the outage has a length. The report's receivers and
    the disciplined ones are this one realisation (the same seeds, :func:`~chronofuse.experiments.gnssdo.simulate_gnssdo`)."""
    env = scenario_environment(scn.receivers.scenario, float(scn.duration_s))
    if not scn.discipline.enabled or scn.duration_s < MIN_DURATION_S:
        return env
    start, length = outage_window_s(scn)
    if length <= 0:
        return env
    return dataclasses.replace(env, jamming_start_s=start, jamming_duration_s=length)


def discipline_and_swarm(scn: Scenario, out: Path, say: Callable[[str], None],
                         oscillator: OscillatorModel | None = None, span: tuple[float, float] = (0.0, 1.0)
                         ) -> tuple[dict, list[Path]]:
    """Run both stages for ``scn``; returns the summary sections, the files written into ``out`` and the
    disciplined output's MTIE and TDEV (``{"mtie": Deviation, "tdev": Deviation}``, empty when skipped).

    The disciplined 1PPS (trial 0, from :data:`~chronofuse.experiments.gnssdo.SETTLE_S` on, the outage in
    holdover included) is checked against the scenario's mask and :data:`OUTPUT_MASKS`
    (``sections["discipline"]["masks"]``: name -> ``ClockVerdict.to_dict()``).

    A run shorter than :data:`MIN_DURATION_S` has no room for the loop to settle: the section then says so.
    ``oscillator``: the scenario's oscillator with its overrides (default: the preset). The loop runs on the
    1PPS: a scenario at another rate is refused naming ``rate_hz``.
    """
    from chronofuse.report.gnssdo import write_report
    from chronofuse.report.swarm_follow import plot_followers

    if scn.duration_s < MIN_DURATION_S:
        return {"discipline": {"skipped": f"the run ({scn.duration_s:g} s) is shorter than the {MIN_DURATION_S:g} s "
                                          "a disciplined oscillator needs to settle"}}, [], {}
    check_disciplinable(scn)
    d = scn.discipline
    start, length = outage_window_s(scn)
    setup = GnssdoSetup(scenario=scn.receivers.scenario, controller=d.controller, receivers=scn.receivers.count,
                        duration_s=int(round(scn.duration_s)), seed=scn.seed, oscillator=scn.oscillator.preset,
                        oscillator_model=oscillator, outage_start_s=start if length > 0 else None, outage_s=length)
    a, b = span
    stage = within(say, a, a + 0.4 * (b - a))  # the simulation; measuring it takes as long again
    stage(f"disciplining the {setup.oscillator} ({setup.controller}) through a {length:g} s GNSS outage")
    sim = simulate_gnssdo(setup, stage)
    say("measuring the disciplined output", a + 0.4 * (b - a))
    summary = evaluate(sim)
    sub = out / "discipline"
    sub.mkdir(parents=True, exist_ok=True)
    files = [sub / name for name in write_report(sim, summary, sub)]
    sections = {"discipline": {k: summary[k] for k in summary if k != "state_changes_trial0"}}
    from chronofuse.analysis import stability
    from chronofuse.analysis.masks import MASKS

    output = np.asarray(sim["run"].phase_s[0, int(SETTLE_S):], dtype=float)
    names = tuple(dict.fromkeys(((scn.analysis.mask,) if scn.analysis.mask else ()) + OUTPUT_MASKS))
    sections["discipline"]["masks"] = {m: MASKS[m].check(output, 1.0).to_dict() for m in names}
    sections["discipline"]["masks_record"] = (f"the disciplined 1PPS from {SETTLE_S:g} s (after settling) to the end, "
                                              f"{output.size} s, the {length:g} s outage in holdover included")
    curves = {stat: stability.compute(stat, output, 1.0, stability.tau_grid(scn.analysis.taus, output.size, 1.0, stat))
              for stat in ("mtie", "tdev")}
    if scn.swarm.followers > 0:
        say(f"{scn.swarm.followers} followers keeping the leader's time over two-way links", a + 0.9 * (b - a))
        leader = np.asarray(sim["run"].phase_s[0, 1:])  # after the first jam sync (the start-up phase step)
        n = scn.swarm.followers
        swarm = follow_leader(np.r_[leader, leader[-1], leader[-1]], interval_s=1.0, parents=(0,) * n,
                              distances_m=tuple(20e3 + 30e3 * i for i in range(n)),
                              velocities_m_s=_follower_velocities_m_s(n, scn.duration_s),
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
    return sections, files, curves
