"""Swarm-sync figures and tables: a sweep's RMSE against its parameter with the PCRB line."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

__all__ = ["plot_sweep", "write_sweep"]


def plot_sweep(summary: pd.DataFrame, param: str, unit: str, path: str | Path, *, title: str = "",
               seed_points: dict | None = None) -> Path:
    """RMSE (ns, log axis) of each algorithm against the swept value, the PCRB as a dashed line, and the
    seed's reported numbers (``{algorithm: [(value, rmse_ns), ...]}``) as open markers."""
    fig = Figure(figsize=(7.0, 4.5))
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    for name, group in summary.groupby("algorithm", sort=False):
        ax.plot(group["value"], group["rmse_ns"], marker="o", label=name)
    pcrb = summary.drop_duplicates("value").sort_values("value")
    ax.plot(pcrb["value"], pcrb["pcrb_rms_ns"], "k--", label="PCRB (same link model)")
    for name, points in (seed_points or {}).items():
        xs, ys = zip(*points)
        ax.plot(xs, ys, linestyle="none", marker="s", markerfacecolor="none", markersize=9, label=f"seed: {name}")
    ax.set_yscale("log")
    ax.set_xlabel(f"{param} ({unit})")
    ax.set_ylabel("RMSE of the offset (ns)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    if title:
        ax.set_title(title)
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
