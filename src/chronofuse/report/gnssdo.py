"""PNG figures of a GNSSDO run: time error with the states shaded, ADEV of the three series, holdover."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from chronofuse.discipline.states import State
from chronofuse.report.figures import legend_outside

_STATE_COLOURS = {State.FREE_RUN: "#dddddd", State.ACQUIRING: "#fde9b0", State.LOCKED: "#d8f0d8",
                  State.HOLDOVER: "#f7c6c6", State.RECOVERY: "#cfe0fb", State.ALARM: "#f4a259"}


def _decimated(t: np.ndarray, v: np.ndarray, keep: int = 20_000):
    step = max(1, t.size // keep)
    return t[::step], v[::step]


def plot_time_error(t_s, phase_s, optimal_s, states, path: Path, title: str) -> Path:
    """Time error of trial 0 (ns) against hours, the clairvoyant servo's beside it, states shaded."""
    fig = Figure(figsize=(10.5, 4))
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    hours = t_s / 3600.0
    edges = np.flatnonzero(np.diff(states)) + 1
    starts = np.concatenate([[0], edges])
    stops = np.concatenate([edges, [states.size]])
    seen = set()
    for a, b in zip(starts, stops):
        s = State(int(states[a]))
        ax.axvspan(hours[a], hours[min(b, hours.size - 1)], color=_STATE_COLOURS[s], lw=0,
                   label=None if s in seen else s.name.lower().replace("_", "-"))
        seen.add(s)
    ax.plot(*_decimated(hours, phase_s * 1e9), lw=0.6, color="C0", label="disciplined 1PPS")
    ax.plot(*_decimated(hours, optimal_s * 1e9), lw=0.6, color="C3", alpha=0.7, label="clairvoyant KF")
    lim = np.nanpercentile(np.abs(phase_s[int(0.05 * phase_s.size):]) * 1e9, 99.5) * 1.5 + 1.0
    ax.set_ylim(-lim, lim)
    ax.set_xlabel("time (h)")
    ax.set_ylabel("time error (ns)")
    ax.set_title(title)
    legend_outside(ax)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    return path


def plot_adev(adev: dict, path: Path, title: str) -> Path:
    """ADEV of the free-running oscillator, the GNSS reference and the disciplined output, and their envelope."""
    fig = Figure(figsize=(6.5, 4.5))
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    styles = {"free_run": ("free-running oscillator", "C7"), "gnss": ("GNSS reference (fused 1PPS)", "C1"),
              "disciplined": ("disciplined output", "C0")}
    for key, (label, colour) in styles.items():
        tau, dev = np.asarray(adev[key]["tau"]), np.asarray(adev[key]["dev"], dtype=float)
        if np.isfinite(dev).any():
            ax.loglog(tau, dev, "o-", ms=3, color=colour, label=label)
    env = np.fmin(np.asarray(adev["free_run"]["dev"], dtype=float), np.asarray(adev["gnss"]["dev"], dtype=float))
    ax.loglog(adev["free_run"]["tau"], env, "k--", lw=0.8, label="lower envelope")
    return _finish_adev(fig, ax, path, title)


def _finish_adev(fig, ax, path: Path, title: str) -> Path:
    """Label an ADEV plot's axes, title and legend, and write it (110 dpi)."""
    ax.set_xlabel("tau (s)")
    ax.set_ylabel("overlapping ADEV")
    ax.grid(True, which="both", lw=0.3)
    ax.set_title(title)
    legend_outside(ax)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    return path


def plot_holdover(t_s, phase_s, optimal_s, start_s: float, stop_s: float, path: Path, title: str) -> Path:
    """Time error accumulated over the outage (trial 0), ours and the clairvoyant KF's."""
    a, b = int(start_s), int(min(stop_s, t_s.size - 1))
    fig = Figure(figsize=(6.5, 4))
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    hours = (t_s[a:b] - t_s[a]) / 3600.0
    ax.plot(hours, (phase_s[a:b] - phase_s[a]) * 1e9, label="controller")
    ax.plot(hours, (optimal_s[a:b] - optimal_s[a]) * 1e9, label="clairvoyant KF")
    ax.set_xlabel("time in holdover (h)")
    ax.set_ylabel("accumulated time error (ns)")
    ax.set_title(title)
    ax.grid(True, lw=0.3)
    legend_outside(ax)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    return path


def write_report(sim: dict, summary: dict, out_dir: Path) -> list[str]:
    """Write the PNGs of one simulated run into ``out_dir``; returns their file names."""
    run, best, setup = sim["run"], sim["clairvoyant"], sim["setup"]
    t = np.arange(run.phase_s.shape[1], dtype=float)
    label = f"{setup.scenario}, {setup.controller}, {setup.receivers} receiver(s)"
    files = [plot_time_error(t, run.phase_s[0], best.phase_s[0], run.states.state[0], out_dir / "time_error.png",
                             f"Time error ({label})").name,
             plot_adev(summary["adev"], out_dir / "adev.png", f"ADEV ({label})").name]
    env = sim["environment"]
    if env.jamming_start_s is not None and env.jamming_duration_s > 0:
        files.append(plot_holdover(t, run.phase_s[0], best.phase_s[0], env.jamming_start_s,
                                   env.jamming_start_s + env.jamming_duration_s, out_dir / "holdover.png",
                                   f"Holdover ({label})").name)
    return files


def plot_characterization(doc: dict, path: Path, title: str) -> Path:
    """A characterised oscillator: the measured ADEV with its simultaneous intervals, the fitted model's ADEV
    and each power-law term's (``doc``: :meth:`~chronofuse.discipline.characterize.Characterization.to_dict`)."""
    from chronofuse.analysis.theory import avar_components
    from chronofuse.models.oscillator import PowerLaw

    a = doc["adev"]
    tau, dev = np.asarray(a["tau_s"]), np.asarray(a["measured"])
    lo, hi = np.asarray(a["lo"]), np.asarray(a["hi"])
    fig = Figure(figsize=(6.5, 4.5))
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    ax.errorbar(tau, dev, yerr=[dev - lo, hi - dev], fmt="o", ms=3, color="C0", capsize=2,
                label=f"measured OADEV ({a['family_ci']:.0%} simultaneous intervals)")
    ax.loglog(tau, a["model"], "-", color="C3", label="fitted model")
    dense = np.logspace(np.log10(tau[0]), np.log10(tau[-1]), 200)
    parts = avar_components(PowerLaw(**doc["h"]), dense, doc["rate_hz"])
    for key, label in (("h2", "white PM"), ("h1", "flicker PM"), ("h0", "white FM"), ("hm1", "flicker FM"),
                       ("hm2", "random-walk FM")):
        if doc["h"][key] > 0:
            ax.loglog(dense, np.sqrt(parts[key]), ":", lw=0.9, label=label)
    ax.set_xscale("log")
    ax.set_yscale("log")
    return _finish_adev(fig, ax, path, title)
