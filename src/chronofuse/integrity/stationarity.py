"""Did the noise change after training? A screen of the tested stretch against the training stretch, and the
false-alarm rate of a clock product over the stations where nothing happened.

A noise model fitted once is only as good as the noise is stationary. On the GRG clock product the excess
alarms after training (3.7 % against 1 %) sit in stations whose second differences, 1 h 45 min after the
training stretch, have a mean square 2.6 to 1600 times the training's (``docs/integrity/clock_products.md``).
:func:`noise_change` measures that ratio and its significance; :func:`false_alarm_summary` counts alarms
over the stations with no clock event and no significant noise change, the stations on which the detector's
H0 can hold.

The test: under H0 (same noise), the mean squares of ``m1`` training and ``m2`` later differences are
``r(0) chi2(n_i) / n_i`` with Bartlett's equivalent degrees of freedom ``n_i``
(:func:`chronofuse.integrity.detector.effective_squares`, the differences being MA(2)), so their ratio is
approximately ``F(n2, n1)``; the one-sided p-value of an increase is ``P(F > ratio)`` (the F test of two
variances, NIST/SEMATECH e-Handbook 1.3.5.9, with equivalent degrees of freedom).
"""

from __future__ import annotations

import numpy as np

from chronofuse.integrity.detector import effective_squares

#: One-sided level of :func:`noise_change` below which a station's noise counts as changed after training.
#: At 1 %, about one station in a hundred is set aside under H0 (its alarms then miss the summary).
NOISE_CHANGE_ALPHA = 0.01


def noise_change(train_df, test_df, r) -> tuple[float, float]:
    """``(ratio, p_value)``: the mean square of the later differences ``test_df`` over that of the training
    differences ``train_df`` (NaN = missing), and the one-sided F-test p-value of an increase (module
    docstring). ``r`` is the fitted ``r(0..2)`` (for the differences' correlation). NaN, NaN when either
    stretch has no difference."""
    from scipy import stats

    a = np.asarray(train_df, dtype=np.float64)
    b = np.asarray(test_df, dtype=np.float64)
    a, b = a[np.isfinite(a)], b[np.isfinite(b)]
    if a.size == 0 or b.size == 0 or not np.any(a):
        return float("nan"), float("nan")
    ratio = float(np.mean(b**2) / np.mean(a**2))
    n_train, n_test = effective_squares(a.size, r), effective_squares(b.size, r)
    return ratio, float(stats.f.sf(ratio, n_test, n_train))


def false_alarm_summary(rows: list[dict], pfa: float, alpha: float = NOISE_CHANGE_ALPHA) -> dict:
    """Alarms over the tested epochs of the stations with no clock event and no noise change (``p`` of
    :func:`noise_change` at or above ``alpha``), from the rows of
    :func:`chronofuse.integrity.products.clock_product_document`.

    Returns ``no_event`` (station names), ``clock_event`` and ``noise_changed`` (names set aside),
    ``untested`` (no test), ``n_tested``, ``n_alarms`` and ``rate`` over ``no_event``, ``nominal`` (``pfa``),
    ``alpha``; and the same count over every station without a clock event (``all_n_tested``,
    ``all_n_alarms``, ``all_rate``), so what the screen sets aside is visible.
    """
    tested = [r for r in rows if r.get("n_tested", 0) > 0 and r.get("noise_change") is not None]
    clock = [r for r in tested if r["clock_events"]]
    rest = [r for r in tested if not r["clock_events"]]
    changed = [r for r in rest if np.isfinite(r["noise_change"]["p_value"]) and r["noise_change"]["p_value"] < alpha]
    quiet = [r for r in rest if r not in changed]

    def rate(group):
        n = sum(r["n_tested"] for r in group)
        k = sum(r["n_alarms"] for r in group)
        return n, k, (k / n if n else float("nan"))

    n, k, p = rate(quiet)
    n_all, k_all, p_all = rate(rest)
    return {
        "no_event": [r["station"] for r in quiet],
        "clock_event": [r["station"] for r in clock],
        "noise_changed": [r["station"] for r in changed],
        "untested": [r["station"] for r in rows if r not in tested],
        "n_tested": n, "n_alarms": k, "rate": p, "nominal": float(pfa), "alpha": float(alpha),
        "all_n_tested": n_all, "all_n_alarms": k_all, "all_rate": p_all,
    }


__all__ = ["NOISE_CHANGE_ALPHA", "false_alarm_summary", "noise_change"]
