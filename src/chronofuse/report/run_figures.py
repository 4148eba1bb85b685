"""The figures of a ``chronofuse run`` report folder (:mod:`chronofuse.experiments.main_job` computes, these draw)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from chronofuse.analysis.stability.result import Deviation
from chronofuse.report.figures import plot_deviations, plot_time_error


def write_run_figures(
    out: Path,
    t_s: np.ndarray,
    pps_s: dict[str, np.ndarray],
    receiver_scenario: str,
    oscillator_name: str,
    oscillator_x_s: np.ndarray,
    oscillator_adev: Deviation,
    theory: tuple[np.ndarray, np.ndarray],
    receiver_devs: dict[str, dict[str, Deviation]],
    mask_limits: dict[str, tuple[np.ndarray, np.ndarray]],
    output_devs: dict[str, Deviation] | None = None,
) -> list[Path]:
    """Write the run's PNGs into ``out``; return their paths in the order written.

    ``time_error.png`` (each receiver's qErr-corrected 1PPS time error ``pps_s``, label -> (steps,) s),
    ``oscillator_phase.png`` (the free-running phase ``oscillator_x_s``), ``adev.png`` (the oscillator's
    OADEV with ``theory`` = (tau_s, ADEV), and each receiver's OADEV when computed), and ``mtie.png`` /
    ``tdev.png`` when the receivers' deviations include them, with the ``mask_limits`` whose label ends in
    that statistic, and the disciplined output's curve of ``output_devs`` (statistic -> Deviation) beside the
    receivers'; MTIE and TDEV in ns.
    """
    files = [out / "time_error.png"]
    plot_time_error(t_s, pps_s, files[-1], title=f"1PPS time error after qErr correction ({receiver_scenario})")
    files.append(out / "oscillator_phase.png")
    plot_time_error(t_s, {f"{oscillator_name} free run": oscillator_x_s}, files[-1],
                    title="Free-running oscillator phase")
    adev_curves = {f"{oscillator_name} OADEV": oscillator_adev}
    adev_curves.update({f"{label} OADEV": devs["oadev"] for label, devs in receiver_devs.items() if "oadev" in devs})
    files.append(out / "adev.png")
    plot_deviations(adev_curves, files[-1], theory={f"{oscillator_name} theory": theory},
                    ylabel="Allan deviation", title="Stability: oscillator (with theory) and receivers")
    for stat, ylabel in (("mtie", "MTIE (ns)"), ("tdev", "TDEV (ns)")):
        curves = {label: devs[stat] for label, devs in receiver_devs.items() if stat in devs}
        if stat in (output_devs or {}):
            curves["disciplined output"] = output_devs[stat]
        if curves:
            files.append(out / f"{stat}.png")
            limits = {k: v for k, v in mask_limits.items() if k.endswith(stat)}
            who = "Receivers and the disciplined output" if output_devs else "Receivers"
            plot_deviations(curves, files[-1], limits=limits, ylabel=ylabel, title=f"{who}: {stat.upper()}", scale=1e9)
    return files
