"""The stability plot a timing engineer would publish: every requested statistic, masks drawn, the verdict.

:func:`stability_figure` returns a :class:`~matplotlib.figure.Figure` (on its own Agg canvas, no pyplot,
no file): one panel for the dimensionless statistics (ADEV family, total family, Theo), one for the time
statistics in nanoseconds (TDEV, TTOTDEV, TIE rms, MTIE), each with its confidence intervals, dashed
noise-slope guides (the power laws of SP 1065 Table 1: ADEV ``tau**-1`` for white and flicker PM,
``tau**-1/2`` white FM, ``tau**0`` flicker FM, ``tau**+1/2`` random-walk FM; TDEV ``tau**-1/2`` white PM,
``tau**0`` flicker PM, ``tau**+1/2`` white FM), the MTIE and TDEV masks of every clock checked, the
points that fail a mask ringed in red, and under the panels the verdict of each clock with every failing
observation interval. A panel with nothing to show is left out.
"""

from __future__ import annotations

import textwrap

import matplotlib
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from chronofuse.analysis.stability.result import Deviation

__all__ = ["stability_figure", "TIME_STATISTICS"]

#: Statistics in seconds (drawn in ns on the time panel); the others are dimensionless.
TIME_STATISTICS = ("tdev", "ttotdev", "tie_rms", "mtie")
_FREQUENCY_GUIDES = ((-1.0, "white/flicker PM"), (-0.5, "white FM"), (0.0, "flicker FM"), (0.5, "RW FM"))
_TIME_GUIDES = ((-0.5, "white PM"), (0.0, "flicker PM"), (0.5, "white FM"))


def _draw_curves(ax, deviations: dict[str, Deviation], scale: float, colors: list[str]) -> None:
    for i, (name, dev) in enumerate(deviations.items()):
        ok = np.isfinite(dev.dev) & (dev.dev > 0)
        if not ok.any():
            continue
        color = colors[i % len(colors)]
        tau, value = dev.tau_s[ok], dev.dev[ok] * scale
        lo, hi = dev.lo[ok] * scale, dev.hi[ok] * scale
        has_ci = np.isfinite(lo).any()
        label = name.upper()
        if has_ci:
            yerr = np.vstack([value - lo, hi - value])
            yerr = np.where(np.isfinite(yerr), yerr, 0.0)
            ax.errorbar(tau, value, yerr=yerr, fmt="o-", ms=3, lw=1, capsize=2, color=color, label=label)
        else:
            ax.plot(tau, value, "o-", ms=3, lw=1, color=color, label=label)


def _draw_guides(ax, deviations: dict[str, Deviation], scale: float, guides) -> None:
    """Dashed power-law lines through the first point of the first curve, labelled at their right end."""
    anchor = next(((d.tau_s[ok][0], d.dev[ok][0] * scale, d.tau_s[ok][-1])
                   for d in deviations.values() if (ok := np.isfinite(d.dev) & (d.dev > 0)).any()), None)
    if anchor is None:
        return
    tau0, value0, tau_end = anchor
    span = np.array([tau0, max(tau_end, tau0 * 10)])
    low, high = ax.get_ylim()  # the guides never stretch the axes the data set
    for slope, label in guides:
        line = value0 * (span / tau0) ** slope
        ax.plot(span, line, ls=(0, (4, 4)), lw=0.7, color="0.55", zorder=0, scalex=False, scaley=False)
        end = float(np.clip(line[-1], low, high))
        ax.annotate(f"$\\tau^{{{slope:+g}}}$ {label}", (span[-1], end), fontsize=6, color="0.4",
                    xytext=(2, 0), textcoords="offset points", va="center", annotation_clip=False)
    ax.set_ylim(low, high)


_MASK_COLORS = ("k", "tab:purple", "tab:brown", "tab:olive", "tab:cyan", "tab:pink")


def _draw_masks(ax, deviations: dict[str, Deviation], verdicts, masks, scale: float) -> None:
    """Each clock's MTIE/TDEV masks (one colour per clock, one line style per metric); for filtered
    classes the dTE_L curve that was checked (it is not the plotted unfiltered one); failing points ringed."""
    taus = np.concatenate([d.tau_s for d in deviations.values()]) if deviations else np.array([1.0])
    grid = np.geomspace(max(taus.min(), 1e-3), taus.max(), 400)
    for k, clock in enumerate(masks):
        color = _MASK_COLORS[k % len(_MASK_COLORS)]
        for metric, style in (("mtie", "-"), ("tdev", "--")):
            mask = getattr(clock, metric)
            if mask is None or metric not in deviations:
                continue
            limit = mask.limit_s(grid) * scale
            if not np.isfinite(limit).any():
                continue
            ax.plot(grid, limit, color=color, ls=style, lw=1.4, label=f"{clock.name} {metric.upper()} mask")
    ringed = False
    for k, verdict in enumerate(verdicts):
        color = _MASK_COLORS[k % len(_MASK_COLORS)]
        for res in (verdict.mtie, verdict.tdev):
            if res is None or res.metric not in deviations:
                continue
            if verdict.filtered:
                ax.plot(res.tau_s, res.value_s * scale, ":", marker=".", ms=3, lw=1, color=color,
                        label=f"{res.metric.upper()} of dTE_L ({verdict.clock})")
            bad = res.evaluated & ~res.passed_each
            if bad.any():
                ax.plot(res.tau_s[bad], res.value_s[bad] * scale, "o", ms=9, mfc="none", mec="tab:red", mew=1.5,
                        label=None if ringed else "fails a mask")
                ringed = True


def _finish(ax, ylabel: str) -> None:
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("tau (s)")
    ax.set_ylabel(ylabel)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="best", fontsize=7)


def stability_figure(deviations: dict[str, Deviation], *, verdicts=(), masks=(), title: str = "") -> Figure:
    """The figure of the module docstring.

    Parameters
    ----------
    deviations : dict of str to Deviation
        Statistic name -> result, every one of which is drawn.
    verdicts : sequence of ClockVerdict
        Verdicts whose failing points are ringed and whose summaries are written under the panels.
    masks : sequence of ClockMasks
        Clock classes whose MTIE and TDEV masks are drawn on the time panel (with those statistics).
    title : str
        Figure title.
    """
    frequency = {k: v for k, v in deviations.items() if k not in TIME_STATISTICS}
    timing = {k: v for k, v in deviations.items() if k in TIME_STATISTICS}
    panels = [p for p in (("frequency", frequency), ("time", timing)) if p[1]]
    if not panels:
        raise ValueError("deviations is empty, must hold at least one Deviation to plot")
    notes = [f"{v.clock}: {v.status.upper()} - {v.summary()}" for v in verdicts]
    wrapped = [textwrap.fill(n, 150 if len(panels) > 1 else 90) for n in notes]
    text_lines = sum(w.count("\n") + 1 for w in wrapped)
    fig = Figure(figsize=(6.5 * len(panels), 5.0 + 0.17 * text_lines), layout="constrained")
    FigureCanvasAgg(fig)
    if wrapped:  # a row under the panels for the verdicts, each line in its verdict's colour
        grid = fig.add_gridspec(2, len(panels), height_ratios=[5.0, 0.17 * text_lines + 0.05])
        axes = [fig.add_subplot(grid[0, i]) for i in range(len(panels))]
        _write_verdicts(fig.add_subplot(grid[1, :]), wrapped, [v.status for v in verdicts], text_lines)
    else:
        axes = fig.subplots(1, len(panels), squeeze=False)[0]
    colors = matplotlib.rcParams["axes.prop_cycle"].by_key()["color"]
    for ax, (kind, group) in zip(axes, panels):
        scale = 1e9 if kind == "time" else 1.0
        ax.set_xscale("log")
        ax.set_yscale("log")
        _draw_curves(ax, group, scale, colors)
        if kind == "time":
            _draw_masks(ax, group, verdicts, masks, scale)
        ax.autoscale_view()
        _draw_guides(ax, group, scale, _TIME_GUIDES if kind == "time" else _FREQUENCY_GUIDES)
        _finish(ax, "time statistic (ns)" if kind == "time" else "deviation (dimensionless)")
    if title:
        fig.suptitle(title)
    return fig


#: The colour of each verdict's line under the plot.
VERDICT_COLORS = {"pass": "tab:green", "fail": "tab:red", "incomplete": "tab:orange", "not evaluated": "tab:gray"}


def _write_verdicts(ax, wrapped: list[str], statuses: list[str], text_lines: int) -> None:
    """Each verdict's summary in ``ax`` (its axes hidden), one under the other, coloured by verdict."""
    ax.set_axis_off()
    line = 0
    for text, status in zip(wrapped, statuses):
        ax.text(0.0, 1.0 - line / max(text_lines, 1), text, fontsize=7, ha="left", va="top",
                color=VERDICT_COLORS.get(status, "tab:orange"), transform=ax.transAxes)
        line += text.count("\n") + 1
