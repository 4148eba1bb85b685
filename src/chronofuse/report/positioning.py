"""Figures of a positioning run: the trajectory, the horizontal error of each solution, the outages.

Drawn on :class:`matplotlib.figure.Figure` objects with the Agg canvas, so no pyplot backend is switched.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from chronofuse.positioning.errors import ned_difference_m

_STYLE = {"gnss": ("tab:gray", "GNSS only"), "gnss+ins": ("tab:blue", "GNSS + INS"),
          "gnss+ins+rts": ("tab:green", "GNSS + INS, RTS smoothed")}


def _save(fig: Figure, path: Path) -> Path:
    FigureCanvasAgg(fig)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    return path


def plot_trajectory(run: dict, path: Path) -> Path:
    """The true path (first trial) with each solution's fixes, in local north/east metres."""
    truth = run["truth_lat_lon_h"]
    ned = ned_difference_m(truth, np.broadcast_to(truth[0], truth.shape))
    fig = Figure(figsize=(6, 6))
    ax = fig.add_subplot()
    ax.plot(ned[:, 1], ned[:, 0], "k-", lw=1, label="truth")
    for name, err in run["errors_ned_m"].items():
        colour, label = _STYLE[name]
        est = ned + err[0]
        ax.plot(est[:, 1], est[:, 0], ".", ms=2, color=colour, label=label)
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend(loc="best", fontsize=8)
    ax.set_title(f"{run['summary']['scenario']}, {run['summary']['systems']}, INS {run['summary']['ins']}")
    return _save(fig, path)


def plot_errors(run: dict, path: Path) -> Path:
    """Horizontal error against time (first trial) and its distribution over every trial."""
    fig = Figure(figsize=(9, 4))
    ax, hist = fig.add_subplot(1, 2, 1), fig.add_subplot(1, 2, 2)
    for name, err in run["errors_ned_m"].items():
        colour, label = _STYLE[name]
        h = np.hypot(err[..., 0], err[..., 1])
        ax.plot(np.arange(1, h.shape[1] + 1), h[0], color=colour, lw=0.8, label=label)
        finite = np.sort(h[np.isfinite(h)])
        if finite.size:
            hist.plot(finite, np.linspace(0, 1, finite.size), color=colour, label=label)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("horizontal error (m)")
    ax.set_yscale("log")
    hist.set_xlabel("horizontal error (m)")
    hist.set_ylabel("fraction of epochs")
    hist.set_xscale("log")
    hist.axhline(0.95, color="k", lw=0.5, ls=":")
    hist.legend(loc="lower right", fontsize=8)
    return _save(fig, path)


def plot_outages(run: dict, path: Path) -> Path:
    """Horizontal error through the GNSS outages (every trial, GNSS/INS solutions), with the 2 m and 10 m lines."""
    gnss = run["errors_ned_m"]["gnss"]
    outage = ~np.isfinite(gnss[..., 0]).any(axis=0)
    fig = Figure(figsize=(8, 4))
    ax = fig.add_subplot()
    t = np.arange(1, outage.size + 1)
    for name, err in run["errors_ned_m"].items():
        if name == "gnss":
            continue
        colour, label = _STYLE[name]
        h = np.hypot(err[..., 0], err[..., 1])
        ax.plot(t, h.T, color=colour, lw=0.5, alpha=0.4)
        ax.plot([], [], color=colour, label=label)
    ax.fill_between(t, 0, 1, where=outage, transform=ax.get_xaxis_transform(), color="tab:red", alpha=0.15,
                    label="no GNSS fix")
    for limit in (2.0, 10.0):
        ax.axhline(limit, color="k", lw=0.5, ls="--")
    ax.set_yscale("log")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("horizontal error (m)")
    ax.legend(loc="upper left", fontsize=8)
    return _save(fig, path)
