"""PNG figures: time-error series and stability plots with theory and masks.

Figures are written with matplotlib's Agg backend (no screen needed). Nanoseconds appear only on
axes, where people read them.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from chronofuse.analysis.stability.result import Deviation  # noqa: E402

_MAX_POINTS = 20_000


def _decimate(t: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Keep at most ~_MAX_POINTS points for plotting (min/max envelope per block keeps spikes)."""
    n = v.size
    if n <= _MAX_POINTS:
        return t, v
    block = int(np.ceil(n / (_MAX_POINTS // 2)))
    m = n // block * block
    vb = v[:m].reshape(-1, block)
    tb = t[:m].reshape(-1, block)
    with np.errstate(all="ignore"):
        lo_idx = np.nanargmin(np.where(np.isnan(vb), np.inf, vb), axis=1)
        hi_idx = np.nanargmax(np.where(np.isnan(vb), -np.inf, vb), axis=1)
    rows = np.arange(vb.shape[0])
    idx = np.sort(np.stack([lo_idx, hi_idx], axis=1), axis=1)
    return tb[rows[:, None], idx].ravel(), vb[rows[:, None], idx].ravel()


def plot_time_error(t_s: np.ndarray, series_s: dict[str, np.ndarray], path: str | Path, *, title: str = "") -> Path:
    """Plot time-error series (seconds in, nanoseconds on the axis) against time in hours."""
    path = Path(path)
    fig, ax = plt.subplots(figsize=(9, 4.5), constrained_layout=True)
    for label, values in series_s.items():
        tt, vv = _decimate(np.asarray(t_s, float), np.asarray(values, float) * 1e9)
        ax.plot(tt / 3600.0, vv, lw=0.6, label=label)
    ax.set_xlabel("time (h)")
    ax.set_ylabel("time error (ns)")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    if title:
        ax.set_title(title)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_deviations(
    deviations: dict[str, Deviation],
    path: str | Path,
    *,
    theory: dict[str, tuple[np.ndarray, np.ndarray]] | None = None,
    limits: dict[str, tuple[np.ndarray, np.ndarray]] | None = None,
    ylabel: str = "deviation",
    title: str = "",
) -> Path:
    """Log-log plot of deviations with their confidence intervals, theory curves and mask limits.

    ``theory`` and ``limits`` map a label to ``(tau_s, value)`` arrays.
    """
    path = Path(path)
    fig, ax = plt.subplots(figsize=(7.5, 5), constrained_layout=True)
    for label, dev in deviations.items():
        ok = np.isfinite(dev.dev) & (dev.dev > 0)
        if not ok.any():
            continue
        has_ci = np.isfinite(dev.lo[ok]).any()
        if has_ci:
            yerr = np.vstack([dev.dev[ok] - dev.lo[ok], dev.hi[ok] - dev.dev[ok]])
            yerr = np.where(np.isfinite(yerr), yerr, 0.0)
            ax.errorbar(dev.tau_s[ok], dev.dev[ok], yerr=yerr, fmt="o-", ms=3, lw=1, capsize=2, label=label)
        else:
            ax.plot(dev.tau_s[ok], dev.dev[ok], "o-", ms=3, lw=1, label=label)
    for label, (tau, value) in (theory or {}).items():
        ax.plot(tau, value, "--", lw=1.2, label=label)
    for label, (tau, value) in (limits or {}).items():
        ax.plot(tau, value, "k-", lw=1.5, alpha=0.7, label=label)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("tau (s)")
    ax.set_ylabel(ylabel)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    if title:
        ax.set_title(title)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
