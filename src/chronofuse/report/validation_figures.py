"""The validation figures of ``docs/figures`` (:mod:`chronofuse.experiments.validation` computes, these draw).

Each function takes numbers already computed and writes one PNG, returning its path.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from chronofuse.analysis.masks import MASKS

#: The clocks whose masks the validation figures draw against the Cs 5071A record.
PRIMARY_CLOCKS = ("prtc-a", "prtc-b", "g811")
from chronofuse.analysis.stability.result import Deviation
from chronofuse.report.figures import plot_deviations, plot_with_references

Table = dict[str, np.ndarray]


def gps_figures(out_dir: Path, ours: dict[str, Deviation], tables: dict[str, Table], n_points: int) -> list[Path]:
    """``gps_deviations.png`` (ADEV, MDEV, MTOTDEV with Stable32's ADEV and MDEV) and ``gps_tdev.png``."""
    return [
        plot_with_references(
            {"ADEV (ours)": ours["adev"], "MDEV (ours)": ours["mdev"], "MTOTDEV (ours)": ours["mtotdev"]},
            {"ADEV, Stable32 table": (tables["adev"]["tau"], tables["adev"]["dev"]),
             "MDEV, Stable32 table": (tables["mdev"]["tau"], tables["mdev"]["dev"])},
            out_dir / "gps_deviations.png",
            ylabel="deviation",
            title=f"GPS 1PPS vs H-maser ({n_points} s): ours (68.3 % CI) and Stable32",
        ),
        plot_with_references(
            {"TDEV (ours)": ours["tdev"]},
            {"TDEV, Stable32 table": (tables["tdev"]["tau"], tables["tdev"]["dev"])},
            out_dir / "gps_tdev.png",
            ylabel="TDEV (s)",
            title="GPS 1PPS vs H-maser: TDEV, ours and Stable32",
        ),
    ]


def receiver_figure(out_dir: Path, corrected: Deviation, raw: Deviation, table: Table, analytic: np.ndarray,
                    duration_s: int) -> Path:
    """``receiver_calibration.png``: the simulated open-sky receiver's ADEV (qErr-corrected and raw), the
    analytic ADEV at the table's taus, and Stable32's ADEV of the GPS-vs-maser record."""
    return plot_deviations(
        {"simulated open sky, pps_error_s + qerr_s": corrected, "simulated open sky, raw pps_error_s": raw},
        out_dir / "receiver_calibration.png",
        theory={"corrected_pps_adev (analytic)": (table["tau"], analytic)},
        limits={"GPS 1PPS vs H-maser, Stable32 ADEV": (table["tau"], table["dev"])},
        ylabel="ADEV",
        title=f"Receiver model calibration ({duration_s} s simulated)",
    )


def oscillator_figure(out_dir: Path, name: str, pooled: Deviation, theory: np.ndarray, trials: int,
                      duration_s: float) -> Path:
    """``oscillator_<name>.png``: pooled simulated OADEV with its CI against the theoretical ADEV."""
    return plot_deviations(
        {f"{name}: simulated OADEV, {trials} trials pooled (68.3 % CI)": pooled},
        out_dir / f"oscillator_{name}.png",
        theory={"adev_theory (h-coefficients + drift)": (pooled.tau_s, theory)},
        ylabel="Allan deviation",
        title=f"{name} preset: {trials} x {duration_s:.0f} s at 1 Hz",
    )


def mask_figure(out_dir: Path, metric: str, ours: Deviation, table: Table, n_points: int, ylabel: str) -> Path:
    """``cs5071a_<metric>.png``: the Cs 5071A record's MTIE or TDEV, Stable32's table and the primary
    reference clocks' masks (G.8272 PRTC-A/B, G.811) drawn from 0.11 s to the last tau (at least 1e5 s)."""
    grid = np.logspace(np.log10(0.11), np.log10(max(1e5, float(ours.tau_s[-1]))), 400)
    return plot_with_references(
        {f"Cs 5071A {metric.upper()} (ours)": ours},
        {f"{metric.upper()}, Stable32 table": (table["tau"], table["dev"])},
        out_dir / f"cs5071a_{metric}.png",
        ylabel=ylabel,
        title=f"Cs 5071A vs H-maser ({n_points} s): {metric.upper()} against ITU-T masks",
        masks={clock: (grid, MASKS[clock].limit_s(metric, grid)) for clock in PRIMARY_CLOCKS},
    )
