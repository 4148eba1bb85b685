"""URT changes after calibration (orchestration only): how fast the monitor flags them, and how far the
output is off while it has not.

:func:`urt_change_run` runs ``doppler-kf`` on links whose reply delay changes at exchange ``onset`` (a step
of ``step_s`` or a ramp of ``ramp_s_per_s``), optionally with a GNSS time comparison of the two nodes every
``reference_every`` exchanges (white error ``reference_sigma_s`` per node). It returns each trial's detection
delay (exchanges after the onset; None if never flagged, negative if flagged before it: a false alarm) and
the output's bias while undetected: the error averaged over the trials not yet flagged, at each exchange
after the onset, its largest magnitude (``max_bias_s``).
"""

from __future__ import annotations

import numpy as np

from chronofuse.experiments.swarm import LinkScenario, calibrate_scenario, knowledge_of, simulate_scenario
from chronofuse.seeding import child_rng, child_seed, root_seed
from chronofuse.sync.base import measurement_array
from chronofuse.sync.registry import make_algorithm
from chronofuse.sync.states import FAULT

__all__ = ["urt_change_run", "urt_change_table"]


def urt_change_run(sc: LinkScenario, *, onset: int, step_s: float = 0.0, ramp_s_per_s: float = 0.0, trials: int = 30,
                   seed=0, reference_sigma_s: float | None = None, reference_every: int = 100) -> dict:
    """The detection delays and the bias while undetected (module docstring)."""
    steps = sc.exchanges
    k = np.arange(steps)
    change = np.where(k >= onset, step_s + ramp_s_per_s * (k - onset) * sc.link.interval_s, 0.0)
    base = root_seed(seed)
    ex, draw = simulate_scenario(sc, trials, child_seed(base, 0), urt_change_s=change)
    calib = calibrate_scenario(sc, draw, child_seed(base, 1))
    ref = None
    monitor = {}
    if reference_sigma_s is not None:
        monitor = {"reference_sigma_s": float(reference_sigma_s)}
        noise = np.vstack([child_rng(base, 2, i).standard_normal(steps) for i in range(trials)])
        ref = np.where(k % int(reference_every) == 0, ex.offset_s + reference_sigma_s * np.sqrt(2.0) * noise, np.nan)
    kf = make_algorithm("doppler-kf", knowledge_of(sc, calib), monitor=monitor).fit()
    res = kf.run(measurement_array(ex), ref)
    err = res.offset_s - ex.offset_s
    flagged = res.node_state == FAULT
    first = np.where(flagged.any(axis=1), flagged.argmax(axis=1), steps)
    undetected = k[None, :] < first[:, None]
    after = np.where(undetected, err, np.nan)[:, onset:]
    counted = np.isfinite(after).sum(axis=0)
    bias = np.where(counted > 0, np.nansum(after, axis=0) / np.maximum(counted, 1), np.nan)
    delays = [None if f == steps else int(f - onset) for f in first]
    return {"delays": delays, "max_bias_s": float(np.nanmax(np.abs(bias))) if np.isfinite(bias).any() else 0.0,
            "flagged": int(np.sum(first < steps)), "false_alarms": int(np.sum(first < onset)), "trials": int(trials),
            "interval_s": sc.link.interval_s}


def urt_change_table(seed: int = 0, trials: int = 30) -> list[dict]:
    """The cases docs/sync reports: a +-5 ns step with no reference, and a 1 ns/min ramp after 300 s of
    monitoring with GNSS references of 0.25, 0.5, 2 and 5 ns per node once a second."""
    rows = []
    for step in (5e-9, -5e-9):
        r = urt_change_run(LinkScenario(exchanges=1500), onset=1000, step_s=step, trials=trials, seed=seed)
        rows.append({"change": f"step {step * 1e9:+g} ns", "reference": "none", **r})
    for sigma in (0.25e-9, 0.5e-9, 2e-9, 5e-9):
        r = urt_change_run(LinkScenario(exchanges=50000), onset=30000, ramp_s_per_s=1e-9 / 60.0, trials=trials,
                           seed=seed, reference_sigma_s=sigma)
        rows.append({"change": "ramp 1 ns/min", "reference": f"{sigma * 1e9:g} ns per node, 1 Hz", **r})
    return rows
