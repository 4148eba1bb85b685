"""The report of ``chronofuse reproduce integrity`` (the detector experiments): figures, tables, JSON, Markdown.

:mod:`chronofuse.experiments.integrity` computes the rows and the summary; this module only draws and
writes them (:func:`write_integrity_report`). Figures are drawn on their own Agg canvas (no pyplot), so the
user's matplotlib backend is left as it is.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from chronofuse.integrity.inject import KINDS
from chronofuse.report.figures import log_log_axes, new_figure, save_figure
from chronofuse.report.jsonio import dumps

REPORT_FILES = ("pfa.png", "training.png", *[f"detection_{k}.png" for k in KINDS], "pfa.csv", "detection.csv",
                "summary.json", "README.md")


def write_integrity_report(out_dir: Path, summary: dict, cfg, detectors, pfas) -> None:
    """Write :data:`REPORT_FILES` to ``out_dir`` (created) from ``run_integrity``'s ``summary`` and config ``cfg``."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    plot_pfa(summary["false_alarms"], pfas, out / "pfa.png")
    plot_training(summary["training"], out / "training.png")
    for kind in KINDS:
        plot_detection(summary["detection"], kind, out / f"detection_{kind}.png", cfg.horizon * cfg.interval_s)
    pd.DataFrame(summary["false_alarms"]).to_csv(out / "pfa.csv", index=False)
    pd.DataFrame(summary["detection"]).to_csv(out / "detection.csv", index=False)
    (out / "summary.json").write_text(dumps(summary) + "\n")
    (out / "README.md").write_text(integrity_markdown(summary, cfg, detectors))


def plot_pfa(rows: list[dict], pfas, path: Path) -> None:
    """Empirical against nominal P_fa per detector, with the 99 % Clopper-Pearson bars (``pfa.png``)."""
    frame = pd.DataFrame(rows)
    fig, ax = new_figure((6.5, 5))
    for name, grp in frame.groupby("detector", sort=False):
        rate = grp["rate_independent"].to_numpy()
        err = np.vstack([rate - grp["ci99_lo"].to_numpy(), grp["ci99_hi"].to_numpy() - rate])
        ax.errorbar(grp["pfa"], np.maximum(rate, 1e-7), yerr=err, fmt="o-", ms=4, capsize=3, label=name)
    ax.plot(pfas, pfas, "k--", lw=1, label="nominal")
    log_log_axes(ax, "nominal P_fa", "empirical P_fa (independent epochs, 99 % CI)")
    save_figure(fig, path)


def plot_training(rows: list[dict], path: Path) -> None:
    """HOD P_fa against training length, per noise-fit method (``training.png``)."""
    frame = pd.DataFrame(rows)
    fig, ax = new_figure((6.5, 4.5))
    for k, (method, grp) in enumerate(frame.groupby("method", sort=False)):
        x = grp["training_epochs"].to_numpy() * (1.0 + 0.08 * k)
        med = grp["median_rate"].to_numpy()
        ax.errorbar(x, med, yerr=[med - grp["p10_rate"], grp["p90_rate"] - med], fmt="o-", capsize=3,
                    label=f"HOD, noise fitted by {method} (median, 10-90 %)")
    ax.axhline(frame["pfa"].iloc[0], color="k", ls="--", lw=1, label="nominal")
    log_log_axes(ax, "training length (epochs)", "empirical P_fa")
    save_figure(fig, path)


def plot_detection(rows: list[dict], kind: str, path: Path, horizon_s: float) -> None:
    """Detection probability and median delay against anomaly size for one kind (``detection_<kind>.png``)."""
    frame = pd.DataFrame([r for r in rows if r["kind"] == kind])
    fig = Figure(figsize=(11, 4.5), layout="constrained")
    FigureCanvasAgg(fig)
    (ax1, ax2) = fig.subplots(1, 2)
    for name, grp in frame.groupby("detector", sort=False):
        ax1.plot(grp["size_sigma"], grp["p_detect"], "o-", ms=4, label=name)
        ax2.plot(grp["size_sigma"], grp["median_delay_s"], "o-", ms=4, label=name)
    for ax in (ax1, ax2):
        ax.set_xscale("log")
        ax.set_xlabel("anomaly size (sigma_df units)")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    ax1.set_ylabel(f"detection probability within {horizon_s:g} s")
    ax2.set_ylabel("median delay of first alarm (s)")
    fig.suptitle(f"{kind}")
    fig.savefig(path, dpi=110)


def integrity_markdown(summary: dict, cfg, detectors) -> str:
    """The report's ``README.md``: ``summary`` from ``run_integrity``, its config ``cfg``, the detector names."""
    lines = [
        "# Clock-bias integrity: HOD chi-square detector against baselines",
        "",
        f"Noise h0 = {cfg.noise.h0:g} s, h-2 = {cfg.noise.hm2:g} /s, sigma_rho = {cfg.noise.sigma_rho_m:g} m, "
        f"t_s = {cfg.interval_s:g} s, window n = {cfg.window}; reference clock noise {cfg.sigma_reference_s:g} s. "
        f"Mode: {'quick' if summary['quick'] else 'full'}; seed {cfg.seed}.",
        "",
        "## False-alarm rate (independent test epochs, 99 % Clopper-Pearson interval)",
        "",
        f"Test epochs are {cfg.window + 2} epochs apart, so HOD, single-epoch and reference windows there share no "
        "correlated data and the binomial interval is exact for them. CUSUM alarms come in runs (its sums carry "
        "over), so for CUSUM the interval is too narrow; its threshold is calibrated by simulation.",
        "",
        "| detector | nominal | empirical | 99 % CI | nominal inside |",
        "|---|---|---|---|---|",
    ]
    for r in summary["false_alarms"]:
        lines.append(f"| {r['detector']} | {r['pfa']:g} | {r['rate_independent']:.3g} | "
                     f"[{r['ci99_lo']:.3g}, {r['ci99_hi']:.3g}] | {'yes' if r['nominal_in_ci99'] else 'no'} |")
    lines += ["", "## P_fa with noise estimated from training data (HOD)", "",
              "| fit | training epochs | median P_fa | 10 % | 90 % |", "|---|---|---|---|---|"]
    for r in summary["training"]:
        lines.append(f"| {r['method']} | {r['training_epochs']} | {r['median_rate']:.3g} | {r['p10_rate']:.3g} | "
                     f"{r['p90_rate']:.3g} |")
    lines += ["", f"## Detection within {cfg.horizon * cfg.interval_s:g} s of onset (P_fa = {cfg.detection_pfa:g})",
              "", "Smallest size (in sigma_df) detected with probability >= 0.9, per detector:", "",
              "| anomaly | " + " | ".join(detectors) + " |", "|---|" + "---|" * len(detectors)]
    for kind, best in summary["min_size_p90"].items():
        lines.append(f"| {kind} | " + " | ".join("-" if best[d] is None else f"{best[d]:g}" for d in detectors) + " |")
    lines += ["", "Figures: `pfa.png`, `training.png`, " + ", ".join(f"`detection_{k}.png`" for k in KINDS) + ".",
              "Tables: `pfa.csv`, `detection.csv`; everything in `summary.json`.", ""]
    return "\n".join(lines)
