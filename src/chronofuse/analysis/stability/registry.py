"""The registry of stability statistics: how the engine computes each one (kernel, range, gaps, EDF, bias).

Kept apart from the engine so that the averaging-time helpers (``taus.tau_grid``) can size a grid to a
statistic's range without importing the engine.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from chronofuse.analysis.stability.bias import htotdev_bias, totdev_bias
from chronofuse.analysis.stability.hybrid import theoh, theoh_grid
from chronofuse.analysis.stability.kernels_allan import (
    adev_raw,
    hdev_raw,
    max_m_adev,
    max_m_hdev,
    max_m_mdev,
    max_m_oadev,
    max_m_ohdev,
    max_m_tdev,
    mdev_raw,
    oadev_raw,
    ohdev_raw,
    tdev_raw,
)
from chronofuse.analysis.stability.kernels_theo import max_m_theo1, theo1_raw
from chronofuse.analysis.stability.kernels_theobr import max_m_theobr, theobr_raw
from chronofuse.analysis.stability.kernels_tie import max_m_mtie, max_m_tie_rms, mtie_raw, tie_rms_raw
from chronofuse.analysis.stability.kernels_total import (
    htotdev_raw,
    max_m_htotdev,
    max_m_mtotdev,
    max_m_totdev,
    max_m_ttotdev,
    mtotdev_raw,
    totdev_raw,
    ttotdev_raw,
)
from chronofuse.validation import check_choice, check_scalar

__all__ = ["StatisticSpec", "STATISTICS", "GAP_POLICIES", "EDF_FAMILIES"]

GAP_POLICIES = ("skip", "fill")
# What a Deviation reports as its gap rule: "samples" (a term is skipped when one of its own samples is
# missing), "span" (when any sample it spans is: the rule for phase integrated from frequency), "window"
# (MTIE: a window's extremes over the samples present in it) or "fill" (gaps interpolated).
GAP_RULES = ("samples", "span", "window", "fill")
EDF_FAMILIES = ("greenhall", "totdev", "mtotdev", "htotdev", "theo1", "none")

FILL = ("fill",)



Kernel = Callable[[np.ndarray, np.ndarray, float], tuple[np.ndarray, np.ndarray]]
BiasFunction = Callable[[np.ndarray, np.ndarray, int], np.ndarray]


@dataclass(frozen=True)
class StatisticSpec:
    """How the engine computes one statistic.

    Attributes
    ----------
    name : str
        Registry key (``"adev"``, ...).
    kernel : callable
        Raw kernel ``(x (N,), m (k,), tau0_s) -> (dev (k,), n (k,))``, no bias correction.
    max_m : callable
        Largest valid averaging factor for N phase points.
    gaps : str
        ``"skip"`` (the kernel skips terms by ``gap_rule``) or ``"fill"`` (the engine interpolates first).
    tau_factor : float
        ``tau = tau_factor * m * tau0`` (0.75 for Theo1, 1 otherwise).
    m_step : int
        Averaging factors must be multiples of this (2 for Theo1).
    edf_family : str
        One of ``EDF_FAMILIES``; ``"none"`` for TIE rms and MTIE (no chi-square interval).
    noise_dmax : int
        Largest number of differences in the lag-1 ACF noise identification (3: Hadamard family).
    bias : callable or None
        ``(alpha (k,), m (k,), N) -> factor (k,)`` multiplying the raw deviation, or None.
    gap_rule : str
        One of ``GAP_RULES``: the default rule, reported on every result.
    gap_rules : tuple of str
        The rules a caller may choose (``compute(..., gap_rule=...)``); the default first. Kernels of
        statistics with more than one take it as their ``gap_rule`` keyword.
    overlapping : bool
        The statistic averages overlapping terms (all but ADEV and HDEV): its B1 noise identification
        divides by the overlapping Allan variance.
    combine : callable or None
        For a statistic made of others (TheoH): ``combine(compute, x_s, rate_hz, tau_s, ci=,
        bias_correction=, gap_rule=) -> Deviation``, which ``compute`` calls (passing itself) instead of its
        own pipeline.
    grid : callable or None
        ``grid(kind, n_points, rate_hz) -> tau_s`` for a statistic whose averaging times are not
        ``tau_factor m / rate_hz`` on one grid of factors (TheoH).
    """

    name: str
    kernel: Kernel
    max_m: Callable[[int], int]
    gaps: str
    tau_factor: float = 1.0
    m_step: int = 1
    edf_family: str = "greenhall"
    noise_dmax: int = 2
    bias: BiasFunction | None = None
    gap_rule: str = "samples"
    overlapping: bool = True
    gap_rules: tuple[str, ...] = ("samples", "span")
    combine: Callable | None = None
    grid: Callable | None = None

    def __post_init__(self):
        check_choice(self.gaps, "gaps", GAP_POLICIES)
        check_choice(self.edf_family, "edf_family", EDF_FAMILIES)
        check_choice(self.gap_rule, "gap_rule", GAP_RULES)
        if (self.gaps == "fill") != (self.gap_rule == "fill"):
            raise ValueError(f"gap_rule == {self.gap_rule!r} does not go with gaps == {self.gaps!r}")
        for rule in self.gap_rules:
            check_choice(rule, "gap_rules", GAP_RULES)
        if self.gap_rules[0] != self.gap_rule:
            raise ValueError(f"gap_rules == {self.gap_rules}, must start with the default gap_rule {self.gap_rule!r}")
        check_scalar(self.tau_factor, "tau_factor", min_val=0, include_min=False)
        check_scalar(self.m_step, "m_step", min_val=1, integer=True)


STATISTICS: dict[str, StatisticSpec] = {
    spec.name: spec
    for spec in (
        StatisticSpec("adev", adev_raw, max_m_adev, "skip", overlapping=False),
        StatisticSpec("oadev", oadev_raw, max_m_oadev, "skip"),
        StatisticSpec("mdev", mdev_raw, max_m_mdev, "skip"),
        StatisticSpec("tdev", tdev_raw, max_m_tdev, "skip"),
        StatisticSpec("hdev", hdev_raw, max_m_hdev, "skip", noise_dmax=3, overlapping=False),
        StatisticSpec("ohdev", ohdev_raw, max_m_ohdev, "skip", noise_dmax=3),
        StatisticSpec(
            "totdev", totdev_raw, max_m_totdev, "fill", edf_family="totdev", bias=totdev_bias, gap_rule="fill", gap_rules=FILL
        ),
        StatisticSpec("mtotdev", mtotdev_raw, max_m_mtotdev, "fill", edf_family="mtotdev", gap_rule="fill", gap_rules=FILL),
        StatisticSpec("ttotdev", ttotdev_raw, max_m_ttotdev, "fill", edf_family="mtotdev", gap_rule="fill", gap_rules=FILL),
        StatisticSpec(
            "htotdev", htotdev_raw, max_m_htotdev, "fill", edf_family="htotdev", noise_dmax=3, bias=htotdev_bias,
            gap_rule="fill", gap_rules=FILL,
        ),
        StatisticSpec("theo1", theo1_raw, max_m_theo1, "fill", tau_factor=0.75, m_step=2, edf_family="theo1",
                      gap_rule="fill", gap_rules=FILL),
        StatisticSpec("theobr", theobr_raw, max_m_theobr, "fill", tau_factor=0.75, m_step=2, edf_family="theo1",
                      gap_rule="fill", gap_rules=FILL),
        StatisticSpec("theoh", theobr_raw, max_m_theobr, "fill", edf_family="theo1", gap_rule="fill", gap_rules=FILL,
                      combine=theoh, grid=theoh_grid),
        StatisticSpec("tie_rms", tie_rms_raw, max_m_tie_rms, "skip", edf_family="none"),
        StatisticSpec("mtie", mtie_raw, max_m_mtie, "skip", edf_family="none", gap_rule="window", gap_rules=("window",)),
    )
}
