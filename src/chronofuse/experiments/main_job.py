"""The main job behind ``chronofuse run``: simulate a scenario and write its report folder.

For now the scenario is a free-running oscillator and a set of GNSS timing receivers (2.2).
The report holds the receivers' 1PPS time error (after the qErr correction the receiver reports), the
oscillator's free-running phase, their stability with the oscillator's theoretical ADEV, and the
receivers' MTIE/TDEV against an ITU-T mask. Later capabilities (disciplining, integrity, sync) extend
this same job.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from chronofuse.analysis import stability
from chronofuse.analysis.masks import MASKS
from chronofuse.analysis.metrics import gdop_over_5_fraction
from chronofuse.analysis.theory import adev_theory
from chronofuse.experiments.main_chain import check_disciplinable, discipline_and_swarm, discipline_environment
from chronofuse.experiments.scenario import Scenario
from chronofuse.models.oscillator import simulate_oscillator
from chronofuse.models.oscillator_presets import preset
from chronofuse.models.receiver import simulate_receivers
from chronofuse.report.html import run_page
from chronofuse.report.run_figures import write_run_figures
from chronofuse.report.jsonio import dumps

from chronofuse.progress import Progress, silent


@dataclass(frozen=True)
class RunReport:
    """What a run wrote and its headline numbers."""

    out_dir: Path
    summary: dict
    files: tuple[Path, ...]


def _oscillator_model(scn: Scenario):
    model = preset(scn.oscillator.preset)
    overrides = {k: v for k, v in scn.oscillator.model_dump().items() if k.startswith("h") and v is not None}
    if overrides:
        model = dataclasses.replace(model, h=dataclasses.replace(model.h, **overrides))
    if scn.oscillator.drift_per_s is not None:
        model = dataclasses.replace(model, drift_per_s=scn.oscillator.drift_per_s)
    return model


def _series_summary(x_s: np.ndarray) -> dict:
    valid = x_s[np.isfinite(x_s)]
    if valid.size == 0:
        return {"n": int(x_s.size), "n_missing": int(x_s.size)}
    return {
        "n": int(x_s.size),
        "n_missing": int(x_s.size - valid.size),
        "rms_ns": float(np.sqrt(np.mean(valid**2)) * 1e9),
        "max_abs_ns": float(np.max(np.abs(valid)) * 1e9),
        "peak_to_peak_ns": float(np.ptp(valid) * 1e9),
    }


def run_scenario(scn: Scenario, out_dir: str | Path, progress: Progress | None = None) -> RunReport:
    """Simulate ``scn`` and write its report folder ``out_dir`` (created; files in it are replaced).

    Returns the summary that is also written as ``summary.json``.
    """
    say = progress or silent
    check_disciplinable(scn)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    seeds = np.random.SeedSequence(scn.seed).spawn(2)  # the children simulate_gnssdo draws the same run from

    say("simulating the oscillator", 0.0)
    model = _oscillator_model(scn)
    osc = simulate_oscillator(model, scn.duration_s, scn.rate_hz, seeds[0], trials=1)
    t_s = osc.t_s
    osc_x = osc.x_s[0]

    say(f"simulating {scn.receivers.count} receivers ({scn.receivers.scenario})", 0.03)
    rx = simulate_receivers(discipline_environment(scn), int(round(scn.duration_s)), scn.receivers.count, seeds[1],
                            rate_hz=scn.rate_hz)
    pps = rx.pps_error_s[0] + rx.epochs.qerr_s[0]  # (receivers, steps): qErr-corrected 1PPS time error (u-blox sign)
    labels = [f"rx{i + 1}" for i in range(scn.receivers.count)]
    n = min(t_s.size, pps.shape[1])

    say("analysing stability", 0.12)
    taus = scn.analysis.taus
    osc_adev = stability.oadev(osc_x[:n], scn.rate_hz, stability.tau_grid(taus, n, scn.rate_hz, "oadev"))
    theory_tau = np.logspace(np.log10(osc_adev.tau_s[0]), np.log10(osc_adev.tau_s[-1]), 60)
    theory = adev_theory(model.h, theory_tau, scn.rate_hz, model.drift_per_s)
    rx_devs: dict[str, dict[str, stability.Deviation]] = {}
    for label, series in zip(labels, pps[:, :n]):
        rx_devs[label] = {name: stability.compute(name, series, scn.rate_hz, stability.tau_grid(taus, n, scn.rate_hz, name))
                          for name in scn.analysis.deviations}

    mask_doc = None
    mask_limits = {}
    if scn.analysis.mask is not None:
        mask = MASKS[scn.analysis.mask]
        mask_doc = {"name": scn.analysis.mask, "receivers": {}}
        for label, series in zip(labels, pps[:, :n]):
            verdict = mask.check(series, scn.rate_hz)
            mask_doc["receivers"][label] = verdict.to_dict()
        mask_doc["passed"] = all(v["passed"] for v in mask_doc["receivers"].values())
        grid = np.logspace(0, np.log10(max(scn.duration_s / 10, 10)), 200)
        mask_limits = {f"{scn.analysis.mask} {stat}": (grid, mask.limit_s(stat, grid)) for stat in ("mtie", "tdev")}

    say("writing the report", 0.25)
    files = []
    frame = pd.DataFrame({"t_s": t_s[:n], "oscillator_x_ns": osc_x[:n] * 1e9})
    for label, series in zip(labels, pps[:, :n]):
        frame[f"{label}_pps_error_ns"] = series * 1e9
    files.append(out / "timeseries.csv")
    frame.to_csv(files[-1], index=False, float_format="%.12g")

    rows = []
    for series_name, devs in [("oscillator", {"oadev": osc_adev})] + list(rx_devs.items()):
        for stat, dev in devs.items():
            for k in range(dev.tau_s.size):
                rows.append(
                    {"series": series_name, "statistic": stat, "tau_s": dev.tau_s[k], "dev": dev.dev[k],
                     "lo": dev.lo[k], "hi": dev.hi[k], "n": int(dev.n[k]), "alpha": int(dev.alpha[k])}
                )
    files.append(out / "stability.csv")
    pd.DataFrame(rows).to_csv(files[-1], index=False, float_format="%.6g")

    chain: dict = {}
    output_devs: dict = {}
    if scn.discipline.enabled:
        chain, chain_files, output_devs = discipline_and_swarm(scn, out, say, oscillator=model, span=(0.32, 1.0))
        files += chain_files
    if output_devs and not mask_limits:  # the disciplined output is checked against the PRTC masks: draw them
        grid = np.logspace(0, np.log10(max(scn.duration_s / 10, 10)), 200)
        mask_limits = {f"{name} {stat}": (grid, MASKS[name].limit_s(stat, grid)) for name in ("prtc-a",)
                       for stat in ("mtie", "tdev")}
    files[2:2] = write_run_figures(out, t_s[:n], dict(zip(labels, pps[:, :n])), scn.receivers.scenario, model.name,
                                   osc_x[:n], osc_adev, (theory_tau, theory), rx_devs, mask_limits, output_devs)

    summary = {
        "scenario": scn.model_dump(),
        "oscillator": {
            "model": model.name,
            "h": dataclasses.asdict(model.h),
            "drift_per_s": model.drift_per_s,
            "free_run": _series_summary(osc_x[:n]),
            "oadev": osc_adev.to_dict(),
            "theory": {"tau": theory_tau.tolist(), "adev": theory.tolist()},
        },
        "receivers": {
            label: {
                "pps_error": _series_summary(series),
                "fix_fraction": float(np.mean(rx.epochs.has_fix[0, i, :n])),
                "gdop_over_5_fraction": gdop_over_5_fraction(rx.epochs.gdop[0, i, :n]),
                "deviations": {stat: dev.to_dict() for stat, dev in rx_devs[label].items()},
            }
            for i, (label, series) in enumerate(zip(labels, pps[:, :n]))
        },
        "mask": mask_doc,
        **chain,
        "files": [str(f.relative_to(out)) for f in files] + ["summary.json"],
    }
    files.append(out / "summary.json")
    summary["files"].append("report.html")
    files[-1].write_text(dumps(summary))
    files.append(run_page(summary, out))
    return RunReport(out_dir=out, summary=summary, files=tuple(files))

