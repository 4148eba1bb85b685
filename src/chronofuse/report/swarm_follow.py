"""Figure of a swarm that follows its leader: each follower's time error to the leader and to true time."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from chronofuse.report.figures import legend_outside


def plot_followers(swarm, outage: np.ndarray, path: Path) -> Path:
    """Two panels over time: followers to the leader (ns), and leader and followers to true time (ns); the
    leader's GNSS outage shaded."""
    fig = Figure(figsize=(10.5, 6))
    FigureCanvasAgg(fig)
    top, bottom = fig.add_subplot(2, 1, 1), fig.add_subplot(2, 1, 2, sharex=None)
    t_h = swarm.t_s / 3600.0
    step = max(1, t_h.size // 20_000)
    for i, (lead, true) in enumerate(zip(swarm.to_leader_s, swarm.to_true_s)):
        top.plot(t_h[::step], lead[::step] * 1e9, lw=0.6, label=f"follower {i + 1}")
        bottom.plot(t_h[::step], true[::step] * 1e9, lw=0.6, label=f"follower {i + 1}")
    bottom.plot(t_h[::step], swarm.leader_s[::step] * 1e9, "k", lw=0.8, label="leader (disciplined OCXO)")
    for ax in (top, bottom):
        if outage.any():
            ax.fill_between(t_h, 0, 1, where=outage, transform=ax.get_xaxis_transform(), color="tab:red",
                            alpha=0.12, label="leader's GNSS outage")
        ax.grid(alpha=0.3)
    top.set_ylabel("to the leader (ns)")
    bottom.set_ylabel("to true time (ns)")
    bottom.set_xlabel("time (h)")
    legend_outside(top)
    legend_outside(bottom)
    top.set_title("Swarm: followers over two-way links")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    return path
