"""Swarm-sync figures and tables: a sweep's RMSE (ns) with its interval against the swept parameter (in the
unit an engineer reads it in), the Bayesian bound drawn on top, and the paper's reported numbers as open
markers in the colour of their algorithm's curve."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.ticker import FuncFormatter, NullFormatter

__all__ = ["DISPLAY_UNITS", "plot_sweep", "write_sweep"]

#: Swept parameter -> (unit shown, factor from SI).
DISPLAY_UNITS = {"velocity": ("m/s", 1.0), "distance": ("km", 1e-3), "reply-delay": ("ms", 1e3), "urt": ("ns", 1e9),
                 "snr": ("dB", 1.0)}


def plot_sweep(summary: pd.DataFrame, param: str, unit: str, path: str | Path, *, title: str = "",
               paper_points: dict | None = None, paper_levels: dict | None = None) -> Path:
    """RMSE (ns, log axis) of each algorithm against the swept value with its 95 % interval as error bars,
    the bound as a thick dashed line on top, the paper's numbers at a value (``{algorithm: [(value_SI,
    rmse_ns)]}``) as open squares and its numbers over the whole sweep (``{algorithm: [(label, rmse_ns)]}``,
    e.g. "< 0.25") as dotted levels, both in the colour of that algorithm's curve."""
    shown, factor = DISPLAY_UNITS.get(param, (unit, 1.0))
    fig = Figure(figsize=(7.5, 4.8))
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    colours = {}
    for name, group in summary.groupby("algorithm", sort=False):
        g = group.sort_values("value")
        x = g["value"].to_numpy() * factor
        y = g["rmse_ns"].to_numpy()
        err = None
        if "rmse_lo_ns" in g:
            err = np.vstack([y - g["rmse_lo_ns"].to_numpy(), g["rmse_hi_ns"].to_numpy() - y])
        line = ax.errorbar(x, y, yerr=err, marker="o", markersize=4, capsize=3, label=name, zorder=2)
        colours[name] = line[0].get_color()
    bound_col = "bound_rms_ns" if "bound_rms_ns" in summary else "pcrb_rms_ns"
    # each algorithm's bound is over the exchanges it is scored on (sync.metrics); the line is the bound over
    # every exchange, the largest of them (that of an algorithm with an estimate at each exchange)
    bound = summary.groupby("value", sort=True)[bound_col].max()
    ax.plot(bound.index.to_numpy() * factor, bound.to_numpy(), color="black", linestyle="--", linewidth=2.2,
            label="Bayesian bound (same model)", zorder=5)
    for name, points in (paper_points or {}).items():
        xs, ys = zip(*points)
        ax.plot(np.asarray(xs) * factor, ys, linestyle="none", marker="s", markerfacecolor="none", markersize=10,
                markeredgewidth=1.8, color=colours.get(name, "grey"), label=f"paper: {name}", zorder=6)
    for name, levels in (paper_levels or {}).items():
        for label, level in levels:
            ax.axhline(level, linestyle=":", linewidth=1.8, color=colours.get(name, "grey"),
                       label=f"paper: {name} {label} {level:g} ns", zorder=4)
    ax.set_yscale("log")
    # plain numbers in ns (0.3, 1, 10), not powers of ten; minor ticks labelled only on an axis under 1.5 decades
    plain = FuncFormatter(lambda v, _: f"{v:g}")
    ax.yaxis.set_major_formatter(plain)
    lo, hi = ax.get_ylim()
    ax.yaxis.set_minor_formatter(plain if np.log10(hi / lo) < 1.5 else NullFormatter())
    ax.set_xlabel(f"{param} ({shown})")
    ax.set_ylabel("RMSE of the clock offset (ns)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    if title:
        ax.set_title(title, fontsize=9)
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=120)
    return path


def write_sweep(table: pd.DataFrame, summary: pd.DataFrame, out: str | Path, stem: str = "sweep") -> list[Path]:
    """Write the tidy table (CSV and Parquet) and the summary (CSV) into ``out``; return the paths."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    paths = [out / f"{stem}.csv", out / f"{stem}.parquet", out / f"{stem}_summary.csv"]
    table.to_csv(paths[0], index=False)
    table.to_parquet(paths[1], index=False)
    summary.to_csv(paths[2], index=False)
    return paths
