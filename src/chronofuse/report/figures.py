"""PNG figures: time-error series and stability plots with theory and masks.

Figures are drawn with matplotlib's object-oriented API (a :class:`~matplotlib.figure.Figure` on its own
Agg canvas): no screen is needed, pyplot is never imported and the user's backend is left as it is.
Nanoseconds appear only on axes, where people read them.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib
import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from chronofuse.analysis.stability.result import Deviation

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


def new_figure(figsize: tuple[float, float]) -> tuple[Figure, Axes]:
    """A figure with one axes on an Agg canvas of its own (constrained layout), outside pyplot."""
    fig = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(fig)
    return fig, fig.subplots()


def save_figure(fig: Figure, path: str | Path) -> Path:
    """Write ``fig`` as a PNG at 110 dpi; return the path."""
    path = Path(path)
    fig.savefig(path, dpi=110)
    return path


def legend_outside(ax: Axes) -> None:
    """The legend to the right of the axes, where it covers no data."""
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, borderaxespad=0.0)


def log_log_axes(ax: Axes, xlabel: str, ylabel: str) -> None:
    """Finish a log-log plot: both axes logarithmic, labelled, a light grid at every tick, the legend outside."""
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.grid(True, which="both", alpha=0.3)
    legend_outside(ax)


def time_axis(span_s: float) -> tuple[float, str]:
    """(seconds per unit, unit) for a time axis that spans ``span_s``: s up to 10 min, min up to 3 h, h beyond."""
    if span_s <= 600:
        return 1.0, "s"
    if span_s <= 3 * 3600:
        return 60.0, "min"
    return 3600.0, "h"


#: Markers and line styles cycled per curve, so that equal curves drawn over each other all stay visible.
CURVE_STYLES = (("o", "-"), ("s", "--"), ("^", ":"), ("D", "-."), ("v", (0, (5, 1))), ("x", (0, (1, 1))))


def plot_time_error(t_s: np.ndarray, series_s: dict[str, np.ndarray], path: str | Path, *, title: str = "") -> Path:
    """Plot time-error series (seconds in, nanoseconds on the axis) against time in s, min or h (:func:`time_axis`)."""
    fig, ax = new_figure((9, 4.5))
    t = np.asarray(t_s, float)
    unit_s, unit = time_axis(float(np.nanmax(t) - np.nanmin(t)) if t.size else 0.0)
    for label, values in series_s.items():
        tt, vv = _decimate(t, np.asarray(values, float) * 1e9)
        ax.plot(tt / unit_s, vv, lw=0.6, label=label)
    ax.set_xlabel(f"time ({unit})")
    ax.set_ylabel("time error (ns)")
    ax.grid(True, alpha=0.3)
    legend_outside(ax)
    if title:
        ax.set_title(title)
    return save_figure(fig, path)


def plot_deviations(
    deviations: dict[str, Deviation],
    path: str | Path,
    *,
    theory: dict[str, tuple[np.ndarray, np.ndarray]] | None = None,
    limits: dict[str, tuple[np.ndarray, np.ndarray]] | None = None,
    ylabel: str = "deviation",
    title: str = "",
    scale: float = 1.0,
) -> Path:
    """Log-log plot of deviations with their confidence intervals, theory curves and mask limits.

    ``theory`` and ``limits`` map a label to ``(tau_s, value)`` arrays. ``scale`` multiplies every value
    (1e9 for time quantities, MTIE and TDEV, drawn in ns with ``ylabel`` saying so). Each curve has its own
    marker and line style (:data:`CURVE_STYLES`), the masks their own, so none hides another.
    """
    fig, ax = new_figure((8.5, 5))
    for i, (label, dev) in enumerate(deviations.items()):
        ok = np.isfinite(dev.dev) & (dev.dev > 0)
        if not ok.any():
            continue
        marker, style = CURVE_STYLES[i % len(CURVE_STYLES)]
        size = 3 + 1.5 * (len(deviations) - 1 - i)  # the first curves larger: the ones drawn over them leave them seen
        has_ci = np.isfinite(dev.lo[ok]).any()
        if has_ci:
            yerr = np.vstack([dev.dev[ok] - dev.lo[ok], dev.hi[ok] - dev.dev[ok]]) * scale
            yerr = np.where(np.isfinite(yerr), yerr, 0.0)
            ax.errorbar(dev.tau_s[ok], dev.dev[ok] * scale, yerr=yerr, marker=marker, ls=style, ms=size, lw=1,
                        capsize=2, mfc="none", label=label)
        else:
            ax.plot(dev.tau_s[ok], dev.dev[ok] * scale, marker=marker, ls=style, ms=size, lw=1, mfc="none", label=label)
    for label, (tau, value) in (theory or {}).items():
        ax.plot(tau, np.asarray(value) * scale, "--", lw=1.2, label=label)
    for i, (label, (tau, value)) in enumerate((limits or {}).items()):
        colour, style = (("k", "-"), ("tab:red", "--"), ("tab:purple", ":"), ("tab:brown", "-."))[i % 4]
        ax.plot(tau, np.asarray(value) * scale, color=colour, ls=style, lw=1.6, alpha=0.8, label=label)
    log_log_axes(ax, "tau (s)", ylabel)
    if title:
        ax.set_title(title)
    return save_figure(fig, path)


_MASK_STYLES = {"prtc-a": ("k", "-"), "prtc-b": ("tab:red", "--"), "g811": ("tab:purple", ":")}
_MASK_LABELS = {"prtc-a": "PRTC-A (G.8272)", "prtc-b": "PRTC-B (G.8272)", "g811": "PRC (G.811)"}


def plot_with_references(deviations: dict[str, Deviation], references: dict[str, tuple[np.ndarray, np.ndarray]],
                         path: str | Path, *, ylabel: str, title: str,
                         masks: dict[str, tuple[np.ndarray, np.ndarray]] | None = None) -> Path:
    """Log-log plot of our curves (points, CI bars), published values (crosses) and masks (lines).

    ``deviations``: label -> :class:`Deviation`; ``references``: label -> ``(tau_s, value)`` drawn as
    crosses in the colour of the same-index curve; ``masks``: clock name -> ``(tau_s, limit)``.
    :func:`plot_deviations` draws references as dashed lines hidden under equal points, and every limit
    in one style, hence this variant.
    """
    fig, ax = new_figure((8.5, 5))
    colors = matplotlib.rcParams["axes.prop_cycle"].by_key()["color"]
    for i, (label, dev) in enumerate(deviations.items()):
        yerr = np.vstack([dev.dev - dev.lo, dev.hi - dev.dev])
        yerr = np.where(np.isfinite(yerr), yerr, 0.0)
        ax.errorbar(dev.tau_s, dev.dev, yerr=yerr, fmt="o-", ms=3, lw=1, capsize=2, color=colors[i], label=label)
    for i, (label, (tau, value)) in enumerate(references.items()):
        ax.plot(tau, value, "x", ms=8, mew=1.5, color="k" if i >= len(colors) else colors[(i + 3) % len(colors)],
                label=label)
    for clock, (tau, limit) in (masks or {}).items():
        color, style = _MASK_STYLES.get(clock, ("gray", "-"))
        ax.plot(tau, limit, color=color, ls=style, lw=1.6, label=f"{_MASK_LABELS.get(clock, clock)} mask")
    log_log_axes(ax, "tau (s)", ylabel)
    ax.set_title(title)
    return save_figure(fig, path)
