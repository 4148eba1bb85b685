"""TheoH, the hybrid statistic: the overlapping ADEV below 10 % of the record, TheoBR from there on.

A statistic made of two others, so the engine's one-kernel pipeline does not fit it: its registry entry
(``STATISTICS["theoh"]``) carries :func:`theoh` as its ``combine`` and :func:`theoh_grid` as its ``grid``,
and both parts go through :func:`chronofuse.analysis.stability.engine.compute` (noise identification,
EDF and interval each by its own part: Greenhall's OADEV EDF below ``k``, Theo1's above). Gaps are
interpolated first (TheoBR's rule), so both parts read the same record.
"""

from __future__ import annotations

import numpy as np

from chronofuse.analysis.stability.convert import fill_gaps
from chronofuse.analysis.stability.factors import averaging_factors
from chronofuse.analysis.stability.kernels_allan import max_m_oadev
from chronofuse.analysis.stability.kernels_theobr import max_m_theobr, theoh_split_s
from chronofuse.analysis.stability.result import Deviation

__all__ = ["theoh", "theoh_grid"]


def theoh_grid(kind: str, n_points: int, rate_hz: float) -> np.ndarray:
    """TheoH's averaging times (s): the ``kind`` grid's ``m tau0`` below ``k``, then ``0.75 m tau0`` (m even)
    from ``k`` on, shape (k,)."""
    tau0 = 1.0 / rate_hz
    k = theoh_split_s(n_points, tau0)
    low = averaging_factors(max_m_oadev(n_points), kind) * tau0
    high = averaging_factors(max_m_theobr(n_points), kind)
    high = 0.75 * high[high % 2 == 0] * tau0
    return np.concatenate((low[low < k], high[high >= k]))


def theoh(compute, x_s, rate_hz: float, tau_s, *, ci: float = 0.683, bias_correction: bool = True,
          gap_rule: str | None = None) -> Deviation:
    """TheoH at ``tau_s`` (k,): OADEV where ``tau < k``, TheoBR where ``tau >= k`` (``k`` = 10 % of the record),
    each part by ``compute`` (the engine's :func:`~chronofuse.analysis.stability.engine.compute`, which passes
    itself: the engine imports the statistics' table, so the table's members may not import the engine)."""
    x = np.asarray(x_s, dtype=float)
    filled = 0
    if np.isnan(x).any():
        x, filled = fill_gaps(x)
    taus = np.asarray(tau_s, dtype=float)
    k = theoh_split_s(x.size, 1.0 / rate_hz)
    low, high = taus[taus < k], taus[taus >= k]
    parts = [compute("oadev", x, rate_hz, low, ci=ci)] if low.size else []
    if high.size:
        parts.append(compute("theobr", x, rate_hz, high, ci=ci))
    if not parts:
        raise ValueError(f"tau_s == {taus.tolist()}, no averaging time for theoh")
    join = {name: np.concatenate([getattr(p, name) for p in parts])
            for name in ("tau_s", "dev", "n", "alpha", "edf", "lo", "hi")}
    methods = np.concatenate([p.alpha_method for p in parts])
    return Deviation(statistic="theoh", alpha_method=methods, ci=float(ci), bias_corrected=False, filled=int(filled),
                     skipped=0, gap_rule="fill", **join)
